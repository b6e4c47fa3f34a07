"""Points just outside a system's domain with V as low as found: proposals of a refutation of
the levels whose sets leave the domain, each proved or not by
:func:`roa.proof._domain.confirmed_outside` (50 digits, the equilibrium's component)."""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.lyapunov import Lyapunov
from roa.model._backend import namespace
from roa.model._system import System
from roa.proof._domain import confirmed_outside


def _boundary_points(system: System, V: Lyapunov, n_dirs: int, seed: int) -> np.ndarray:
    """Points just outside the domain on rays from the centre (the first crossing of each ray
    within ``|d| <= 2^40``, located by bisection)."""
    n, c = V.n, np.asarray(V.center, dtype=float)
    rng = np.random.default_rng(seed)
    dirs = np.concatenate([np.eye(n), -np.eye(n), rng.standard_normal((n_dirs, n))])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    t_hi = np.full(len(dirs), 2.0**-20)
    out = np.zeros(len(dirs), dtype=bool)
    with np.errstate(all="ignore"):
        for _ in range(61):  # grow until the ray leaves the domain
            grow = ~out & (t_hi < 2.0**40)
            if not grow.any():
                break
            left = ~system.inside(c + t_hi[grow, None] * dirs[grow])
            out[np.flatnonzero(grow)[left]] = True
            t_hi[np.flatnonzero(grow)[~left]] *= 2.0
        dirs, t_hi = dirs[out], t_hi[out]
        t_lo = np.zeros(len(dirs))
        for _ in range(60):
            mid = 0.5 * (t_lo + t_hi)
            inside = system.inside(c + mid[:, None] * dirs)
            t_lo, t_hi = np.where(inside, mid, t_lo), np.where(inside, t_hi, mid)
    return c + t_hi[:, None] * dirs


def domain_witness(
    system: System, V: Lyapunov, *, n_dirs: int = 400, seed: int = 0
) -> tuple[float, np.ndarray, dict[str, Any]] | None:
    """``(V(x), x, check)``: a point ``x`` outside the domain (``margin(x) <= 0``) whose value
    bounds from above every level whose set stays inside the domain: ``V(x) <= V(x)`` and
    ``margin(x) <= 0`` re-checked at 50 digits, ``x`` proved to lie in the equilibrium's component
    of ``{V <= V(x) (1 + 1e-12)}``. None when no such point is found (the domain may hold every
    level set)."""
    from scipy.optimize import minimize

    if system.margin is None:
        return None
    pts = _boundary_points(system, V, n_dirs, seed)
    if not len(pts):
        return None
    with np.errstate(all="ignore"):
        vals = V.value(pts)
    order = np.argsort(np.where(np.isfinite(vals), vals, np.inf))[:3]

    def margin(x: np.ndarray) -> float:
        return float(np.asarray(system.margin(list(x), namespace("numpy"))))  # type: ignore[misc]

    best: tuple[float, np.ndarray, dict[str, Any]] | None = None
    for i in order:
        starts = [pts[i]]
        with np.errstate(all="ignore"):
            res = minimize(lambda x: float(V.value(x[None])[0]), pts[i], method="SLSQP",
                           constraints=[{"type": "ineq", "fun": lambda x: -margin(x)}],
                           options={"maxiter": 200, "ftol": 1e-15})  # fmt: skip
        if np.all(np.isfinite(res.x)):
            starts.insert(0, np.asarray(res.x, dtype=float))
        for x in starts:
            with np.errstate(all="ignore"):
                v = float(V.value(x[None])[0])
            if not (np.isfinite(v) and v > 0) or (best is not None and v >= best[0]):
                continue
            found = confirmed_outside(system, V, x)
            if found is not None:
                best = (found[0], x, found[1])
                break
    return best
