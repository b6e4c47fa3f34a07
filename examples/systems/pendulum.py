"""Trigonometric: the damped pendulum theta' = omega, omega' = -sin(theta) - omega.

Stable equilibria at theta = 2 k pi (a run with enough energy settles at 2 pi: status
converged_elsewhere), saddles at (2 k + 1) pi. No LYAPUNOV_P: roa solves A'P + PA = -I."""

from roa import System

SYSTEM = System(
    name="damped-pendulum",
    field=lambda t, x, xp: (x[1], -xp.sin(x[0]) - x[1]),
    equilibrium=(0.0, 0.0),
    state_names=("theta", "omega"),
    state_units=("rad", "rad/s"),
)
