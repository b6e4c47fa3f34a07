"""One state, cubic: x' = -x + x^3. Equilibrium 0; the basin is (-1, 1) (x = +-1 are equilibria,
|x| > 1 blows up in finite time). With V = x^2, V' = -2 x^2 (1 - x^2): the largest level is 1
exactly (closed form)."""

from roa import System

SYSTEM = System(
    name="one-state-cubic",
    field=lambda t, x, xp: (-x[0] + x[0] ** 3,),
    equilibrium=(0.0,),
    state_names=("x",),
    state_units=("1",),
)
LYAPUNOV_P = [[1.0]]
