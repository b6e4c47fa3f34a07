"""The time-reversed Van der Pol oscillator, a standard region-of-attraction benchmark.

x1' = -x2, x2' = x1 + (x1^2 - 1) x2. With V = x'Px, P = [[1.5, -0.5], [-0.5, 1]], the largest level
with V' < 0 on {V <= rho} is rho = 2.3045 (Tedrake, Underactuated Robotics course notes; LyZNet's
dReal bisection gives 2.3042).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.model._system import System

#: Lyapunov matrix of the published benchmark.
P_BENCHMARK = np.array([[1.5, -0.5], [-0.5, 1.0]])
#: Published largest certified level (Drake course notes).
RHO_BENCHMARK = 2.3045


def vanderpol(mu: float = 1.0) -> System:
    """Time-reversed Van der Pol oscillator with damping parameter ``mu`` (> 0)."""
    mu = float(mu)
    if not mu > 0:
        raise RoaInputError(f"mu must be > 0, got {mu!r}")

    return System(
        name="vanderpol",
        field=field,
        equilibrium=(0.0, 0.0),
        state_names=("x1", "x2"),
        state_units=("1", "1"),
        lyapunov=P_BENCHMARK if mu == 1.0 else None,  # the published P is for mu = 1
        params={"mu": mu},
    )


def field(t: Any, x: Any, xp: Any, p: Any) -> tuple:
    """``x1' = -x2``, ``x2' = x1 + mu (x1^2 - 1) x2``."""
    return (-x[1], x[0] + p.mu * (x[0] * x[0] - 1) * x[1])
