"""Khalil's level-set search: the largest set {s(x) <= c} on which V' < 0 (except at the equilibrium).

Given a :class:`~roa.system.System` with an equilibrium ``x0``, a quadratic Lyapunov candidate
``V(x) = (x - x0)' P (x - x0)`` and a *shape* ``s(x) = (x - x0)' S (x - x0)`` (``S`` positive
definite: ``S = P`` searches sublevel sets of ``V`` itself, ``S = I`` Euclidean balls), find::

    c* = sup { c > 0 : V'(x) < 0 for all x with 0 < s(x) <= c, x inside the system's domain }
       = inf { s(x) : x != x0, V'(x) >= 0 or x outside the domain }

(the second form holds because V' < 0 near ``x0`` when ``V`` is a strict Lyapunov function of the
linearisation; otherwise ``c* = 0``). Reading "Phi <= 0" instead of "V' < 0" gives the same number
unless V' touches zero without changing sign, which the witness check would show.

Two independent methods, both returning a :class:`LevelSetResult` with a *witness* ``x`` on the
boundary of the admissible set (``V'(x) = 0`` to rounding, or the domain boundary):

* :func:`sampled_level` -- vectorised directions on the unit sphere of the shape, the first
  sign change of V' along each ray bracketed on a radial grid and refined by bisection, then the
  best directions refined by sampling in shrinking caps around them. The minimum over the sampled
  directions is an upper bound of c* that decreases as the number of directions grows
  (``result.details["convergence"]``).
* :func:`casadi_level` (in :mod:`roa.levelset_casadi`, re-exported here) -- IPOPT (through CasADi) minimising ``s(x)`` subject to
  ``V'(x) / s(x) >= 0``, multi-start from violating points; the best local minimiser, then moved
  onto V' = 0 exactly by a root search along its ray.

:func:`level_search` runs one or both and checks their agreement.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import linalg, optimize

from roa.levelset_casadi import casadi_level
from roa.lyapunov import QuadraticLyapunov, check_positive_definite
from roa.system import System

__all__ = [
    "AGREEMENT_RTOL",
    "BOTH_STATUSES",
    "LEVEL_STATUSES",
    "METHODS",
    "WITNESS_ATOL",
    "LevelSetResult",
    "casadi_level",
    "inner_level",
    "jacobian",
    "level_search",
    "locally_negative",
    "lyapunov_matrix",
    "sampled_level",
]

METHODS = ("sampled", "casadi", "both")
#: Relative agreement required between the two methods.
AGREEMENT_RTOL = 1e-4
#: A witness is accepted when |V'(witness)| is below this.
WITNESS_ATOL = 1e-8

LEVEL_STATUSES = (
    "found",  # a finite c* with a witness
    "unbounded",  # no violation found within the search radius (c* >= r_max^2)
    "not_locally_negative",  # V' is not negative definite near the equilibrium: c* = 0
    "failed",  # the method found no admissible point (solver failures)
)
#: Statuses of ``level_search(method="both")`` besides the shared ones above.
BOTH_STATUSES = (
    "agree",  # both found, within AGREEMENT_RTOL
    "disagree",  # both found, further apart
    "partial",  # one found, the other did not (see per_method)
)


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
class _Problem:
    system: System
    V: QuadraticLyapunov
    S: np.ndarray
    shape: str
    Linv_T: np.ndarray  # x = x0 + Linv_T @ y with |y|^2 = s(x)

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


def _problem(system: System, V: QuadraticLyapunov, S: Any, shape: str) -> _Problem:
    S = check_positive_definite(S, what=f"shape {shape!r} matrix")
    if S.shape != V.P.shape:
        raise ValueError(f"shape matrix must be {V.P.shape}, got {S.shape}")
    if system.equilibrium is None:
        raise ValueError(f"system {system.name!r} has no equilibrium: no level-set search")
    if not np.allclose(system.x_eq, V.center):
        raise ValueError("V must be centred at the system's equilibrium")
    L = np.linalg.cholesky(S)  # S = L L'
    return _Problem(system, V, S, shape, np.linalg.inv(L.T))


def jacobian(system: System, x: np.ndarray | None = None) -> np.ndarray:
    """Jacobian of the field at ``x`` (default the equilibrium), exact via CasADi."""
    import casadi as ca

    from roa.backend import namespace

    x = system.x_eq if x is None else np.asarray(x, dtype=float)
    sym = ca.SX.sym("x", system.n)
    f = ca.vertcat(*system.field(0.0, [sym[i] for i in range(system.n)], namespace("casadi")))
    return np.array(ca.Function("J", [sym], [ca.jacobian(f, sym)])(x), dtype=float)


def lyapunov_matrix(system: System) -> np.ndarray:
    """P solving A'P + PA = -I for the linearisation A at the equilibrium (A must be Hurwitz)."""
    A = jacobian(system)
    eig = np.linalg.eigvals(A)
    if np.max(eig.real) >= 0:
        raise ValueError(
            f"linearisation of {system.name!r} is not Hurwitz (eigenvalue {eig[np.argmax(eig.real)]:.4g}): "
            "no quadratic Lyapunov function from A'P + PA = -I; give LYAPUNOV_P in the system file"
        )
    P = linalg.solve_continuous_lyapunov(A.T, -np.eye(system.n))
    return 0.5 * (P + P.T)


def locally_negative(system: System, V: QuadraticLyapunov) -> tuple[bool, float]:
    """Whether V' is negative definite near the equilibrium: A'P + PA < 0. Returns (ok, max eig)."""
    A = jacobian(system)
    Q = A.T @ V.P + V.P @ A
    lam = float(np.linalg.eigvalsh(0.5 * (Q + Q.T))[-1])
    return lam < 0, lam


def inner_level(P_outer: Any, level: float, S_inner: Any) -> float:
    """Largest c with {y'S y <= c} inside {y'P y <= level}: ``level / lambda_max(P, S)``."""
    lam = linalg.eigh(np.asarray(P_outer, float), np.asarray(S_inner, float), eigvals_only=True)
    return float(level / lam[-1])


# ----------------------------------------------------------------------------- sampled method


def _unit(Z: np.ndarray) -> np.ndarray:
    return Z / np.linalg.norm(Z, axis=-1, keepdims=True)


def _crossings(
    prob: _Problem, U: np.ndarray, r_grid: np.ndarray, *, iters: int = 40, chunk: int = 4096
) -> np.ndarray:
    """Shape radius of the first violation along each direction (inf if none on the grid)."""
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


def sampled_level(
    system: System,
    V: QuadraticLyapunov,
    S: Any,
    *,
    shape: str = "custom",
    n_directions: int = 20000,
    r_max: float = 100.0,
    n_radial: int = 96,
    refine_rounds: int = 20,
    refine_directions: int = 192,
    n_candidates: int = 3,
    seed: int = 0,
) -> LevelSetResult:
    """Largest shape level with V' < 0, by rays in sampled directions (see module docstring).

    Parameters
    ----------
    system, V, S
        The system, the Lyapunov candidate and the shape matrix.
    n_directions : int
        Number of random directions on the unit sphere of the shape (>= 16).
    r_max : float
        Search radius in shape units (sqrt(s)); rays without violation up to it count as infinite.
    n_radial : int
        Points of the geometric radial grid from ``1e-4 r_max`` to ``r_max`` used for bracketing.
    refine_rounds, refine_directions, n_candidates : int
        Cap-refinement: rounds, directions per round, and how many of the best directions to refine.
    seed : int
        Random seed.
    """
    if int(n_directions) < 16:
        raise ValueError(f"n_directions must be >= 16, got {n_directions}")
    if not (np.isfinite(r_max) and r_max > 0):
        raise ValueError(f"r_max must be finite and > 0, got {r_max}")
    if int(n_radial) < 8:
        raise ValueError(f"n_radial must be >= 8, got {n_radial}")
    prob = _problem(system, V, S, shape)
    ok, lam = locally_negative(system, V)
    if not ok:
        return LevelSetResult(
            0.0,
            "not_locally_negative",
            "sampled",
            shape,
            system.x_eq,
            0.0,
            details={"max_eig_AtP_PA": lam},
        )
    rng = np.random.default_rng(seed)
    n = system.n
    U = _unit(rng.standard_normal((int(n_directions), n)))
    r_grid = r_max * np.geomspace(1e-4, 1.0, int(n_radial))
    r = _crossings(prob, U, r_grid)
    convergence = []
    m = int(n_directions)
    sizes = sorted({max(16, m // 4**k) for k in range(4)})
    for size in sizes:
        convergence.append({"n_directions": size, "value": float(np.min(r[:size]) ** 2)})
    if not np.isfinite(r).any():
        return LevelSetResult(
            float(r_max**2),
            "unbounded",
            "sampled",
            shape,
            None,
            None,
            details={"r_max": r_max, "convergence": convergence},
        )
    # Cap refinement around the best few (well separated) directions.
    order = np.argsort(r)
    cands: list[int] = []
    for i in order:
        if not np.isfinite(r[i]):
            break
        if all(abs(U[i] @ U[j]) < 0.95 for j in cands):
            cands.append(int(i))
        if len(cands) >= n_candidates:
            break
    best_r, best_u = np.inf, None
    for i in cands:
        u, ru = U[i], r[i]
        sigma = 0.1
        for _ in range(int(refine_rounds)):
            Z = _unit(u + sigma * rng.standard_normal((int(refine_directions), n)))
            grid = ru * np.linspace(1.0 / 24, 1.25, 30)
            rz = _crossings(prob, Z, grid)
            j = int(np.argmin(rz))
            if rz[j] < ru:
                u, ru = Z[j], rz[j]
            sigma *= 0.55
        if ru < best_r:
            best_r, best_u = ru, u
    assert best_u is not None
    witness = prob.points(best_u, np.asarray(best_r))
    return _finish(
        prob,
        witness,
        "sampled",
        {
            "n_directions": m,
            "r_max": r_max,
            "n_radial": int(n_radial),
            "raw_value": float(np.min(r) ** 2),
            "convergence": convergence,
            "refine_rounds": int(refine_rounds),
            "seed": seed,
        },
    )


def _finish(prob: _Problem, x: np.ndarray, method: str, details: dict[str, Any]) -> LevelSetResult:
    """Put ``x`` exactly on V' = 0 along its ray (if it is a V' root), evaluate, wrap."""
    x = np.asarray(x, dtype=float)
    c = prob.V.center
    inside = prob.system.margin is None or bool(prob.system.inside(x))
    vd = float(prob.vdot(x))
    if inside and np.isfinite(vd):

        def g(t: float) -> float:
            return float(prob.vdot(c + t * (x - c)))

        for width in (1e-9, 1e-6, 1e-3):
            a, b = 1 - width, 1 + width
            if g(a) * g(b) < 0:
                t = optimize.brentq(g, a, b, xtol=1e-15, rtol=4 * np.finfo(float).eps)
                x = c + t * (x - c)
                vd = float(prob.vdot(x))
                break
    d = x - c
    value = float(d @ prob.S @ d)
    kind = (
        "vdot_zero"
        if inside and abs(vd) < WITNESS_ATOL
        else ("domain_boundary" if not inside else None)
    )
    status = "found" if kind is not None else "failed"
    return LevelSetResult(value, status, method, prob.shape, x, vd, kind, details)


# ----------------------------------------------------------------------------- both


def level_search(
    system: System,
    V: QuadraticLyapunov,
    S: Any,
    *,
    shape: str = "custom",
    method: str = "both",
    sampled: dict[str, Any] | None = None,
    casadi: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Run one or both methods; returns ``{"value", "status", "method", "shape", "witness", ...}``.

    With one method its result is returned as is (status from :data:`LEVEL_STATUSES`). With
    ``method="both"``, ``per_method`` holds both results and only *successful* ones (status
    ``"found"``, both upper bounds of c* attained at their witnesses) give the value and witness:

    * both found: the smaller one; ``relative_difference`` is their gap and ``status`` is
      ``"agree"`` if it is <= :data:`AGREEMENT_RTOL`, else ``"disagree"``;
    * one found: its result, ``status`` ``"partial"`` (the other's status in ``per_method``);
    * none found: the common status of both if they agree (e.g. ``"unbounded"``),
      ``"not_locally_negative"`` if either says so, else ``"failed"``; the value is the smaller
      one (not an upper bound of c*).
    """
    if method not in METHODS:
        raise ValueError(f"method {method!r}: allowed {', '.join(METHODS)}")
    results = []
    if method in ("sampled", "both"):
        results.append(sampled_level(system, V, S, shape=shape, **(sampled or {})))
    if method in ("casadi", "both"):
        results.append(casadi_level(system, V, S, shape=shape, **(casadi or {})))
    if method != "both":
        return results[0].to_json()
    found = [r for r in results if r.status == "found"]
    best = min(found or results, key=lambda r: r.value)
    out = best.to_json()
    rel = float("inf")  # no gap measured unless both found
    if len(found) == 2:
        a, b = (r.value for r in found)
        rel = abs(a - b) / max(abs(a), abs(b)) if max(abs(a), abs(b)) > 0 else 0.0
        status = "agree" if rel <= AGREEMENT_RTOL else "disagree"
    elif len(found) == 1:
        status = "partial"
    else:
        statuses = {r.status for r in results}
        if len(statuses) == 1:
            status = statuses.pop()
        elif "not_locally_negative" in statuses:
            status = "not_locally_negative"
        else:
            status = "failed"
    out.update(
        method="both",
        status=status,
        relative_difference=rel,
        per_method={r.method: r.to_json() for r in results},
    )
    return out
