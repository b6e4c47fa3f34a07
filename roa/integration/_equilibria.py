"""Other equilibria: where a run that did not converge to the studied equilibrium has settled."""

from __future__ import annotations

import numpy as np

from roa.model._system import System


def settled_elsewhere(
    system: System, x_end: np.ndarray, converge_tol: float
) -> tuple[np.ndarray, np.ndarray]:
    """Which final states sit at another equilibrium, and which one.

    A final state ``x`` (rows of ``x_end``) has settled elsewhere when ``|f(x)| < converge_tol``
    (``|F(x) - x|`` for a map: :meth:`roa.System.residual`), a
    root ``x*`` of ``f`` found from ``x`` (scipy's hybrid method) lies within ``converge_tol`` of
    it, and ``x*`` is more than ``converge_tol`` away from the studied equilibrium. Returns
    ``(mask, points)`` with ``points[i]`` the equilibrium found (NaN where ``mask`` is false).
    """
    from scipy import optimize  # here, not at import: scipy.optimize takes a while to load

    X = np.atleast_2d(np.asarray(x_end, dtype=float))
    mask = np.zeros(len(X), dtype=bool)
    points = np.full_like(X, np.nan)
    if system.equilibrium is None or system.time_varying or len(X) == 0:
        return mask, points
    with np.errstate(all="ignore"):
        speed = np.linalg.norm(system.residual(X), axis=1)
    for i in np.flatnonzero(np.isfinite(speed) & (speed < converge_tol)):
        with np.errstate(all="ignore"):
            sol = optimize.root(lambda x: system.residual(x), X[i], method="hybr", tol=1e-12)
        if not np.all(np.isfinite(sol.x)):
            continue
        with np.errstate(all="ignore"):
            residual = float(np.linalg.norm(system.residual(sol.x)))
        # hybr may stop "without progress" at a root it cannot improve: the residual decides
        if not (sol.success or residual <= 1e-10 * (1.0 + float(np.linalg.norm(sol.x)))):
            continue
        near = np.linalg.norm(sol.x - X[i]) <= converge_tol
        other = np.linalg.norm(sol.x - system.x_eq) > converge_tol
        inside = system.margin is None or bool(system.inside(sol.x))
        if near and other and inside:
            mask[i] = True
            points[i] = sol.x
    return mask, points
