"""A user's own system for roa: the time-reversed Van der Pol oscillator.

Run the README tutorial on it:

    roa khalil  --system examples/vanderpol_system.py:SYSTEM --shape level --json
    roa certify --system examples/vanderpol_system.py:SYSTEM --method both --json
    roa basin   --system examples/vanderpol_system.py:SYSTEM --slice x1,x2 --grid 200x200 \
                --box x1=-3:3,x2=-3:3 --plot vdp_basin.png --json
"""

from roa import System


def field(t, x, xp):
    """x1' = -x2, x2' = x1 + (x1^2 - 1) x2; ``xp`` is the array namespace (numpy, CasADi, ...)."""
    return (-x[1], x[0] + (x[0] ** 2 - 1) * x[1])


SYSTEM = System(
    name="my-vanderpol",
    field=field,
    equilibrium=(0.0, 0.0),
    state_names=("x1", "x2"),
    state_units=("1", "1"),
)

#: Optional: the Lyapunov matrix to analyse (otherwise roa solves A'P + PA = -I).
LYAPUNOV_P = [[1.5, -0.5], [-0.5, 1.0]]
