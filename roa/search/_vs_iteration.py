"""Search of a polynomial Lyapunov function by SOS V-s iteration (Jarvis-Wloszek, Tan-Packard).

In whitened variables ``y`` (``x = x_eq + M y`` from a quadratic seed ``V0``), with the field made
polynomial in ``(y, aux)`` by :func:`roa.search._sos.recast_field` (equalities ``h = 0``, ``g >= 0``),
three semidefinite programs (cvxpy + Clarabel) alternate, each linear in its unknowns:

* **gamma step** (V fixed): the largest ``gamma`` with ``(y'y)^k (V - gamma) + lambda V' + mu h -
  sigma_g g`` SOS (``V' = 0`` away from the equilibrium only where ``V >= gamma``); V is rescaled
  to ``V / gamma`` (level 1), ``lambda`` kept;
* **beta step** (V fixed): the largest ``beta`` with ``(y'y)^k2 (p - beta) + lambda2 (V - 1)`` SOS,
  i.e. ``{p < beta}`` inside ``{V < 1}`` for the shape function ``p`` (a positive definite
  quadratic: the region to enlarge); ``lambda2`` kept;
* **V step** (``lambda``, ``lambda2`` fixed): V free with ``V - eps y'y`` SOS, both identities
  above at level 1, maximise ``beta``. The previous V is feasible, so ``beta`` never decreases.

That is the ``shape`` objective: it enlarges an ellipsoid inside ``{V <= 1}``, which cannot grow
past the nearest point where the region of attraction ends in the shape's metric (e.g. saddle
equilibria on the ellipsoid of the quadratic's optimum: then beta stays put whatever V). The
``volume`` objective enlarges the set itself: the V step minimises V's mean over the cube
``[-reach, reach]^n`` in y (linear in V's coefficients: exact monomial moments), keeping the
decrease identity at level 1 and ``V - eps y'y`` SOS; there is no beta step and no containment.
The previous V is feasible, so the mean never increases, and where V falls ``{V <= 1}`` grows (a
proxy for its volume: the caller measures it). Candidates rank by beta, resp. by the mean.

**Over a parameter box.** The decrease identity is imposed at each point of
:func:`parameter_points`, each with its own multiplier ``lambda_i`` and one common ``V``: the gamma
step takes the lowest level over the points, the V step keeps every identity; a seed that is not a
Lyapunov function at some point's linearisation is replaced (:func:`_box_seed`). The caller's
robust validator proves the candidates for every parameter of the box, never this module.

Odd fields (``f(x_eq - d) = -f(x_eq + d)``) keep V, ``lambda``, ``lambda2`` even and split the Gram
matrices in even/odd blocks (same optimum). Each round's V is a *candidate*: :func:`vs_search`
returns them all, and the caller (:func:`roa.certify`) finds its level by sampling and proves it by
interval branch and bound; the SDPs are solved in floating point and prove nothing.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from roa.errors import RoaInputError
from roa.lyapunov import PolynomialLyapunov, QuadraticLyapunov
from roa.model._parameters import describe_point
from roa.model._system import System
from roa.progress import note, step
from roa.search._sdp import (
    SOLVERS,
    Poly,
    Program,
    ProgramTooLarge,
    diff,
    is_even,
    lin,
    lyapunov_form,
    monomials,
    mul,
    multipliers,
    poly_of,
    power,
    solve,
    sym_blocks,
    sym_keep,
)
from roa.search._seed import seed_level
from roa.search._sos import recast_field
from roa.status import SosStatus

#: Most coefficients of a searched V (its monomials of degree 2..degree); the Gram blocks are
#: bounded on their own by :data:`roa.search._sdp.MAX_GRAM_BLOCK` (roa.search._sdp.check_block).
MAX_V_TERMS = 5000
#: What the V step enlarges: ``shape`` the level ``beta`` of ``{p <= beta}`` inside ``{V <= 1}``;
#: ``volume`` V's mean over a cube (``{V <= 1}`` grows where V falls), ``{p <= beta}`` kept inside.
OBJECTIVES = ("shape", "volume")


@dataclass(frozen=True)
class VsRound:
    """One round: ``gamma`` (level of the V it started from, before rescaling), ``beta`` (the
    shape level reached by the V step), solver seconds and status."""

    index: int
    gamma: float | None
    beta: float | None
    seconds: float
    status: str

    def to_dict(self) -> dict[str, Any]:
        return {"round": self.index, "gamma": self.gamma, "beta": self.beta,
                "seconds": round(self.seconds, 3), "status": self.status}  # fmt: skip


@dataclass(frozen=True)
class VsResult:
    """Outcome of :func:`vs_search`: ``candidates`` are the V of each round (level 1 each, best
    ``beta`` last); ``status`` is the solver's, never a certificate."""

    status: SosStatus
    degree: int
    candidates: list[PolynomialLyapunov]
    betas: list[float | None]
    rounds: list[VsRound]
    seconds: float
    sizes: dict[str, Any] = field(default_factory=dict)
    message: str = ""
    means: list[float] = field(default_factory=list)
    scores: list[float] = field(default_factory=list)

    @property
    def best(self) -> PolynomialLyapunov | None:
        return self.ranked()[0] if self.candidates else None

    def ranked(self) -> list[PolynomialLyapunov]:
        """The candidates, best first: by the objective's score (``beta``, or minus V's mean)."""
        scores = self.scores or [float(b or 0.0) for b in self.betas]
        return [self.candidates[int(i)] for i in np.argsort(scores, kind="stable")[::-1]]

    def to_dict(self) -> dict[str, Any]:
        return {"status": self.status.value, "degree": self.degree, "betas": self.betas,
                "means": self.means, "rounds": [r.to_dict() for r in self.rounds],
                "seconds": round(self.seconds, 3), "sizes": self.sizes,
                "message": self.message}  # fmt: skip


class _Problem:
    """The polynomial data of the three programs, in whitened variables."""

    def __init__(self, system: System, V0: QuadraticLyapunov, shape: np.ndarray, degree: int,
                 multiplier_degree: int | None, symmetry: bool | str, aux_degree: int | None,
                 recast_mode: str, scale: float = 1.0) -> None:  # fmt: skip
        # y'y = V0 / scale: the seed's level set {V0 <= scale} is the unit sphere in y, so that
        # monomials up to the program's degree stay O(1) on the region of interest
        self.M = np.linalg.inv(np.linalg.cholesky(V0.P).T) * np.sqrt(scale)
        self.Minv = np.linalg.inv(self.M)
        self.center = V0.center
        self.rf = rf = recast_field(system, self.M, V0.center, mode=recast_mode)
        self.gens = rf.d + rf.aux
        self.nd, self.nv = len(rf.d), len(self.gens)
        fy = [sum(float(self.Minv[i, j]) * rf.f[j] for j in range(self.nd)) for i in range(self.nd)]
        self.fy = [poly_of(sp.expand(e), self.gens) for e in fy]
        self.eqs, self.nonneg = ([poly_of(h, self.gens) for h in hs]
                                 for hs in (rf.equalities, rf.nonnegative))  # fmt: skip
        Mt = self.M.T @ shape @ self.M  # p(y) = (My)' S (My)
        pairs = [(a, b) for a in range(self.nd) for b in range(a, self.nd) if Mt[a, b] != 0.0]
        self.p = {tuple(int(i == a) + int(i == b) for i in range(self.nv)):
                  float(Mt[a, b]) * (1 if a == b else 2) for a, b in pairs}  # fmt: skip
        sym = is_even([*self.fy], self.nd, odd=True) and is_even([*self.eqs, *self.nonneg], self.nd)
        if symmetry is True and not sym:
            raise RoaInputError("symmetry=True needs an odd field and even recast constraints")
        self.sym = sym and symmetry in ("auto", True)
        self.aux_degree, self.D = aux_degree, degree // 2
        self.vbasis = [m for m in monomials(self.nd, degree, 2) if not self.sym or sum(m) % 2 == 0]
        self.vbasis = [(*m, *([0] * (self.nv - self.nd))) for m in self.vbasis]
        if len(self.vbasis) > MAX_V_TERMS:  # before the expansions, which take hours then
            raise ProgramTooLarge(_too_many(degree, self.nd, f"{len(self.vbasis)}"))
        deg_vd = degree - 1 + max(sum(m) for p in self.fy for m in p)
        self.mlam = 2 - deg_vd % 2 if multiplier_degree is None else multiplier_degree
        total = max(deg_vd + self.mlam, degree)
        self.total = total + (total % 2)
        self.k = (self.total - degree) // 2
        self.k2 = self.D  # (y'y)^k2 (p - beta) + lambda2 (V - 1): lambda2 quadratic
        self.yy = {tuple(2 * int(i == a) for i in range(self.nv)): 1.0 for a in range(self.nd)}
        self.yyk, self.yyk2 = (power(self.yy, e, self.nv) for e in (self.k, self.k2))
        # V' of each basis monomial of V: sum_i d(y^a)/dy_i f_i
        self.dmono = [lin(*((1.0, mul(diff(m, i), self.fy[i])) for i in range(self.nd)))
                      for m in self.vbasis]  # fmt: skip

    def keep(self, basis: list[tuple]) -> list[tuple]:
        return sym_keep(basis, self.nd, self.sym, self.aux_degree)

    def blocks(self, basis: list[tuple]) -> list[list[tuple]]:
        return sym_blocks(basis, self.nd, self.sym, self.aux_degree)

    def y_only(self, basis: list[tuple]) -> list[tuple]:
        return [m for m in basis if sum(m[self.nd :]) == 0]

    # -- the decrease identity: (y'y)^k (V - gamma) + lambda V' + mu h - sigma g - sigma0 ----------
    def decrease(self, ident: Program, Vc: Any, lam: Any, gamma: Any) -> Program:
        """Add the decrease identity; ``Vc`` V's coefficients (array or variable), ``lam`` the
        multiplier (a fixed Poly or None for a free one), ``gamma`` the level (float or variable)."""
        cols = [mul(self.yyk, {m: 1.0}) for m in self.vbasis]
        if lam is None:  # gamma step: V fixed (numbers), lambda free
            Vpoly = lin(*((float(c), {m: 1.0}) for m, c in zip(self.vbasis, Vc, strict=True)))
            Vd = lin(*((float(c), p) for p, c in zip(self.dmono, Vc, strict=True)))
            ident.const(mul(self.yyk, Vpoly))
            ident.free(Vd, self.keep(monomials(self.nv, self.mlam)))
        else:  # V step: V free (variable), lambda fixed
            ident.linear([lin((1.0, c), (1.0, mul(lam, d)))
                          for c, d in zip(cols, self.dmono, strict=True)], Vc)  # fmt: skip
        ident.linear([lin((-1.0, self.yyk))], gamma)
        multipliers(ident, self.total, self.eqs, self.nonneg, self.blocks, self.keep)
        return ident

    # -- containment: (y'y)^k2 (p - beta) + lambda2 (V - 1) - sigma (in y only) ---------------------
    def contain(self, ident: Program, Vc: Any, lam2: Poly | None, beta: Any) -> Program:
        ident.const(mul(self.yyk2, self.p))
        ident.linear([lin((-1.0, self.yyk2))], beta)
        deg = 2 * self.D + 2
        lam_basis = self.y_only(self.keep(monomials(self.nv, 2)))
        if lam2 is None:
            Vm1 = lin(*((float(c), {m: 1.0}) for m, c in zip(self.vbasis, Vc, strict=True)),
                      (1.0, {tuple([0] * self.nv): -1.0}))  # fmt: skip
            ident.free(Vm1, lam_basis)
        else:
            ident.linear([mul(lam2, {m: 1.0}) for m in self.vbasis], Vc)
            ident.const(lin((-1.0, lam2)))
        for b in self.blocks(self.y_only(monomials(self.nv, deg // 2))):
            ident.gram(b, None)
        return ident

    def positive(self, ident: Program, Vc: Any, eps: float) -> None:
        """``V - eps y'y`` SOS over monomials of degree 1..D in y."""
        ident.linear([{m: 1.0} for m in self.vbasis], Vc)
        ident.const(lin((-eps, self.yy)))
        basis = [m for m in self.y_only(monomials(self.nv, self.D)) if sum(m) >= 1]
        for b in self.blocks(basis):
            ident.gram(b, None)

    def linear_decrease(self, ident: Program, Vc: Any, margin: float) -> None:
        """Local decrease kept strict: ``-(A'Pv + Pv A) >= margin * mu0 I`` for the quadratic part
        ``Pv`` of V (``A`` the field's Jacobian at the equilibrium, ``mu0`` the seed's value),
        an LMI linear in V's coefficients. Without it the V step may drift to a V whose
        linearisation only marginally decreases (the sampled search then finds no level)."""
        n = self.nd
        A = np.zeros((n, n))
        for i, p in enumerate(self.fy):
            for m, c in p.items():
                if sum(m) == 1 and sum(m[:n]) == 1:
                    A[i, m.index(1)] += c
        mu0 = float(np.linalg.eigvalsh(-(A + A.T))[0])
        if mu0 <= 0:
            return
        L = lyapunov_form(A, lambda i, j: Vc[self.vbasis.index(
            tuple(int(a == i) + int(a == j) for a in range(self.nv)))])  # fmt: skip
        ident.psd.append(L - margin * mu0 * np.eye(n) >> 0)

    def box_means(self, reach: float) -> np.ndarray:
        """Mean of each monomial of V over the cube ``[-reach, reach]^n`` in y (exact:
        ``prod_i reach^a_i / (a_i + 1)`` for even exponents ``a_i``, else 0)."""
        return np.array([
            math.prod(reach ** a / (a + 1) if a % 2 == 0 else 0.0 for a in m[: self.nd])
            for m in self.vbasis
        ])  # fmt: skip

    def to_lyapunov(self, Vc: np.ndarray, name: str) -> PolynomialLyapunov:
        """V(y(x)) with ``y = M^-1 (x - c)``, expanded in ``d = x - c``."""
        d = sp.symbols(f"d0:{self.nd}", real=True)
        y = [sum(float(self.Minv[i, j]) * d[j] for j in range(self.nd)) for i in range(self.nd)]
        expr = 0
        for m, c in zip(self.vbasis, Vc, strict=True):
            if c != 0.0:
                expr += float(c) * sp.Mul(*[y[i] ** m[i] for i in range(self.nd)])
        terms = [(m, float(c)) for m, c in sp.Poly(sp.expand(expr), *d).terms()
                 if abs(float(c)) > 0 and sum(m) >= 2]  # fmt: skip
        V = PolynomialLyapunov([m for m, _ in terms], [c for _, c in terms], self.center, name)
        attach_gram(V)  # a positive definite Gram matrix: the exact route's V >= mu |d|^2
        return V


def vs_search(system: System, V0: QuadraticLyapunov, *, degree: int = 4, shape: Any = None,
              rounds: int = 6, multiplier_degree: int | None = None, symmetry: bool | str = "auto",
              aux_degree: int | None = None, recast_mode: str = "exact", eps: float = 1e-6,
              tol: float = 1e-3, solver_options: dict[str, Any] | None = None,
              solver: str = "auto", budget: float | None = None, objective: str = "shape",
              reach: float = 1.5) -> VsResult:  # fmt: skip
    """Polynomial Lyapunov candidates of degree ``degree`` by V-s iteration (module docstring).

    ``V0`` seeds the iteration (and fixes the whitening); ``shape`` is the matrix ``S`` of the
    shape function ``p(x) = (x - x_eq)' S (x - x_eq)`` (default ``V0.P``). Stops after ``rounds``
    V steps or when ``beta`` grows by less than ``tol`` (relative). ``solver``: ``auto``,
    ``clarabel`` or ``scs`` (:meth:`roa.search._sdp.Program.solve`). ``budget``: wall-clock
    seconds for the whole search; no SDP starts past it and each gets the time left as its solver
    time limit, so the search stops with the candidates of the rounds it completed: status
    ``stopped``, ``message`` saying when. With progress on (:func:`roa.progress.enable`), each
    round after the first starts with a line giving the last shape level and an estimate of the
    time the rounds left take at the pace so far. ``objective``: ``shape`` (maximise ``beta``) or
    ``volume`` (minimise V's mean over the cube ``[-reach, reach]^n`` in the whitened ``y``, where
    the seed's level set is the unit sphere; module docstring); the volume objective stops when
    the mean falls by less than ``tol`` (relative).
    """
    if solver not in SOLVERS:
        raise RoaInputError(f"solver must be one of {SOLVERS}, got {solver!r}")
    if degree not in (2, 4, 6, 8):
        raise RoaInputError(f"degree must be 2, 4, 6 or 8, got {degree!r}")
    if not (isinstance(rounds, int) and 1 <= rounds <= 50):
        raise RoaInputError(f"rounds must be an integer in [1, 50], got {rounds!r}")
    if objective not in OBJECTIVES:
        raise RoaInputError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    if not (isinstance(reach, int | float) and math.isfinite(reach) and reach > 0):
        raise RoaInputError(f"reach must be a finite number > 0, got {reach!r}")
    t0 = _now()

    def none(status: SosStatus, message: str) -> VsResult:
        return VsResult(status, degree, [], [], [], _now() - t0, message=message)

    # V's even monomials alone (fewest it can have) over MAX_V_TERMS: refused before the seed's
    # level search, which alone takes a while in tens of states
    even = sum(math.comb(system.n + d - 1, d) for d in range(2, degree + 1, 2))
    if even > MAX_V_TERMS:
        return none(SosStatus.TOO_LARGE, _too_many(degree, system.n, f"at least {even}"))
    S = V0.P if shape is None else np.asarray(shape, dtype=float)
    points, how = parameter_points(system)
    V0, reseeded = _box_seed(system, V0)
    if reseeded and shape is None:
        S = V0.P
    at = [system] if not points else [system.at(**p) for p in points]
    scale = min(seed_level(s, V0) for s in at)
    try:
        pbs = _problems(at, symmetry, V0=V0, shape=S, degree=degree, scale=scale,
                        multiplier_degree=multiplier_degree, aux_degree=aux_degree,
                        recast_mode=recast_mode)  # fmt: skip
    except ProgramTooLarge as exc:
        return none(SosStatus.TOO_LARGE, str(exc))
    except (RoaInputError, sp.PolynomialError) as exc:
        return none(SosStatus.NOT_POLYNOMIAL, str(exc))
    pb = pbs[0]
    base = dict(solver_options or {})

    def left() -> float | None:
        return None if budget is None else budget - (_now() - t0)

    def options() -> dict[str, Any]:
        if (rest := left()) is None:
            return base
        # never below 1e-3 s (a solver refuses a negative limit): the budget may run out
        # between the check before a step and its solve
        limit = max(rest, 1e-3)
        return {**base, "time_limit": min(base.get("time_limit") or limit, limit)}

    def spent() -> bool:
        return (rest := left()) is not None and rest <= 0

    # the seed in y: V0 = y'y
    Vc = np.array([1.0 if sum(m) == 2 and max(m) == 2 else 0.0 for m in pb.vbasis])
    sizes = {"variables": [str(g) for g in pb.gens], "degree_V": degree, "degree": pb.total,
             "V_coefficients": len(pb.vbasis), "symmetry": "even/odd blocks" if pb.sym else "none",
             "recast": pb.rf.description}  # fmt: skip
    if points:
        sizes["parameter_points"] = [dict(p) for p in points]
        sizes["parameter_points_chosen"] = how
        if reseeded:
            sizes["seed"] = V0.name
    cands: list[PolynomialLyapunov] = []
    betas: list[float | None] = []
    means: list[float] = []  # V's mean over the cube [-reach, reach]^n in y, V at level 1
    weights = pb.box_means(float(reach))
    if objective == "volume":
        sizes["objective"] = f"mean of V over the cube [-{reach:g}, {reach:g}]^{pb.nd} in y"
    log: list[VsRound] = []
    status, message = SosStatus.SOLVED, ""
    for r in range(rounds + 1):
        t1 = _now()
        if spent():
            message = (f"time budget of {budget} s spent before round {r}: kept {len(cands)} "
                       "candidates")  # fmt: skip
            status = SosStatus.FAILED if not cands else SosStatus.STOPPED
            break
        if r:
            _pace(r, rounds, t0, log, budget)
        # gamma step: the level of the current V (the lowest over the parameter points, each
        # with its own multiplier), then V / gamma (level 1)
        lams: list[Poly] = []
        gval: float | None = None
        for k, pk in enumerate(pbs):
            ident, gamma = Program(pk.nv), Program.scalar()
            pk.decrease(ident, Vc, None, gamma)
            where = f" at {describe_point(points[k])}" if points else ""
            with step(f"V-s round {r}: gamma step{where}"):
                ok, gk, lam = ident.solve(gamma, options=options(), free_index=0, solver=solver)
            if not ok or gk is None or gk <= 0 or lam is None:
                gval = None
                break
            lams.append(lam)
            gval = gk if gval is None else min(gval, gk)
        if gval is None:
            status, message = _failed(r, "gamma", ident.status, spent(), budget, len(cands))
            if points:
                message += f" at {describe_point(points[len(lams)])}"
            log.append(VsRound(r, None, None, _now() - t1, ident.status))
            break
        Vc = Vc / gval
        sizes.setdefault("gram_blocks_gamma_step", ident.sizes())
        sizes.setdefault("solver", ident.solver)
        # beta step: the shape level inside {V <= 1} (the shape objective's only)
        bval: float | None = None
        lam2: Poly | None = None
        if objective == "shape":
            ident, beta = Program(pb.nv), Program.scalar()
            pb.contain(ident, Vc, None, beta)
            with step(f"V-s round {r}: beta step"):
                ok, bval, lam2 = ident.solve(beta, options=options(), free_index=0, solver=solver)
            if not ok or bval is None:
                status, message = _failed(r, "beta", ident.status, spent(), budget, len(cands))
                log.append(VsRound(r, gval, None, _now() - t1, ident.status))
                break
        cands.append(pb.to_lyapunov(Vc, f"V-s degree {degree}, round {r}"))
        betas.append(bval)
        means.append(float(weights @ Vc))
        if spent():
            log.append(VsRound(r, float(gval), bval, _now() - t1, "budget"))
            message = (f"time budget of {budget} s spent in round {r}: kept {len(cands)} "
                       "candidates")  # fmt: skip
            status = SosStatus.STOPPED
            break
        if bval is None:
            stalled = r >= 1 and means[-1] > means[-2] * (1 - tol)
        else:
            stalled = r > 1 and bval < float(betas[-2] or 0.0) * (1 + tol)
        if r == rounds or stalled:
            log.append(VsRound(r, float(gval), bval, _now() - t1, "final"))
            if bval is None:
                message = (f"{len(cands)} candidates; mean of V over the cube {means[0]:.6g} -> "
                           f"{min(means):.6g}")  # fmt: skip
            else:
                shown = [b for b in betas if b is not None]
                message = f"{len(cands)} candidates; beta {shown[0]:.6g} -> {max(shown):.6g}"
            if points:
                where = "; ".join(describe_point(p) for p in points)
                message += f"; V' < 0 imposed at {len(points)} parameter points ({where}): {how}"
                if reseeded:
                    message += f"; seed: {V0.name}"
            break
        # V step: V free, lambda and lambda2 fixed, maximise beta
        ident, vvar, beta = Program(pb.nv), Program.scalar(shape=len(pb.vbasis)), Program.scalar()
        pb.decrease(ident, vvar, lams[0], 1.0)
        others = [pk.decrease(ident.fork(), vvar, lam_k, 1.0)  # the same V at every point
                  for pk, lam_k in zip(pbs[1:], lams[1:], strict=True)]  # fmt: skip
        extra: list[Program] = []
        if objective == "volume":  # V's mean over the cube decreases: {V <= 1} grows
            goal, sense = weights @ vvar, False
        else:  # {p <= beta} inside {V <= 1}, beta increases
            extra.append(pb.contain(ident.fork(), vvar, lam2, beta))
            goal, sense = beta, True
        ident3 = ident.fork()
        pb.positive(ident3, vvar, eps)
        for pk in pbs:
            pk.linear_decrease(ident, vvar, 0.01)
        with step(f"V-s round {r}: V step"):
            ok, bnew, _ = ident.solve(goal, maximise=sense, options=options(),
                                      also=[*others, *extra, ident3], solver=solver)  # fmt: skip
        log.append(VsRound(r, float(gval), bval, _now() - t1, ident.status))
        if not ok or bnew is None or vvar.value is None:
            message = f"round {r}: V step {ident.status}; kept the V of round {r}"
            if spent():
                status = SosStatus.STOPPED
                message = f"time budget of {budget} s spent in the V step of {message}"
            break
        Vc = np.asarray(vvar.value, dtype=float)
    if not cands:
        return VsResult(status, degree, [], [], log, _now() - t0, sizes, message)
    final = SosStatus.STOPPED if status is SosStatus.STOPPED else SosStatus.SOLVED
    scores = [-m for m in means] if objective == "volume" else [float(b or 0.0) for b in betas]
    return VsResult(final, degree, cands, betas, log, _now() - t0, sizes, message, means, scores)


def parameter_points(system: System) -> tuple[list[dict[str, float]], str]:
    """The parameter values the V-s iteration imposes V's decrease at, and how they were chosen:
    none for a system without uncertain parameters; the box's vertices when the field is affine
    in the parameters (then ``V'(x, p)`` is affine in ``p`` for a fixed ``V``, and its decrease on
    ``{V <= 1}`` at the vertices gives it on the whole box); else the nominal values, the vertices
    and one interior point along each axis (nothing claimed between them). Either way a proposal:
    the validator of :func:`roa.certify` decides for every parameter of the box."""
    if not system.parameters:
        return [], "none"
    from roa.model._parameters import ParameterBox, sample_points

    box = ParameterBox.of(system)
    if _field_affine(system, box):
        return [dict(v) for v in box.vertices()], "vertices (the field is affine in the parameters)"
    return sample_points(system, per_axis=1), ("nominal values, vertices and one interior point "
                                                "per axis (the field is not affine in the "
                                                "parameters: nothing claimed between them)")  # fmt: skip


def _field_affine(system: System, box: Any) -> bool:
    """Whether ``f(x, p)`` is affine in ``p``: at seeded sample states, ``f`` at the centre and at
    the midpoints of the edges through the lowest and highest vertex equals the mean of ``f`` at
    the edge's (resp. all) vertices, to rounding (a check at those points: a proposal only)."""
    rng = np.random.default_rng(0)
    X = system.x_eq + rng.uniform(-1.0, 1.0, (16, system.n))
    lo = dict(zip(box.names, box.lo, strict=True))
    hi = dict(zip(box.names, box.hi, strict=True))
    checks = [(box.midpoint, list(box.vertices()))]
    for name in box.names:
        for corner in (lo, hi):
            a, b = {**corner, name: lo[name]}, {**corner, name: hi[name]}
            checks.append(({**corner, name: 0.5 * (lo[name] + hi[name])}, [a, b]))
    with np.errstate(all="ignore"):
        for mid, ends in checks:
            f_mid = system.at(**mid).f(X)
            mean = sum(system.at(**e).f(X) for e in ends) / len(ends)
            tol = 1e-9 * max(1.0, float(np.nanmax(np.abs(mean))))
            if not np.all(np.abs(f_mid - mean) <= tol):
                return False
    return True


def _box_seed(system: System, V0: QuadraticLyapunov) -> tuple[QuadraticLyapunov, bool]:
    """``V0``, or, when it is not a Lyapunov function at the linearisation for some sample point
    of the parameter box, the common quadratic V of the box's LMIs
    (:func:`roa.search._box_lyapunov.box_lyapunov`, when feasible): a gamma step at a point where
    ``V0'`` is positive near the equilibrium has no level, so the iteration could not start."""
    if not system.parameters:
        return V0, False
    from roa.search._box_lyapunov import box_lyapunov
    from roa.search._candidate import worst_linearisation

    if worst_linearisation(system, V0) is None:
        return V0, False
    res = box_lyapunov(system)
    P = res.P  # the LMIs' matrix (a result's field, not a V's representation)
    if not res.feasible or P is None:
        return V0, False
    return QuadraticLyapunov.for_system(system, P, name="P of the box's common Lyapunov "
                                        "LMIs"), True  # fmt: skip


def _problems(systems: list[System], symmetry: bool | str, **kw: Any) -> list[_Problem]:
    """One :class:`_Problem` per parameter point, sharing V's monomials: the even/odd split only
    when every point allows it; the same recast variables at every point (else an error)."""
    pbs = [_Problem(s, symmetry=symmetry, **kw) for s in systems]
    if len({pb.sym for pb in pbs}) > 1:
        pbs = [_Problem(s, symmetry=False, **kw) for s in systems]
    if len({tuple(map(str, pb.gens)) for pb in pbs}) > 1 or len({pb.total for pb in pbs}) > 1:
        raise RoaInputError("the recast field has other variables or degrees at other parameter values of the "
                            "box: the V-s iteration over the box needs one polynomial structure")  # fmt: skip
    return pbs


def _too_many(degree: int, n: int, count: str) -> str:
    return (f"a V of degree {degree} in {n} states has {count} coefficients, more than the "
            f"{MAX_V_TERMS} searched here (its SOS programs would not fit in memory): not built; "
            "use a lower degree or fewer states")  # fmt: skip


def _failed(r: int, what: str, solver: str, spent: bool, budget: float | None,
            kept: int) -> tuple[SosStatus, str]:  # fmt: skip
    """Status and message of a gamma or beta step that gave no answer: ``stopped`` when the
    budget ran out (with candidates kept), else ``failed``."""
    if spent:
        return (SosStatus.STOPPED if kept else SosStatus.FAILED,
                f"time budget of {budget} s spent in round {r} ({what} step: {solver}): kept "
                f"{kept} candidates")  # fmt: skip
    return SosStatus.FAILED, f"round {r}: {what} step {solver}"


def _now() -> float:
    """The clock of the budget and the progress lines (a counter in tests)."""
    return time.perf_counter()


def _pace(r: int, rounds: int, t0: float, log: list[VsRound], budget: float | None) -> None:
    """Progress line before round ``r``: the last shape level and the time the rounds left
    (``r .. rounds``) take at the mean pace of the rounds done, capped by the budget."""
    spent = _now() - t0
    per = spent / r
    more = per * (rounds + 1 - r)
    beta = log[-1].beta if log else None
    cap = "" if budget is None else f", budget {budget:g} s"
    if budget is not None and spent + more > budget:
        more = max(0.0, budget - spent)
        cap += " (stops there with the best round)"
    note(f"V-s: {r} of at most {rounds + 1} rounds in {spent:.0f} s (beta "
         f"{'none' if beta is None else f'{beta:.6g}'}); about {more:.0f} s more at this "
         f"pace{cap}")  # fmt: skip


def attach_gram(V: Any, solver_options: dict[str, Any] | None = None) -> bool:
    """Attach a positive definite Gram matrix to the polynomial ``V`` (``V.gram``) when the
    program finds one that the exact cover (:func:`roa.proof.gram_cover`) proves positive
    definite; whether it did. The exact SOS route proves ``{V <= c}`` bounded from
    ``V >= mu |d|^2`` by that cover; a V of the iteration has coefficients only, so one small
    program (``V = m' Q m`` coefficient by coefficient, ``m`` the monomials of degree
    ``1..deg V / 2``, ``Q >= t s I`` with ``s`` V's largest coefficient and ``t <= 1``
    maximised) proposes ``Q``. Only the exact cover decides; otherwise V keeps no Gram matrix."""
    poly = V.polynomial_view() or {}
    terms = {tuple(int(k) for k in m): float(c) for m, c in poly.items() if c}
    if not terms or V.gram_view() is not None:
        return V.gram_view() is not None
    n = int(V.n)
    deg = max(sum(m) for m in terms)
    if deg % 2 or min(sum(m) for m in terms) < 2:
        return False
    basis = monomials(n, deg // 2, 1)
    prog, t = Program(n), Program.scalar()
    prog.const({m: -c for m, c in terms.items()})
    Q = prog.gram(basis, None, sign=1.0, margin=t * max(abs(c) for c in terms.values()))
    res = solve(prog.problem(t, extra=[t <= 1]), options=solver_options)
    if not res.usable or t.value is None or not float(t.value) > 0 or Q.value is None:
        return False
    from roa.proof._cover import gram_cover

    V.with_gram((basis, 0.5 * (np.asarray(Q.value) + np.asarray(Q.value).T)))
    if gram_cover(V, 1.0) is None:  # not proved positive definite exactly: none attached
        V.with_gram(None)
        return False
    return True
