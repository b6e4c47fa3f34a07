"""Three states, quadratic coupling: x1' = -x1 + x2 x3, x2' = -x2 + x1 x3, x3' = -x3 + x1 x2.

With V = |x|^2, V' = -2 |x|^2 + 6 x1 x2 x3. On the sphere |x|^2 = r^2 the product x1 x2 x3 is at most
(r^2 / 3)^(3/2) (AM-GM), so V' < 0 for r^2 < 3 and V' = 0 at x = (1, 1, 1): the largest level is 3
exactly (closed form). (1, 1, 1) is an equilibrium, so a run from it never converges."""

from roa import System


def field(t, x, xp):
    return (-x[0] + x[1] * x[2], -x[1] + x[0] * x[2], -x[2] + x[0] * x[1])


SYSTEM = System(
    name="poly3d",
    field=field,
    equilibrium=(0.0, 0.0, 0.0),
    state_names=("x1", "x2", "x3"),
    state_units=("1", "1", "1"),
)
LYAPUNOV_P = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
