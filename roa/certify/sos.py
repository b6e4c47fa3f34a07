"""SOS certificate of a level set: the largest rho with V' < 0 on {V <= rho} minus the equilibrium.

For a quadratic ``V(x) = d' P d`` (``d = x - x_eq``) and a field whose ``V'`` is polynomial after
*recasting*, one semidefinite program (cvxpy, solver Clarabel), no bisection::

    maximise rho  s.t.  (d'd)^k (V - rho) + lambda(y) V'(y) + sum_j mu_j(y) h_j(y) - sigma_1(y) s
                        is a sum of squares,  sigma_1 SOS,  lambda, mu_j free polynomials,

in the variables ``y = (d, s)`` (``d`` whitened: ``x = x_eq + M d`` with ``M'PM ~ I``). If ``V'(y) = 0`` at some ``d != 0`` of the recast variety
``{h_j = 0, s >= 0}`` then ``(d'd)^k (V - rho) >= 0``, i.e. ``V >= rho``; since ``V' < 0`` near the
equilibrium (negative-definite linear part, checked), ``V' < 0`` on ``{V < rho} \\ {x_eq}``.

**Recasting** (exact, no enclosure): every factor ``b(x)^(k/2)`` with ``k`` odd and ``b`` a
polynomial gets an auxiliary variable ``s = b^(-1/2)`` with ``s^2 b - 1 = 0`` and ``s >= 0``; then
``b^(k/2) = s^(-k)`` for ``k < 0`` and ``b^((k+1)/2) s`` for ``k > 0``. For the IPC,
``phi0(w) = w (1 + w^2)^(-3/2) = w s^3`` exactly, so the recast costs nothing in rho; only the
degree of the relaxation does (reported by the gap to the sampled optimum).

The result is a value with the solver's status; ``rho`` is a *candidate* until checked by
:func:`roa.certify.validate.validate_level` (the SDP is solved in floating point).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sps
import sympy as sp

from roa.backend import namespace
from roa.lyapunov import QuadraticLyapunov
from roa.system import System

SOS_STATUSES = ("solved", "inaccurate", "infeasible", "failed", "not_polynomial")


@dataclass(frozen=True)
class SOSResult:
    """Outcome of the SOS program: ``rho`` is meaningful only with ``status == "solved"``."""

    status: str
    rho: float | None
    solver_status: str
    seconds: float
    recast: str
    sizes: dict[str, Any] = field(default_factory=dict)
    message: str = ""

    def to_json(self) -> dict[str, Any]:
        return {
            "status": self.status,
            "level": self.rho,
            "method": "sos",
            "solver_status": self.solver_status,
            "seconds": round(self.seconds, 3),
            "recast": self.recast,
            "sizes": self.sizes,
            "message": self.message,
        }


@dataclass
class Recast:
    """Polynomial form of ``V'``: variables, ``V'``, equality constraints, nonnegative variables."""

    d: list[sp.Symbol]
    aux: list[sp.Symbol]
    V: sp.Expr
    Vdot: sp.Expr
    equalities: list[sp.Expr]
    nonnegative: list[sp.Expr]
    description: str


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


def recast(system: System, lyap: QuadraticLyapunov, *, mode: str = "exact") -> Recast:
    """Symbolic ``V'`` in whitened variables ``y`` (``x = x_eq + M y``, ``V = y' (M'PM) y ~ |y|^2``),
    made polynomial: ``exact`` with ``s = b^(-1/2)``, ``s^2 b = 1``, ``s >= 0``; ``enclosure`` with
    ``t = b^(k/2) in [0, 1]`` for ``k < 0`` and ``b >= 1`` (loses the relation between t and b).
    """
    if mode not in RECASTS:
        raise ValueError(f"recast mode {mode!r}: allowed {', '.join(RECASTS)}")
    n = lyap.n
    d = list(sp.symbols(f"y0:{n}", real=True))
    M = np.linalg.inv(np.linalg.cholesky(lyap.P).T)
    dx = [
        sum(sp.Float(float(M[i, j]), 17) * d[j] for j in range(n) if M[i, j] != 0) for i in range(n)
    ]
    x = [
        dx[i] + sp.Float(float(lyap.center[i]), 17) if lyap.center[i] != 0 else dx[i]
        for i in range(n)
    ]
    P = [[sp.Float(float(lyap.P[i, j]), 17) for j in range(n)] for i in range(n)]
    f = system.field(0.0, x, namespace("sympy"))
    V = sp.expand(sum(dx[i] * P[i][j] * dx[j] for i in range(n) for j in range(n)))
    f = [sp.powsimp(sp.sympify(fi)) for fi in f]
    aux: list[sp.Symbol] = []
    eqs: list[sp.Expr] = []
    boxes: list[sp.Expr] = []
    subs: dict[sp.Expr, sp.Expr] = {}
    notes = []
    atoms = set().union(*(fi.atoms(sp.Pow) for fi in f))
    for p in sorted(atoms, key=sp.default_sort_key):
        e = p.exp
        if not (isinstance(e, sp.Rational) and e.q == 2):
            continue
        base = p.base
        if not base.is_polynomial(*d):
            raise ValueError(f"cannot recast {p}: base is not polynomial")
        k = int(e.p)
        if mode == "enclosure":
            if k > 0 or not _at_least_one(base):
                raise ValueError(f"enclosure needs b^(k/2) with k < 0 and b >= 1, got {p}")
            t = sp.Symbol(f"t{len(aux)}", real=True)
            aux.append(t)
            boxes.append(t)
            boxes.append(1 - t)
            subs[p] = t
            notes.append(f"{t} = ({base})^({k}/2) enclosed in [0, 1]")
            continue
        s = next(
            (
                a
                for a, b in zip(aux, eqs, strict=True)
                if sp.expand(b - (a**2 * sp.expand(base) - 1)) == 0
            ),
            None,
        )
        if s is None:
            s = sp.Symbol(f"s{len(aux)}", real=True)
            aux.append(s)
            eqs.append(sp.expand(s**2 * sp.expand(base) - 1))
            boxes.append(s)
            notes.append(f"{s} = ({base})^(-1/2), {s}^2 ({base}) = 1, {s} >= 0")
        subs[p] = s ** (-k) if k < 0 else base ** ((k + 1) // 2) * s
    f = [fi.xreplace(subs) for fi in f]
    Vdot = sp.expand(2 * sum(dx[i] * P[i][j] * f[j] for i in range(n) for j in range(n)))
    if not Vdot.is_polynomial(*d, *aux):
        raise ValueError("V' is not polynomial after recasting half-integer powers")
    return Recast(d, aux, V, Vdot, eqs, boxes, "; ".join(notes) or "polynomial (no recast)")


# -- polynomial <-> coefficient vectors --------------------------------------------------------------
def _monomials(nvars: int, max_deg: int, min_deg: int = 0) -> list[tuple[int, ...]]:
    out = []
    for deg in range(min_deg, max_deg + 1):
        for c in itertools.combinations_with_replacement(range(nvars), deg):
            e = [0] * nvars
            for i in c:
                e[i] += 1
            out.append(tuple(e))
    return out


def _coeffs(expr: sp.Expr, gens: list[sp.Symbol]) -> dict[tuple[int, ...], float]:
    poly = sp.Poly(sp.expand(expr), *gens)
    return {m: float(c) for m, c in poly.terms() if c != 0}


def _add(a: tuple, b: tuple) -> tuple:
    return tuple(x + y for x, y in zip(a, b, strict=True))


class _Assembler:
    """Maps monomials to rows; collects sparse columns of the linear identity."""

    def __init__(self) -> None:
        self.rows: dict[tuple, int] = {}

    def row(self, m: tuple) -> int:
        if m not in self.rows:
            self.rows[m] = len(self.rows)
        return self.rows[m]

    def multiplier(self, poly: dict, basis: list[tuple]) -> tuple[list, list, list]:
        """Columns ``basis_k * poly`` for a free multiplier with coefficients on ``basis``."""
        r, c, v = [], [], []
        for k, b in enumerate(basis):
            for m, coef in poly.items():
                r.append(self.row(_add(m, b)))
                c.append(k)
                v.append(coef)
        return r, c, v

    def gram(self, basis: list[tuple], times: dict | None = None) -> tuple[list, list, list]:
        """Columns of ``sum_ij Q_ij b_i b_j * times`` for a symmetric Q (flattened row-major)."""
        times = times or {tuple([0] * len(basis[0])): 1.0}
        r, c, v = [], [], []
        nb = len(basis)
        for i in range(nb):
            for j in range(nb):
                bij = _add(basis[i], basis[j])
                for m, coef in times.items():
                    r.append(self.row(_add(bij, m)))
                    c.append(i * nb + j)
                    v.append(coef)
        return r, c, v


def _sparse(parts: tuple, nrows: int, ncols: int) -> sps.csr_matrix:
    r, c, v = parts
    return sps.csr_matrix((v, (r, c)), shape=(nrows, ncols))


def sos_level(
    system: System,
    lyap: QuadraticLyapunov,
    *,
    recast_mode: str = "exact",
    multiplier_degree: int | None = None,
    solver_options: dict[str, Any] | None = None,
) -> SOSResult:
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
    """
    import cvxpy as cp

    t0 = time.perf_counter()
    if system.time_varying:
        raise ValueError(f"system {system.name!r} is time-varying: no equilibrium to certify")
    try:
        rc = recast(system, lyap, mode=recast_mode)
    except (ValueError, sp.PolynomialError) as exc:
        return SOSResult(
            "not_polynomial", None, "not run", time.perf_counter() - t0, "", message=str(exc)
        )
    gens = rc.d + rc.aux
    nv = len(gens)
    Vd = _coeffs(rc.Vdot, gens)
    deg_vd = max(sum(m) for m in Vd)
    if multiplier_degree is None:
        multiplier_degree = 2 if deg_vd % 2 == 0 else 1
    total = deg_vd + multiplier_degree
    if total % 2:
        total += 1
    k = (total - 2) // 2
    dd = sum(x**2 for x in rc.d)  # whitened: d'd ~ V
    A = _coeffs(sp.expand(dd**k * rc.V), gens)
    B = _coeffs(sp.expand(dd**k), gens)
    asm = _Assembler()
    lam_basis = _monomials(nv, multiplier_degree)
    parts = {"lambda": asm.multiplier(Vd, lam_basis)}
    eq_polys = [_coeffs(h, gens) for h in rc.equalities]
    for j, h in enumerate(eq_polys):
        deg_h = max(sum(m) for m in h)
        parts[f"mu{j}"] = asm.multiplier(h, _monomials(nv, total - deg_h))
    half = total // 2
    g0 = _monomials(nv, half)
    parts["sigma0"] = asm.gram(g0)
    g1 = []
    for j, g in enumerate(rc.nonnegative):
        gp = _coeffs(g, gens)
        g1.append(_monomials(nv, (total - max(sum(m) for m in gp)) // 2))
        parts[f"sigma{j + 1}"] = asm.gram(g1[-1], gp)
    for m in list(A) + list(B):
        asm.row(m)
    nrow = len(asm.rows)
    avec, bvec = np.zeros(nrow), np.zeros(nrow)
    for m, c in A.items():
        avec[asm.rows[m]] = c
    for m, c in B.items():
        bvec[asm.rows[m]] = c
    rho = cp.Variable()
    lam = cp.Variable(len(lam_basis))
    expr = avec - rho * bvec + _sparse(parts["lambda"], nrow, len(lam_basis)) @ lam
    cons = []
    for j, h in enumerate(eq_polys):
        nb = len(_monomials(nv, total - max(sum(m) for m in h)))
        mu = cp.Variable(nb)
        expr = expr + _sparse(parts[f"mu{j}"], nrow, nb) @ mu
    Q0 = cp.Variable((len(g0), len(g0)), symmetric=True)
    cons.append(Q0 >> 0)
    expr = expr - _sparse(parts["sigma0"], nrow, len(g0) ** 2) @ cp.vec(Q0, order="C")
    for j, basis in enumerate(g1):
        Q = cp.Variable((len(basis), len(basis)), symmetric=True)
        cons.append(Q >> 0)
        expr = expr - _sparse(parts[f"sigma{j + 1}"], nrow, len(basis) ** 2) @ cp.vec(Q, order="C")
    # (d'd)^k (V - rho) + lambda V' + mu h - sigma1 s - sigma0 == 0
    cons.append(expr == 0)
    prob = cp.Problem(cp.Maximize(rho), cons)
    sizes = {
        "variables": [str(g) for g in gens],
        "degree": total,
        "gram_sizes": [len(g0)] + [len(b) for b in g1],
        "equality_rows": nrow,
        "multiplier_degree": multiplier_degree,
        "k": k,
    }
    try:
        prob.solve(solver=cp.CLARABEL, **(solver_options or {}))
        solver_status = str(prob.status)
    except cp.error.SolverError as exc:
        return SOSResult(
            "failed",
            None,
            f"solver error: {exc}",
            time.perf_counter() - t0,
            rc.description,
            sizes,
            "the solver failed: no certificate",
        )
    status = {
        cp.OPTIMAL: "solved",
        cp.OPTIMAL_INACCURATE: "inaccurate",
        cp.INFEASIBLE: "infeasible",
        cp.INFEASIBLE_INACCURATE: "infeasible",
    }.get(prob.status, "failed")
    value = (
        float(rho.value) if status in ("solved", "inaccurate") and rho.value is not None else None
    )
    msg = {
        "solved": "SOS candidate level; certified only after interval validation",
        "inaccurate": "solver reported an inaccurate solution: not a certificate",
        "infeasible": "no certificate at this degree",
        "failed": f"solver status {prob.status}: no certificate",
    }[status]
    return SOSResult(
        status, value, solver_status, time.perf_counter() - t0, rc.description, sizes, msg
    )
