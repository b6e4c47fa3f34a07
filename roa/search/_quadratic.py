"""Search over quadratic Lyapunov functions for a larger certified region, in physical terms.

``P = L L'`` (``L`` lower triangular, normalised to ``trace(P) = trace(P0)``) is optimised with
Nelder-Mead; inside, the level ``rho(P)`` is the smallest ``V`` at which ``V' >= 0`` along a fixed
set of whitened rays (grid bracketing + bisection, vectorised). The objective is measured in the
*physical* coordinates of the user: either the smooth fraction of a reference box of physical
states inside ``{V(coords(x)) <= rho}`` (``objective="box"``) or the sector ``theta_max`` along a
curve of physical states (``objective="sector"``). The result is only a candidate: it is certified
afterwards by :func:`roa.proof.validate_level` at a level just below ``rho``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import optimize

from roa.errors import RoaInputError
from roa.lyapunov import QuadraticLyapunov
from roa.lyapunov._regions import symmetric_extent
from roa.model._system import System
from roa.search._levelset_core import crossings, problem

OBJECTIVES = ("box", "sector")


def ray_level(
    system: System,
    P: np.ndarray,
    directions: np.ndarray,
    *,
    r_max: float = 20.0,
    n_radial: int = 80,
    extra: np.ndarray | None = None,
) -> float:
    """min over rays ``x = x_eq + M (r u)`` (``M'PM = I``) of the first ``r^2`` with ``V' >= 0``.

    An upper bound of the largest level (a sampled estimate, not a proof); ``inf`` if no ray
    crosses within ``r_max``. ``extra`` adds rays given in the system's coordinates
    (``x - x_eq``, any length), e.g. the witnesses of earlier local searches.
    """
    V = QuadraticLyapunov.for_system(system, P)
    prob = problem(system, V, V.P, "level")  # rays whitened by V itself: shape radius^2 = V
    if extra is not None and len(extra):
        W = np.asarray(extra, dtype=float) @ np.linalg.cholesky(V.P)  # whitened: u = L' x
        W /= np.linalg.norm(W, axis=1, keepdims=True)
        directions = np.concatenate([directions, W, -W])
    r = np.geomspace(1e-2, r_max, n_radial)
    return float(np.min(crossings(prob, directions, r, iters=30)) ** 2)


def sector(
    form: Callable[[np.ndarray], np.ndarray], level: float, curve: Callable, t_max: float
) -> float:
    """Largest t in [0, t_max] with ``form(curve(s)) <= level`` for all |s| <= t (grid + bisection).

    A float estimate; :func:`roa.proof.certified_sector` proves a lower bound by intervals.
    """
    return symmetric_extent(lambda s: form(curve(s)) <= level, t_max, n_grid=2001, n_bisect=50)


@dataclass
class SearchResult:
    P: np.ndarray
    level: float
    objective: str
    value: float
    history: list[float] = field(default_factory=list)
    seconds: float = 0.0
    evaluations: int = 0
    rounds: list[dict[str, float]] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        return {
            "P": self.P.tolist(),
            "sampled_level": self.level,
            "objective": self.objective,
            "objective_value": self.value,
            "seconds": round(self.seconds, 2),
            "evaluations": self.evaluations,
            "rounds": self.rounds,
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
    rounds: int = 4,
    min_decay: float = 0.02,
    seed: int = 0,
) -> SearchResult:
    """Maximise the physical size of ``{V <= rho(P)}`` over positive-definite ``P``.

    ``rho(P)`` is the ray estimate of :func:`ray_level` (an upper bound). Sampling gaps would be
    exploited by the optimiser, so the search runs in ``rounds`` exchange rounds: after each
    Nelder-Mead run the level of the best ``P`` is recomputed by the multistart IPOPT search of
    :func:`roa.search.casadi_level`; if it is lower, its witness joins the rays and the search
    restarts from the best ``P``. The result is the round's ``P`` with the best objective measured
    at ``min(ray level, IPOPT level)`` (exchange rounds can lose ground), with that level.

    Parameters
    ----------
    system : System
        System in the analysis coordinates (with an equilibrium).
    P0 : ndarray
        Starting Lyapunov matrix (e.g. the paper's).
    to_analysis : callable
        Physical states ``(..., n)`` -> analysis coordinates (``inf`` where undefined).
    objective : {"box", "sector"}
        Smooth fraction of ``box`` inside the set, or the sector along ``curve`` (t -> states,
        t in [0, t_max]; V even and the curve odd are assumed, so only t >= 0 is scored).
    rounds : int
        Exchange rounds (>= 1), see above.
    min_decay : float
        Only ``P`` with ``A'P + PA <= -min_decay P`` (``A`` the Jacobian at the equilibrium) are
        admitted: nearly degenerate ``P`` have thin cones of ``V' >= 0`` that rays miss.
    """
    if system.time != "continuous":
        raise RoaInputError(f"system {system.name!r} is discrete-time: this search admits P by "
                            "A'P + PA, a flow's decrease")  # fmt: skip
    from roa.search._levelset import casadi_level, jacobian

    if objective not in OBJECTIVES:
        raise ValueError(f"objective {objective!r}: allowed {', '.join(OBJECTIVES)}")
    if int(rounds) < 1:
        raise ValueError(f"rounds must be >= 1, got {rounds}")
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
    else:
        tgrid = np.linspace(0.0, t_max, 801)[1:]
        Y = to_analysis(curve(tgrid)) - system.x_eq
        Y = np.where(np.isfinite(Y), Y, 1e150)
    A = jacobian(system)
    hist: list[float] = []
    active: list[np.ndarray] = []
    t0 = time.perf_counter()

    def score(theta: np.ndarray) -> float:
        P = _unpack(theta, n, trace)
        if np.linalg.eigvalsh(P)[0] <= 1e-8 * trace:
            return 1.0
        Li = np.linalg.inv(np.linalg.cholesky(P))
        if np.linalg.eigvalsh(Li @ (A.T @ P + P @ A) @ Li.T)[-1] > -min_decay:
            return 1.0  # V' <= -min_decay V fails near the equilibrium
        try:
            rho = ray_level(system, P, U, extra=np.array(active) if active else None)
        except np.linalg.LinAlgError:
            return 1.0
        if not np.isfinite(rho):
            return 1.0
        s = measure(P, rho)
        hist.append(s)
        return -s

    def measure(P: np.ndarray, rho: float) -> float:
        v = np.einsum("ki,ij,kj->k", Y, P, Y)
        if objective == "box":
            s = float(np.mean(1.0 / (1.0 + np.exp(np.clip((v / rho - 1.0) / 0.02, -50, 50)))))
        else:
            out = v > rho
            if not out.any():
                s = 1.0
            else:  # first grid point outside, interpolated for a continuous score
                k = int(np.argmax(out))
                v0 = v[k - 1] if k else 0.0
                t0_ = tgrid[k - 1] if k else 0.0
                frac = (rho - v0) / max(v[k] - v0, 1e-300)
                s = float(t0_ + frac * (tgrid[k] - t0_)) / t_max
        return s

    x0 = np.linalg.cholesky(P0)[np.tril_indices(n)]
    nfev = 0
    log = []
    best: tuple[float, np.ndarray, float] | None = None  # (checked objective, theta, level)
    for _ in range(int(rounds)):
        res = optimize.minimize(
            score,
            x0,
            method="Nelder-Mead",
            options={"maxiter": maxiter, "xatol": 1e-4, "fatol": 1e-6, "adaptive": True},
        )
        nfev += int(res.nfev)
        x0 = res.x
        P = _unpack(res.x, n, trace)
        rho_ray = ray_level(system, P, U, extra=np.array(active) if active else None)
        chk = casadi_level(system, QuadraticLyapunov.for_system(system, P), P, shape="level")
        rho = min(rho_ray, chk.value) if chk.status == "found" else rho_ray
        checked = measure(P, rho) if np.isfinite(rho) else 0.0
        log.append(
            {
                "objective": -float(res.fun),
                "ray_level": rho_ray,
                "local_level": chk.value,
                "checked_objective": checked,
            }
        )
        if best is None or checked > best[0]:
            best = (checked, res.x.copy(), rho)
        if chk.status != "found" or chk.value >= rho_ray * (1 - 1e-4):
            break
        active.append(np.asarray(chk.witness, dtype=float) - system.x_eq)
    assert best is not None
    return SearchResult(
        _unpack(best[1], n, trace),
        best[2],
        objective,
        best[0],
        hist,
        time.perf_counter() - t0,
        nfev,
        log,
    )
