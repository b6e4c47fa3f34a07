"""Searches for a refutation of a level at the sample points of a parameter box (propose only).

A point returned here is a proposal: :func:`roa.proof._robust.validate_robust` counts it only once
:func:`roa.proof.recheck_witness` has confirmed it at 50 digits in the equilibrium's
component.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.lyapunov import Lyapunov
from roa.model._parameters import sample_points
from roa.model._system import System

#: Directions of the sampled witness search at each sample point of the box.
WITNESS_DIRECTIONS = 4000


def sampled_witness(
    system: System, lyap: Lyapunov, level: float, *, directions: int = WITNESS_DIRECTIONS
) -> tuple[np.ndarray | None, dict[str, float], dict[str, Any] | None]:
    """``(x, p, check)``: a confirmed witness of ``V'_p(x) >= 0`` inside ``{V <= level}`` at one of
    the box's sample points (:func:`roa.model._parameters.sample_points`), else ``(None, p, None)`` with
    ``p`` the sample point of the lowest sampled level (the likely worst case). A search: no
    witness proves nothing."""
    from roa.options import SampledOptions
    from roa.proof._cover import connected_to_center
    from roa.proof._witness import recheck_witness
    from roa.search._levelset import level_search

    best: tuple[float, np.ndarray, dict[str, float], System] | None = None
    opts = SampledOptions(n_directions=directions)
    points = sample_points(system)
    for p in points:
        fixed = system.at(**p)
        near = _near_equilibrium(fixed, lyap, level)
        if near is not None:
            return near[0], p, near[1]
        res = level_search(fixed, lyap, shape="level", method="sampled", sampled=opts)
        if res.level is None or res.witness is None:
            continue
        if best is None or res.level < best[0]:
            best = (float(res.level), np.asarray(res.witness, dtype=float), p, fixed)
    if best is None:
        return None, points[0], None
    value, w, p, fixed = best
    if value < level:
        check = recheck_witness(fixed, lyap, w, level)
        if check["confirmed"] and connected_to_center(lyap, w, level):
            return w, p, check
    return None, p, None


def _near_equilibrium(
    system: System, lyap: Lyapunov, level: float
) -> tuple[np.ndarray, dict[str, Any]] | None:
    """Where ``V'`` is not negative definite to second order at the equilibrium (``A'H + HA`` has
    an eigenvalue > 0, ``H`` half the Hessian of V): a confirmed witness ``x_eq + t u`` along its
    eigenvector ``u`` inside ``{V <= level}`` (``t`` halved until ``V' >= 0`` holds at 50 digits),
    or None. A search."""
    from roa.model._linearisation import decrease_matrix, linearise
    from roa.proof._cover import connected_to_center
    from roa.proof._witness import recheck_witness

    H = 0.5 * lyap.hessian_at_center()
    A = linearise(system).A
    Q = decrease_matrix(system, A, H)  # A'H + HA, or A'HA - H for a map
    w, U = np.linalg.eigh(0.5 * (Q + Q.T))
    if not w[-1] > 0:
        return None
    u, c = U[:, -1], np.asarray(lyap.center, dtype=float)
    t = 1.0
    for _ in range(60):  # down to V(c + t u) < level
        if float(lyap.value((c + t * u)[None])[0]) < level:
            break
        t *= 0.5
    for _ in range(40):
        x = c + t * u
        check = recheck_witness(system, lyap, x, level)
        if check["confirmed"] and connected_to_center(lyap, x, level):
            return x, check
        t *= 0.5
    return None
