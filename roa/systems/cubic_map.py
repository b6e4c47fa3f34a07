"""A discrete-time polynomial map with a closed-form largest level: ``x+ = (lam + mu x1^2) R x``.

``R`` is the rotation by ``theta``, ``0 <= lam < 1`` and ``mu > 0``. The linearisation
``A = lam R`` is Schur and ``A'PA - P = -I`` has the solution ``P = p I`` with
``p = 1 / (1 - lam^2)`` (``R'R = I``). For ``V = p |x|^2``,
``Delta V = V(F(x)) - V(x) = p |x|^2 ((lam + mu x1^2)^2 - 1)``, negative exactly where
``x1^2 < (1 - lam) / mu`` (away from 0). The largest level with ``Delta V < 0`` on
``{V <= c} \\ {0}`` is therefore

    c* = p (1 - lam) / mu = 1 / (mu (1 + lam)),

reached at ``x = (+-sqrt((1 - lam) / mu), 0)`` (``2/3`` for the defaults ``lam = 0.5``,
``mu = 1``).
"""

from __future__ import annotations

import math
from typing import Any

from roa.errors import RoaInputError
from roa.model._system import System


def optimum(lam: float = 0.5, mu: float = 1.0) -> float:
    """The closed-form largest level ``c* = 1 / (mu (1 + lam))`` for ``V = |x|^2 / (1 - lam^2)``."""
    return 1.0 / (mu * (1.0 + lam))


def cubic_map(lam: float = 0.5, mu: float = 1.0, theta: float = 0.7) -> System:
    """The map of the module doc with parameters ``lam`` (in [0, 1)), ``mu`` (> 0), ``theta``."""
    lam, mu, theta = float(lam), float(mu), float(theta)
    if not 0 <= lam < 1:
        raise RoaInputError(f"lam must be in [0, 1), got {lam!r}")
    if not mu > 0:
        raise RoaInputError(f"mu must be > 0, got {mu!r}")
    if not math.isfinite(theta):
        raise RoaInputError(f"theta must be finite, got {theta!r}")
    return System.discrete(
        step,
        name="cubic-map",
        equilibrium=(0.0, 0.0),
        state_names=("x1", "x2"),
        state_units=("1", "1"),
        params={"lam": lam, "mu": mu, "c": math.cos(theta), "s": math.sin(theta)},
    )


def step(t: Any, x: Any, xp: Any, p: Any) -> tuple:
    """``(lam + mu x1^2) R x`` (``R`` with the doubles ``c = cos theta``, ``s = sin theta``)."""
    g = p.lam + p.mu * x[0] * x[0]
    return (g * (p.c * x[0] - p.s * x[1]), g * (p.s * x[0] + p.c * x[1]))
