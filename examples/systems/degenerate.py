"""Degenerate linearisation (zero Jacobian): x1' = -x1^3 + x1^5, x2' = -x2^3.

With V = |x|^2, V' = -2 x1^4 + 2 x1^6 - 2 x2^4 < 0 unless x1^2 >= 1: negative but quartic near the
origin, and zero at (+-1, 0): the largest level is 1 exactly (closed form). The linearisation is zero,
so A'P + PA = 0 says nothing; higher-order terms decide."""

from roa import System

SYSTEM = System(
    name="degenerate",
    field=lambda t, x, xp: (-(x[0] ** 3) + x[0] ** 5, -(x[1] ** 3)),
    equilibrium=(0.0, 0.0),
    state_names=("x1", "x2"),
    state_units=("1", "1"),
)
LYAPUNOV_P = [[1.0, 0.0], [0.0, 1.0]]
