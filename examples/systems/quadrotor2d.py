"""Planar quadrotor under a linear (LQR-type) feedback: 6 states, sin/cos of the pitch angle.

The control-affine model of LyZNet's ICML'24 example (``examples/icml24-pinn-pi/2d_quad``):
states ``(x, y, theta, x', y', theta')``, gravity ``g = 9.81``, mass and inertia 1, inputs
``u1`` (thrust beyond hover, along the body axis) and ``u2`` (torque)::

    x''     = g sin(theta) + u1 sin(theta)
    y''     = -g + g cos(theta) + u1 cos(theta)
    theta'' = u2,                 u = -K x,

with LyZNet's gain ``K`` (rows ``u1``, ``u2``). The equilibrium is the origin (hover). No
LYAPUNOV_P: roa solves A'P + PA = -I for the linearisation."""

from roa import System

G = 9.81
K = (
    (0.0, 1.0, 0.0, 0.0, 1.7321, 0.0),
    (1.0, 0.0, 13.5165, 1.938, 0.0, 5.2946),
)


def field(t, x, xp):
    u1 = -(K[0][1] * x[1] + K[0][4] * x[4])
    u2 = -(K[1][0] * x[0] + K[1][2] * x[2] + K[1][3] * x[3] + K[1][5] * x[5])
    s, c = xp.sin(x[2]), xp.cos(x[2])
    return (x[3], x[4], x[5], G * s + u1 * s, -G + G * c + u1 * c, u2)


SYSTEM = System(
    name="quadrotor2d",
    field=field,
    equilibrium=(0.0,) * 6,
    state_names=("x", "y", "theta", "vx", "vy", "omega"),
    state_units=("m", "m", "rad", "m/s", "m/s", "rad/s"),
)
