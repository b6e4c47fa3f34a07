"""The lowest witness near a point of ``{V' >= 0}``: a local minimum of V there (SLSQP), proposed
to :func:`roa.proof._witness.confirmed_bound`, which proves it or not.

A refuted validation, or a level search, gives a point ``w`` with ``V'(w) >= 0``. The least value
of V on ``{V' >= 0}`` bounds the largest certifiable level; a local minimum near ``w`` is the
proposal that bounds it most tightly. Only the proof's confirmation makes it a bound.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.lyapunov import Lyapunov
from roa.model._system import System
from roa.proof._witness import confirmed_bound


def lowest_confirmed_witness(
    system: System, V: Lyapunov, w: np.ndarray
) -> tuple[float, np.ndarray | None, dict[str, Any] | None]:
    """``(value, x, check)``: a local minimum ``x`` of V on ``{V' >= delta}`` from ``w`` (SLSQP,
    ``delta`` 1e-12, 1e-10, 1e-8 in turn) at most ``V(w) (1 + 1e-6)`` that
    :func:`~roa.proof._witness.confirmed_bound` proves (``V' >= 0`` at 50 digits, in the
    equilibrium's component of ``{V <= V(x)}``); ``(V(w), None, None)`` when none is
    (SLSQP may end a hair above a ``w`` that is already a local minimum; a confirmed ``x`` is a
    valid bound whatever its value). A confirmed ``x`` bounds the true optimum of V by ``V(x)``
    (the validation's witness sits on the level it refuted, the level search's near the touching
    point; the minimum is where V' = 0 first touches a level surface)."""
    from scipy.optimize import minimize

    with np.errstate(all="ignore"):
        best = float(V.value(w[None])[0])

    def vdot(x: np.ndarray) -> float:
        return float(V.derivative(system, x[None])[0])

    for delta in (1e-12, 1e-10, 1e-8):
        with np.errstate(all="ignore"):
            res = minimize(lambda x: float(V.value(x[None])[0]), w, method="SLSQP",
                           constraints=[{"type": "ineq", "fun": lambda x, dl=delta: vdot(x) - dl}],
                           options={"maxiter": 300, "ftol": 1e-15})  # fmt: skip
            x = np.asarray(res.x, dtype=float)
            v = float(V.value(x[None])[0])
        if not (np.isfinite(v) and 0 < v < best * (1 + 1e-6)):
            continue
        found = confirmed_bound(system, V, x)
        if found is not None:
            return found[0], x, found[1]
    return best, None, None
