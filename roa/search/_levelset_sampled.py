"""Sampled method of Khalil's level-set search (see :mod:`roa.search._levelset`).

Rays in random directions on the unit sphere of the shape; the first sign change of V' along each
ray is bracketed on a geometric radial grid and refined by bisection, then the best directions are
refined by sampling in caps around them: a round that finds an earlier crossing moves there and
widens the cap 1.5x, one that does not halves it; a direction is done after ``refine_rounds``
rounds in a row without improvement (its cap then 2^-refine_rounds of what it was). The cap adapts
so that the refinement converges in 10-30 states too, where a fixed shrinking schedule stopped
short of the optimum. The minimum over the sampled directions is an
upper bound of the largest level that decreases as the number of directions grows
(``details["convergence"]``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.lyapunov import Lyapunov
from roa.model._system import System
from roa.options import SampledOptions
from roa.search._levelset_core import LevelSetResult, Problem, crossings, finish, start, unit

#: A refined direction stops after at most this many rounds per allowed miss (a safety cap).
MAX_ROUNDS_PER_MISS = 50
#: A relative improvement below this counts as a miss (rounding-level gains do not widen the cap).
MIN_GAIN = 1e-12


def sampled_level(
    system: System,
    V: Lyapunov,
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
        The system, the Lyapunov candidate and the shape matrix (``None``: the shape is ``V``
        itself, for a non-quadratic ``V``; each ray's first violation then counts with its value
        ``V(x)``, and radii are measured near the equilibrium by V's Hessian).
    n_directions : int
        Number of random directions on the unit sphere of the shape (>= 16).
    r_max : float
        Search radius in shape units (sqrt(s)); rays without violation up to it count as infinite.
    n_radial : int
        Points of the geometric radial grid from ``1e-4 r_max`` to ``r_max`` used for bracketing.
    refine_rounds, refine_directions, n_candidates : int
        Cap refinement: rounds in a row without improvement that end a direction's refinement,
        directions per round, and how many of the best directions to refine.
    seed : int
        Random seed.
    """
    SampledOptions(
        n_directions=int(n_directions),
        r_max=r_max,
        n_radial=int(n_radial),
        refine_rounds=int(refine_rounds),
        refine_directions=int(refine_directions),
        n_candidates=int(n_candidates),
        seed=int(seed),
    )  # validates; fmt: skip
    prob, early = start(system, V, S, shape, "sampled")
    if early is not None:
        return early
    rng = np.random.default_rng(seed)
    n = system.n
    U = unit(rng.standard_normal((int(n_directions), n)))
    r_grid = r_max * np.geomspace(1e-4, 1.0, int(n_radial))
    r = crossings(prob, U, r_grid)
    key = _keys(prob, U, r)  # the shape value at each ray's first violation (r^2 if quadratic)
    convergence = []
    m = int(n_directions)
    sizes = sorted({max(16, m // 4**k) for k in range(4)})
    for size in sizes:
        value = np.min(r[:size]) ** 2 if not prob.by_value else np.min(key[:size])
        convergence.append({"n_directions": size, "value": float(value)})
    if not np.isfinite(r).any():
        top = float(r_max**2) if not prob.by_value else _top_value(prob, U, r_max)
        return LevelSetResult(
            top,
            "unbounded",
            "sampled",
            shape,
            None,
            None,
            details={"n_directions": m, "r_max": r_max, "convergence": convergence},
        )
    # Cap refinement around the best few (well separated) directions.
    order = np.argsort(key)
    cands: list[int] = []
    for i in order:
        if not np.isfinite(key[i]):
            break
        if all(abs(U[i] @ U[j]) < 0.95 for j in cands):
            cands.append(int(i))
        if len(cands) >= n_candidates:
            break
    best_r, best_u, best_k = np.inf, None, np.inf
    total_rounds = 0
    for i in cands:
        u, ru, ku = U[i], r[i], key[i]
        sigma, misses, rounds = 0.1, 0, 0
        while misses < int(refine_rounds) and rounds < MAX_ROUNDS_PER_MISS * int(refine_rounds):
            Z = unit(u + sigma * rng.standard_normal((int(refine_directions), n)))
            grid = ru * np.linspace(1.0 / 24, 1.25, 30)
            rz = crossings(prob, Z, grid)
            kz = _keys(prob, Z, rz)
            j = int(np.argmin(kz))
            rounds += 1
            gain = ku - kz[j]
            if gain > 0:
                u, ru, ku = Z[j], rz[j], kz[j]
            if gain > MIN_GAIN * abs(ku):  # success: widen the cap, else halve it
                sigma, misses = min(0.5, 1.5 * sigma), 0
            else:
                sigma, misses = 0.5 * sigma, misses + 1
        total_rounds += rounds
        if ku < best_k:
            best_r, best_u, best_k = ru, u, ku
    assert best_u is not None
    witness = prob.points(best_u, np.asarray(best_r))
    return finish(
        prob,
        witness,
        "sampled",
        {
            "n_directions": m,
            "r_max": r_max,
            "n_radial": int(n_radial),
            "raw_value": float(np.min(r) ** 2) if not prob.by_value else float(np.min(key)),
            "convergence": convergence,
            "refine_rounds": int(refine_rounds),
            "rounds_run": total_rounds,
            "seed": seed,
        },
    )


def _keys(prob: Problem, U: np.ndarray, r: np.ndarray) -> np.ndarray:
    """What ranks the rays: the radius (quadratic shape), else the shape value V at the crossing."""
    if not prob.by_value:
        return r
    out = np.full(len(r), np.inf)
    ok = np.isfinite(r)
    if ok.any():
        with np.errstate(all="ignore"):
            vals = prob.shape_value(prob.points(U[ok], r[ok]))
        out[ok] = np.where(np.isfinite(vals), vals, np.inf)
    return out


def _top_value(prob: Problem, U: np.ndarray, r_max: float) -> float:
    """The smallest V at radius ``r_max`` over the directions: a lower bound of the level."""
    with np.errstate(all="ignore"):
        vals = prob.shape_value(prob.points(U, np.full(len(U), r_max)))
    return float(np.nanmin(vals))
