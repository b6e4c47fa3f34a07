"""Shared base of the level-set search methods (:mod:`roa.search._levelset`): the problem and its witness.

Given a system with an equilibrium ``x0``, a candidate ``V`` centred on it (any
:class:`roa.lyapunov.Lyapunov`) and a *shape* ``s(x) = (x - x0)' S (x - x0)`` (``S`` positive
definite) or, for a non-quadratic ``V`` and ``shape="level"``, ``s = V`` itself, the largest level
is::

    c* = sup { c > 0 : V'(x) < 0 for all x with 0 < s(x) <= c, x inside the system's domain }
       = inf { s(x) : x != x0, V'(x) >= 0 or x outside the domain }

Each method (:mod:`roa.search._levelset_sampled`, :mod:`roa.search._levelset_casadi`) returns a
:class:`LevelSetResult` whose witness lies on the boundary of the admissible set, moved exactly onto
``V' = 0`` along its ray by :func:`finish`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import linalg, optimize

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov, check_positive_definite
from roa.lyapunov._local import locally_negative
from roa.model._system import System

#: Relative agreement required between the two methods.
AGREEMENT_RTOL = 1e-4
#: A witness is accepted when |V'(witness)| is below this.
WITNESS_ATOL = 1e-8


@dataclass(frozen=True)
class LevelSetResult:
    """A largest level ``c*`` of the shape, with how it was found and a point that proves it tight."""

    value: float
    status: str
    method: str
    shape: str
    witness: np.ndarray | None
    vdot_witness: float | None
    witness_kind: str | None = None  # "vdot_zero" or "domain_boundary"
    details: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "value": float(self.value),
            "status": self.status,
            "method": self.method,
            "shape": self.shape,
            "witness": None if self.witness is None else self.witness.tolist(),
            "vdot_witness": self.vdot_witness,
            "witness_kind": self.witness_kind,
            **self.details,
        }


@dataclass(frozen=True)
class Problem:
    system: System
    V: Lyapunov
    S: np.ndarray
    shape: str
    Linv_T: np.ndarray  # x = x0 + Linv_T @ y with |y|^2 = s(x) (for s = V: near x0)
    by_value: bool = False  # the shape is V itself (a non-quadratic V): s(x) = V(x)

    def shape_value(self, x: np.ndarray) -> np.ndarray:
        """The shape s at states ``x`` (``(..., n)``)."""
        if self.by_value:
            return self.V.value(x)
        d = np.asarray(x, dtype=float) - self.V.center
        return np.einsum("...i,ij,...j->...", d, self.S, d)

    def shape_expr(self, x: Any, xp: Any) -> Any:
        """The shape as an expression of the components ``x`` (CasADi, sympy)."""
        if self.by_value:
            return self.V.expr(x, xp)
        n = self.V.n
        d = [x[i] - float(self.V.center[i]) for i in range(n)]
        return sum(d[i] * float(self.S[i, j]) * d[j] for i in range(n) for j in range(n))

    def vdot(self, X: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):
            return self.V.derivative(self.system, X)

    def bad(self, X: np.ndarray) -> np.ndarray:
        """Violation: V' >= 0, not finite, or outside the domain."""
        vd = self.vdot(X)
        out = ~(vd < 0)
        if self.system.margin is not None:
            out |= ~self.system.inside(X)
        return out

    def points(self, U: np.ndarray, r: np.ndarray) -> np.ndarray:
        """States at shape radius ``r`` (s = r^2) along unit directions ``U`` (broadcast)."""
        return self.V.center + (r[..., None] * U) @ self.Linv_T.T


def problem(system: System, V: Lyapunov, S: Any, shape: str) -> Problem:
    """The search problem; ``S=None`` (non-quadratic ``V``, shape "level") makes the shape V."""
    by_value = S is None
    if by_value:
        S = 0.5 * V.hessian_at_center()
        try:
            check_positive_definite(S, what="V's Hessian")
        except RoaInputError:
            S = np.eye(V.n)  # rays in the system's coordinates; only the directions matter
    S = check_positive_definite(S, what=f"shape {shape!r} matrix")
    if S.shape != (V.n, V.n):
        raise RoaInputError(f"shape matrix must be {(V.n, V.n)}, got {S.shape}")
    if system.equilibrium is None:
        raise RoaInputError(f"system {system.name!r} has no equilibrium: no level-set search")
    if not np.allclose(system.x_eq, V.center):
        raise RoaInputError(
            f"V must be centred at the equilibrium of {system.name!r} {system.x_eq.tolist()}, "
            f"got center {V.center.tolist()}"
        )
    L = np.linalg.cholesky(S)  # S = L L'
    return Problem(system, V, S, shape, np.linalg.inv(L.T), by_value)


def start(
    system: System, V: Lyapunov, S: Any, shape: str, method: str
) -> tuple[Problem, LevelSetResult | None]:
    """The problem of one method, and its result already when V' is not negative near x_eq."""
    prob = problem(system, V, S, shape)
    ok, lam = locally_negative(system, V)
    if ok:
        return prob, None
    early = LevelSetResult(0.0, "not_locally_negative", method, shape, system.x_eq, 0.0,
                           details={"max_eig_AtP_PA": lam})  # fmt: skip
    return prob, early


def unit(Z: np.ndarray) -> np.ndarray:
    """Rows of ``Z`` scaled to unit Euclidean norm."""
    return Z / np.linalg.norm(Z, axis=-1, keepdims=True)


def inner_level(P_outer: Any, level: float, S_inner: Any) -> float:
    """Largest c with {y'S y <= c} inside {y'P y <= level}: ``level / lambda_max(P, S)``."""
    lam = linalg.eigh(np.asarray(P_outer, float), np.asarray(S_inner, float), eigvals_only=True)
    return float(level / lam[-1])


def finish(prob: Problem, x: np.ndarray, method: str, details: dict[str, Any]) -> LevelSetResult:
    """Put ``x`` exactly on V' = 0 along its ray (if it is a V' root), evaluate, wrap.

    ``x`` counts as a ``vdot_zero`` witness only when it is a genuine boundary point of
    ``{V' < 0}``: a sign change of V' is bracketed next to it on its ray (then it is moved onto the
    root), or ``|V'(x)|`` is below ``WITNESS_ATOL`` *and* at most ``1e-8`` x ``|V'| > 0`` halfway
    along the ray (a tangential zero). A point next to the equilibrium, where V' is tiny only
    because it vanishes there (``V' = -4e-53``, or 0 by rounding, at ``|x| = 1e-13`` when V' starts
    at degree 4), is neither and is refused (status ``failed``).
    """
    x = np.asarray(x, dtype=float)
    c = prob.V.center
    inside = prob.system.margin is None or bool(prob.system.inside(x))
    vd = float(prob.vdot(x))
    genuine = False
    if inside and np.isfinite(vd):

        def g(t: float) -> float:
            return float(prob.vdot(c + t * (x - c)))

        for width in (1e-9, 1e-6, 1e-3):
            a, b = 1 - width, 1 + width
            if g(a) * g(b) < 0:
                t = optimize.brentq(g, a, b, xtol=1e-15, rtol=4 * np.finfo(float).eps)
                x = c + t * (x - c)
                vd = float(prob.vdot(x))
                genuine = True
                break
        if not genuine:
            half = abs(g(0.5))
            genuine = bool(np.isfinite(half) and half > 0 and abs(vd) <= 1e-8 * half)
    if prob.by_value:
        value = float(prob.V.value(x[None, :])[0])
    else:
        d = x - c
        value = float(d @ prob.S @ d)
    kind = (
        "vdot_zero"
        if inside and genuine and abs(vd) < WITNESS_ATOL
        else ("domain_boundary" if not inside else None)
    )
    status = "found" if kind is not None else "failed"
    return LevelSetResult(value, status, method, prob.shape, x, vd, kind, details)


def vdot_order(prob: Problem, *, n_directions: int = 256, seed: int = 0) -> int:
    """The even degree ``p`` at which V' starts at the equilibrium (2 for a definite linearisation).

    Estimated from V' on two small spheres of the shape (radii ``1e-3`` and ``2e-3``): the median
    over directions of ``log2 |V'(2e-3 u)| / |V'(1e-3 u)|``, rounded to the nearest even integer
    >= 2 (2 when the samples are not finite or zero). An estimate used only to scale the CasADi
    constraint ``V' / s^(p/2) >= 0``, which is then bounded away from 0 near the equilibrium.
    """
    rng = np.random.default_rng(seed)
    U = unit(rng.standard_normal((n_directions, prob.V.n)))
    with np.errstate(all="ignore"):
        a = np.abs(prob.vdot(prob.points(U, np.full(n_directions, 1e-3))))
        b = np.abs(prob.vdot(prob.points(U, np.full(n_directions, 2e-3))))
        ratio = np.log2(b / a)
    ratio = ratio[np.isfinite(ratio)]
    if len(ratio) == 0:
        return 2
    return max(2, 2 * int(round(float(np.median(ratio)) / 2)))


def crossings(
    prob: Problem, U: np.ndarray, r_grid: np.ndarray, *, iters: int = 40, chunk: int = 4096
) -> np.ndarray:
    """Shape radius of the first violation along each direction (inf if none on the grid).

    Each ray is scanned on ``r_grid`` (increasing); the first violating grid point and the one
    before it bracket the crossing, refined by ``iters`` bisections. The radius returned violates
    (V' >= 0, not finite, or outside the domain); a violation between two grid points that the
    grid steps over is missed.
    """
    out = np.full(len(U), np.inf)
    for a in range(0, len(U), chunk):
        Uc = U[a : a + chunk]
        bad = prob.bad(prob.points(Uc[:, None, :], np.broadcast_to(r_grid, (len(Uc), len(r_grid)))))
        hit = bad.any(axis=1)
        if not hit.any():
            continue
        k = np.argmax(bad, axis=1)[hit]
        Uh = Uc[hit]
        hi = r_grid[k]
        lo = np.where(k > 0, r_grid[np.maximum(k - 1, 0)], 0.0)
        for _ in range(iters):  # invariant: lo admissible (or 0), hi violating
            mid = 0.5 * (lo + hi)
            b = prob.bad(prob.points(Uh, mid))
            hi = np.where(b, mid, hi)
            lo = np.where(b, lo, mid)
        res = out[a : a + chunk]
        res[hit] = hi
        out[a : a + chunk] = res
    return out
