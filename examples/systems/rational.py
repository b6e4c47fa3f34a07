"""Rational field: x1' = -x1 + x1^2 / (1 + x2^2), x2' = -x2.

On x2 = 0 the field is x1' = -x1 + x1^2, an equilibrium at x1 = 1; with V = |x|^2,
V' = 2 x1^2 (x1 / (1 + x2^2) - 1) - 2 x2^2, zero at (1, 0) and negative on 0 < |x|^2 < 1 (for x1 <= 0
both terms are <= 0 and not both 0; for 0 < x1 < 1, x1 / (1 + x2^2) < 1): the largest level is 1."""

from roa import System

SYSTEM = System(
    name="rational",
    field=lambda t, x, xp: (-x[0] + x[0] ** 2 / (1.0 + x[1] ** 2), -x[1]),
    equilibrium=(0.0, 0.0),
    state_names=("x1", "x2"),
    state_units=("1", "1"),
)
LYAPUNOV_P = [[1.0, 0.0], [0.0, 1.0]]
