"""SOS certificate of a level set: the largest rho with V' < 0 on {V <= rho} minus the equilibrium.

For a quadratic ``V(x) = d' P d`` (``d = x - x_eq``) and a field whose ``V'`` is polynomial after
*recasting*, one semidefinite program (cvxpy, solver Clarabel), no bisection::

    maximise rho  s.t.  (d'd)^k (V - rho) + lambda(y) V'(y) + sum_j mu_j(y) h_j(y) - sigma_1(y) u
                        is a sum of squares,  sigma_1 SOS,  lambda, mu_j free polynomials,

in the variables ``y = (d, u)`` (``d`` whitened: ``x = x_eq + M d`` with ``M'PM ~ I``). If
``V'(y) = 0`` at some ``d != 0`` of the recast variety ``{h_j = 0, u >= 0}`` then ``(d'd)^k (V - rho) >= 0``, i.e. ``V >= rho``; since ``V' < 0`` near the
equilibrium (negative-definite linear part, checked), ``V' < 0`` on ``{V < rho} \\ {x_eq}``.

**Recasting** (:func:`recast_field`): the one recast of :func:`roa.proof.polynomial_field`
(``b^(k/2) = (t0 + u)^k`` with ``u = sqrt(b) - t0 >= 0``, the field times its positive
denominator: :mod:`roa.proof._recast`). For the IPC, ``phi0(w) = w (1 + w^2)^(-3/2)`` is
``w / (1 + u)^3`` exactly, so the recast costs nothing in rho; only the degree of the relaxation
does. Odd fields split the program by the symmetry ``d -> -d`` (:func:`sos_level`).

The result is a value with the solver's status; ``rho`` is a *candidate* until checked by
:func:`roa.proof.validate_level` (the SDP is solved in floating point).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Any

import numpy as np
import sympy as sp

from roa.errors import RoaInputError
from roa.lyapunov import QuadraticLyapunov
from roa.model._backend import namespace
from roa.model._system import System
from roa.search._sdp import (
    MAX_GRAM_BLOCK,
    MAX_SDP_BYTES,
    Program,
    is_even,
    monomials,
    multipliers,
    poly_of,
    sdp_bytes,
    solve,
    sym_blocks,
    sym_keep,
)
from roa.status import SosStatus

SYMMETRY = ("auto", True, False)


@dataclass(frozen=True)
class SOSResult:
    """Outcome of the SOS program: ``level`` is meaningful only with ``status == "solved"``."""

    status: SosStatus
    level: float | None
    solver_status: str
    seconds: float
    recast: str
    sizes: dict[str, Any] = field(default_factory=dict)
    message: str = ""

    def to_json(self) -> dict[str, Any]:
        return {"status": self.status.value, "level": self.level, "method": "sos",
                "solver_status": self.solver_status, "seconds": round(self.seconds, 3),
                "recast": self.recast, "sizes": self.sizes, "message": self.message}  # fmt: skip


RECASTS = ("exact", "enclosure")


def _nonneg(e: sp.Expr) -> bool:
    """Structural sufficient check that ``e >= 0`` (sums/products of squares and of c >= 0)."""
    if e.is_number:
        return bool(e >= 0)
    if isinstance(e, sp.Pow):
        return (e.exp.is_integer and e.exp % 2 == 0) or (_nonneg(e.base) and e.exp.is_positive)
    if isinstance(e, sp.Add | sp.Mul):
        return all(_nonneg(a) for a in e.args)
    return False


def _at_least_one(base: sp.Expr) -> bool:
    """Sufficient check that ``base >= 1``: a constant >= 1 plus nonnegative terms."""
    const, rest = base.as_independent(*base.free_symbols, as_Add=True)
    return bool(const >= 1) and _nonneg(rest)


@dataclass
class RecastField:
    """The field in variables ``y`` (``x = c + M y``) made polynomial in ``(y, aux)``: ``f`` is
    ``positive`` x the field, ``positive > 0`` wherever the constraints hold (so ``grad V . f``
    has the sign of ``V'``)."""

    d: list[sp.Symbol]
    aux: list[sp.Symbol]
    dx: list[sp.Expr]  # x - c as linear forms in y
    f: list[sp.Expr]  # positive x the field f(x(y)) (x coordinates), polynomial in (y, aux)
    equalities: list[sp.Expr]
    nonnegative: list[sp.Expr]
    description: str
    positive: sp.Expr = sp.Integer(1)
    V: sp.Expr = sp.Integer(0)  # V and Vdot = positive x V' in y (:func:`recast` only)
    Vdot: sp.Expr = sp.Integer(0)


NONSMOOTH = (sp.Min, sp.Max, sp.Abs, sp.Piecewise, sp.sign, sp.Heaviside)
NO_TRIG = ("the SOS level proposer takes fields without sin/cos (the level program has no Taylor "
           "bounds): no SOS candidate here, the sampled search proposes the level (the exact SOS "
           "validator recasts sin, cos and rational terms itself)")  # fmt: skip


def recast_field(system: System, M: np.ndarray, center: np.ndarray, *, mode: str = "exact"
                 ) -> RecastField:  # fmt: skip
    """``f(c + M y)`` made polynomial: ``exact`` by the one recast (module docstring, **Recasting**;
    no sin/cos: the level program has no Taylor bounds), then ``d = M y``; ``enclosure`` with ``t = b^(k/2)
    in [0, 1]`` for ``k < 0`` and ``b >= 1`` (a relaxation: it loses the relation between t and
    b). Raises :class:`RoaInputError` for what cannot be made polynomial (saturation
    ``min``/``max``/``clip``/``abs``, sin/cos, other functions, ...)."""
    if mode not in RECASTS:
        raise RoaInputError(f"recast mode {mode!r}: allowed {', '.join(RECASTS)}")
    n = len(center)
    d = list(sp.symbols(f"y0:{n}", real=True))
    dx = [sum(sp.Float(float(M[i, j]), 17) * d[j] for j in range(n) if M[i, j] != 0)
          for i in range(n)]  # fmt: skip
    x = [dx[i] + sp.Float(float(center[i]), 17) if center[i] != 0 else dx[i] for i in range(n)]
    f = system.field(0.0, x, namespace("sympy"))
    f = [sp.powsimp(sp.sympify(fi)) for fi in f]
    if any(fi.has(*NONSMOOTH) for fi in f):
        raise RoaInputError("the field uses min/max/clip/abs (saturation): SOS needs a polynomial field; use "
                            "method='interval' (sampled search + interval validation)")  # fmt: skip
    if mode == "exact":
        return _exact_field(system, d, dx, center)
    aux: list[sp.Symbol] = []
    boxes, subs, notes = [], {}, []
    atoms = set().union(*(fi.atoms(sp.Pow) for fi in f))
    for p in sorted(atoms, key=sp.default_sort_key):
        e = p.exp
        if not (isinstance(e, sp.Rational) and e.q == 2):
            continue
        base, k = p.base, int(e.p)
        if not base.is_polynomial(*d) or k > 0 or not _at_least_one(base):
            raise RoaInputError(f"enclosure needs b^(k/2) with k < 0 and b >= 1 polynomial, "
                                f"got {p}")  # fmt: skip
        t = sp.Symbol(f"t{len(aux)}", real=True)
        aux.append(t)
        boxes += [t, 1 - t]
        subs[p] = t
        notes.append(f"{t} = ({base})^({k}/2) enclosed in [0, 1]")
    f = [sp.expand(fi.xreplace(subs)) for fi in f]
    if not all(fi.is_polynomial(*d, *aux) for fi in f):
        raise RoaInputError("the enclosure takes polynomial fields with b^(k/2) terms only; use "
                            "the exact recast")  # fmt: skip
    return RecastField(d, aux, dx, f, [], boxes, "; ".join(notes) or "polynomial (no recast)")


def _exact_field(system: System, d: list[sp.Symbol], dx: list[sp.Expr], center: np.ndarray
                 ) -> RecastField:  # fmt: skip
    """The one recast (:func:`roa.proof.polynomial_field`) in ``d = x - c``, then
    ``d = M y`` (floats: the programs only propose)."""
    from fractions import Fraction

    from roa.proof._recast import polynomial_field
    from roa.proof._sos_check import NotPolynomial, sym_poly

    try:
        pf = polynomial_field(system, tuple(Fraction(float(c)) for c in center))
    except NotPolynomial as exc:
        raise RoaInputError(f"no SOS candidate here (the sampled search proposes the level): "
                            f"{exc}") from None  # fmt: skip
    if pf.angles:
        raise RoaInputError(NO_TRIG)
    n = len(d)
    aux = list(pf.gens[n:])
    to_y = dict(zip(pf.gens[:n], dx, strict=True))

    def fl(p: Any) -> sp.Expr:
        return sp.expand(p.as_expr().xreplace(to_y))

    eqs, ineqs = pf.root_constraints()
    polys = [fl(sym_poly(h, pf.gens)) for _, h in eqs + ineqs]
    notes = [w for w, _ in eqs]
    if pf.denominator != "1":
        notes.append(f"the field multiplied by {pf.denominator} > 0")
    return RecastField(d, aux, dx, [fl(F) for F in pf.F], polys[: len(eqs)], polys[len(eqs):],
                       "; ".join(notes) or "polynomial (no recast)", fl(pf.Lpos))  # fmt: skip


def recast(system: System, lyap: QuadraticLyapunov, *, mode: str = "exact") -> RecastField:
    """Symbolic ``V'`` in whitened variables ``y`` (``x = x_eq + M y``, ``V = y' (M'PM) y ~ |y|^2``),
    made polynomial by :func:`recast_field` (times its positive factor: the sign of ``V'``)."""
    n = lyap.n
    M = np.linalg.inv(np.linalg.cholesky(lyap.P).T)
    rf = recast_field(system, M, lyap.center, mode=mode)
    dx, f = rf.dx, rf.f
    P = [[sp.Float(float(lyap.P[i, j]), 17) for j in range(n)] for i in range(n)]
    V = sp.expand(sum(dx[i] * P[i][j] * dx[j] for i in range(n) for j in range(n)))
    Vdot = sp.expand(2 * sum(dx[i] * P[i][j] * f[j] for i in range(n) for j in range(n)))
    return replace(rf, V=V, Vdot=Vdot)


def _too_large(block: int, nvars: int, t0: float) -> SOSResult:
    return SOSResult(SosStatus.TOO_LARGE, None, "not built", time.perf_counter() - t0, "",
                     sizes={"gram_block": block, "variables": nvars},
                     message=f"the SOS program needs a Gram block of {block} monomials in "
                     f"{nvars} variables (at most {MAX_GRAM_BLOCK} here, and an estimated "
                     f"{sdp_bytes(block) / 2**30:.3g} GiB of solver memory, at most "
                     f"{MAX_SDP_BYTES / 2**30:.3g}): not built; the level "
                     "comes from the sampled search instead")  # fmt: skip


def sos_level(system: System, lyap: QuadraticLyapunov, *, recast_mode: str = "exact",
              multiplier_degree: int | None = None, solver_options: dict[str, Any] | None = None,
              symmetry: str | bool = "auto", aux_degree: int | None = None) -> SOSResult:  # fmt: skip
    """Largest rho certified by the SOS program of the module docstring (status-carrying value).

    Parameters
    ----------
    system, lyap : System, QuadraticLyapunov
        Autonomous system with an equilibrium; quadratic candidate centred on it.
    multiplier_degree : int, optional
        Degree of lambda (default: the smallest making the total degree even, at least 2 for a
        quartic V').
    recast_mode : {"exact", "enclosure"}
        How non-polynomial factors are handled (see :func:`recast`).
    solver_options : dict, optional
        Passed to Clarabel through cvxpy (e.g. ``{"max_iter": 2}`` to force a failure).
    symmetry : {"auto", True, False}
        Odd fields (``f(x_eq - d) = -f(x_eq + d)``, e.g. the IPC's flat closed loop) make every
        polynomial of the program even in ``d`` (auxiliary variables of even bases are even).
        Averaging any certificate with its reflection ``d -> -d`` gives one with even free
        multipliers and Gram matrices block-diagonal in (even, odd) monomials of ``d``, so the
        reduced program has the same optimum with smaller blocks. ``"auto"`` uses it when the
        coefficients show the symmetry (checked exactly on the assembled polynomials).
    aux_degree : int, optional
        Largest degree of the auxiliary variables in Gram bases and multipliers (default: no
        cap). A cap is a restriction of the relaxation: rho can only decrease.
    """
    t0 = time.perf_counter()
    if system.time_varying:
        raise RoaInputError(f"system {system.name!r} is time-varying: no equilibrium to certify")
    least = math.comb(system.n + 2, 2)  # V' has degree >= 2: the Gram basis holds degree <= 2
    if least > MAX_GRAM_BLOCK or sdp_bytes(least) > MAX_SDP_BYTES:
        return _too_large(least, system.n, t0)
    try:
        rc = recast(system, lyap, mode=recast_mode)
    except (ValueError, sp.PolynomialError) as exc:
        return SOSResult(SosStatus.NOT_POLYNOMIAL, None, "not run", time.perf_counter() - t0, "",
                         message=str(exc))  # fmt: skip
    gens, nd = rc.d + rc.aux, len(rc.d)
    nv = len(gens)
    Vd = poly_of(rc.Vdot, gens)
    deg_vd = max(sum(m) for m in Vd)
    multiplier_degree = 2 - deg_vd % 2 if multiplier_degree is None else multiplier_degree
    total = deg_vd + multiplier_degree + (deg_vd + multiplier_degree) % 2
    k = (total - 2) // 2
    dd = sum(x**2 for x in rc.d)  # whitened: d'd ~ V
    A = poly_of(sp.expand(dd**k * rc.V), gens)
    B = poly_of(sp.expand(dd**k), gens)
    eq_polys, nn_polys = ([poly_of(h, gens) for h in hs] for hs in (rc.equalities, rc.nonnegative))
    if symmetry not in SYMMETRY:
        raise RoaInputError(f"symmetry {symmetry!r}: allowed {', '.join(map(str, SYMMETRY))}")
    even = is_even([Vd, A, B, *eq_polys, *nn_polys], nd)
    if symmetry is True and not even:
        raise RoaInputError("symmetry=True needs V' and the recast constraints even in x - x_eq")
    use_sym = even and symmetry in ("auto", True)
    blocks = partial(sym_blocks, nd=nd, sym=use_sym, aux_degree=aux_degree)  # y -> -y: even/odd
    keep = partial(sym_keep, nd=nd, sym=use_sym, aux_degree=aux_degree)  # free: even ones only
    biggest = max(len(b) for b in blocks(monomials(nv, total // 2)))
    if biggest > MAX_GRAM_BLOCK or sdp_bytes(biggest) > MAX_SDP_BYTES:
        return _too_large(biggest, nv, t0)
    prog, rho = Program(nv), Program.scalar()
    prog.free(
        Vd, keep(monomials(nv, multiplier_degree))
    )  # (d'd)^k (V - rho) + lambda V' + mu h - sum_j sigma_j g_j - sigma0
    grams = multipliers(prog, total, eq_polys, nn_polys, blocks, keep)
    prog.const(A)
    prog.linear([{m: -c for m, c in B.items()}], rho)
    sizes = {"variables": [str(g) for g in gens], "degree": total,
             "gram_sizes": [len(b) for b, _ in grams],
             "symmetry": "even/odd blocks in x - x_eq" if use_sym else "none",
             "equality_rows": len(prog.rows), "multiplier_degree": multiplier_degree, "k": k}  # fmt: skip
    res = solve(prog.problem(rho), options=solver_options)
    if res.status.startswith("solver error"):
        return SOSResult(SosStatus.FAILED, None, res.status, time.perf_counter() - t0,
                         rc.description, sizes, "the solver failed: no certificate")  # fmt: skip
    status, msg = {
        "optimal": ("solved", "SOS candidate level; certified only after interval validation"),
        "inaccurate": ("inaccurate", "solver reported an inaccurate solution: not a certificate"),
        "infeasible": ("infeasible", "no certificate at this degree"),
        "error": ("failed", f"solver status {res.status}: no certificate"),
    }[res.group]
    value = float(rho.value) if res.usable and rho.value is not None else None
    return SOSResult(SosStatus(status), value, res.status, time.perf_counter() - t0,
                     rc.description, sizes, msg)  # fmt: skip
