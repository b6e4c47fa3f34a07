"""Two states, polynomial (Khalil, Nonlinear Systems, 3rd ed., Example 8.9 type):
x1' = -x1 + 2 x1^2 x2, x2' = -x2. The exact region of attraction is {x1 x2 < 1}. With V = |x|^2,
V' = -2 x1^2 + 4 x1^3 x2 - 2 x2^2; the largest level is computed independently in the tests by a
scipy multistart (min |x|^2 s.t. V'(x) = 0)."""

from roa import System

SYSTEM = System(
    name="poly2d",
    field=lambda t, x, xp: (-x[0] + 2.0 * x[0] ** 2 * x[1], -x[1]),
    equilibrium=(0.0, 0.0),
    state_names=("x1", "x2"),
    state_units=("1", "1"),
)
LYAPUNOV_P = [[1.0, 0.0], [0.0, 1.0]]
