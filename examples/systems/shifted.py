"""A shifted equilibrium: x' = -(x - 2) + (x - 2)^3, equilibrium x = 2 (the one-state cubic moved by
2). With V = (x - 2)^2 the largest level is 1 exactly; the basin is (1, 3)."""

from roa import System

SYSTEM = System(
    name="shifted-cubic",
    field=lambda t, x, xp: (-(x[0] - 2.0) + (x[0] - 2.0) ** 3,),
    equilibrium=(2.0,),
    state_names=("x",),
    state_units=("1",),
)
LYAPUNOV_P = [[1.0]]
