"""Search over quadratic Lyapunov functions for a larger certified region, in physical terms.

``P = L L'`` (``L`` lower triangular, normalised to ``trace(P) = trace(P0)``) is optimised with
Nelder-Mead; inside, the level ``rho(P)`` is the smallest ``V`` at which ``V' >= 0`` along a fixed
set of whitened rays (grid bracketing + bisection, vectorised). The objective is measured in the
*physical* coordinates of the user: either the smooth fraction of a reference box of physical
states inside ``{V(coords(x)) <= rho}`` (``objective="box"``) or the sector ``theta_max`` along a
curve of physical states (``objective="sector"``). The result is only a candidate: it is certified
afterwards by :func:`roa.certify.validate.validate_level` at a level just below ``rho``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import optimize

from roa.lyapunov import QuadraticLyapunov
from roa.system import System

OBJECTIVES = ("box", "sector")


def ray_level(
    system: System,
    P: np.ndarray,
    directions: np.ndarray,
    *,
    r_max: float = 20.0,
    n_radial: int = 80,
) -> float:
    """min over rays ``x = x_eq + M (r u)`` (``M'PM = I``) of the first ``r^2`` with ``V' >= 0``.

    An upper bound of the largest level (a sampled estimate, not a proof); ``inf`` if no ray
    crosses within ``r_max``.
    """
    V = QuadraticLyapunov.for_system(system, P)
    M = np.linalg.inv(np.linalg.cholesky(V.P).T)
    X = directions @ M.T  # (k, n): x - x_eq per unit whitened step
    r = np.geomspace(1e-2, r_max, n_radial)
    pts = V.center + r[None, :, None] * X[:, None, :]
    with np.errstate(all="ignore"):
        bad = ~(V.derivative(system, pts) < 0)
    hit = bad.any(axis=1)
    if not hit.any():
        return float("inf")
    k = np.argmax(bad, axis=1)[hit]
    hi = r[k]
    lo = np.where(k > 0, r[np.maximum(k - 1, 0)], 0.0)
    Xh = X[hit]
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        with np.errstate(all="ignore"):
            b = ~(V.derivative(system, V.center + mid[:, None] * Xh) < 0)
        hi = np.where(b, mid, hi)
        lo = np.where(b, lo, mid)
    return float(np.min(hi) ** 2)


def sector(
    form: Callable[[np.ndarray], np.ndarray], level: float, curve: Callable, t_max: float
) -> float:
    """Largest t in [0, t_max] with ``form(curve(s)) <= level`` for all |s| <= t (grid + bisection)."""
    grid = np.linspace(0.0, t_max, 2001)[1:]
    out = []
    for sgn in (1.0, -1.0):
        inside = form(curve(sgn * grid)) <= level
        if inside.all():
            out.append(t_max)
            continue
        k = int(np.argmin(inside))
        lo, hi = (grid[k - 1] if k else 0.0), grid[k]
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            if form(curve(np.array([sgn * mid])))[0] <= level:
                lo = mid
            else:
                hi = mid
        out.append(lo)
    return float(min(out))


@dataclass
class SearchResult:
    P: np.ndarray
    level: float
    objective: str
    value: float
    history: list[float] = field(default_factory=list)
    seconds: float = 0.0
    evaluations: int = 0

    def to_json(self) -> dict[str, Any]:
        return {
            "P": self.P.tolist(),
            "sampled_level": self.level,
            "objective": self.objective,
            "objective_value": self.value,
            "seconds": round(self.seconds, 2),
            "evaluations": self.evaluations,
        }


def _unpack(theta: np.ndarray, n: int, trace: float) -> np.ndarray:
    L = np.zeros((n, n))
    L[np.tril_indices(n)] = theta
    P = L @ L.T + 1e-9 * np.eye(n)
    return P * (trace / np.trace(P))


def optimise_quadratic(
    system: System,
    P0: np.ndarray,
    to_analysis: Callable[[np.ndarray], np.ndarray],
    *,
    objective: str = "box",
    box: tuple | None = None,
    curve: Callable | None = None,
    t_max: float = 1.5,
    n_directions: int = 1500,
    n_box: int = 4000,
    maxiter: int = 400,
    seed: int = 0,
) -> SearchResult:
    """Maximise the physical size of ``{V <= rho(P)}`` over positive-definite ``P``.

    Parameters
    ----------
    system : System
        System in the analysis coordinates (with an equilibrium).
    P0 : ndarray
        Starting Lyapunov matrix (e.g. the paper's).
    to_analysis : callable
        Physical states ``(..., n)`` -> analysis coordinates (``inf`` where undefined).
    objective : {"box", "sector"}
        Smooth fraction of ``box`` inside the set, or the sector along ``curve`` (t -> states).
    """
    if objective not in OBJECTIVES:
        raise ValueError(f"objective {objective!r}: allowed {', '.join(OBJECTIVES)}")
    n = system.n
    rng = np.random.default_rng(seed)
    U = rng.normal(size=(n_directions, n))
    U /= np.linalg.norm(U, axis=1, keepdims=True)
    U = np.concatenate([U, -U])
    trace = float(np.trace(P0))
    if objective == "box":
        if box is None:
            raise ValueError("objective 'box' needs box=((lo, hi), ...)")
        b = np.asarray(box, dtype=float)
        Y = to_analysis(b[:, 0] + (b[:, 1] - b[:, 0]) * rng.random((n_box, n))) - system.x_eq
    elif curve is None:
        raise ValueError("objective 'sector' needs curve(t) -> physical states")
    hist: list[float] = []
    t0 = time.perf_counter()

    def score(theta: np.ndarray) -> float:
        P = _unpack(theta, n, trace)
        if np.linalg.eigvalsh(P)[0] <= 1e-8 * trace:
            return 1.0
        try:
            rho = ray_level(system, P, U)
        except np.linalg.LinAlgError:
            return 1.0
        if not np.isfinite(rho):
            return 1.0
        if objective == "box":
            v = np.einsum("ki,ij,kj->k", Y, P, Y)
            s = float(np.mean(1.0 / (1.0 + np.exp(np.clip((v / rho - 1.0) / 0.02, -50, 50)))))
        else:
            s = (
                sector(
                    lambda X: np.einsum(
                        "ki,ij,kj->k", to_analysis(X) - system.x_eq, P, to_analysis(X) - system.x_eq
                    ),
                    rho,
                    curve,
                    t_max,
                )
                / t_max
            )
        hist.append(s)
        return -s

    L0 = np.linalg.cholesky(P0)
    res = optimize.minimize(
        score,
        L0[np.tril_indices(n)],
        method="Nelder-Mead",
        options={"maxiter": maxiter, "xatol": 1e-4, "fatol": 1e-6, "adaptive": True},
    )
    P = _unpack(res.x, n, trace)
    return SearchResult(
        P,
        ray_level(system, P, U),
        objective,
        -float(res.fun),
        hist,
        time.perf_counter() - t0,
        int(res.nfev),
    )
