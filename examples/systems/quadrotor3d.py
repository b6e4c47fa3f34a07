"""Quadrotor in space under LQR: 9 states, sin/cos of roll and pitch.

States ``(x, y, z, vx, vy, vz, phi, theta, psi)`` (position, velocity, roll, pitch, yaw), unit
mass, gravity ``g = 9.81``; inputs: the thrust beyond hover ``u1`` (along the body axis) and the
attitude rates ``u2, u3, u4`` (an inner rate loop assumed perfect)::

    x'' = (g + u1) cos(phi) sin(theta)
    y'' = -(g + u1) sin(phi)
    z'' = (g + u1) cos(phi) cos(theta) - g
    phi' = u2,  theta' = u3,  psi' = u4,           u = -K x.

The thrust direction is written in the heading frame (``psi = 0``): the yaw enters only its own
rate loop. ``K`` is the LQR gain of the linearisation at hover (``Q = I``, ``R = I``, rounded to
4 decimals; ``tests/certification/test_sos_backoff.py`` recomputes it with scipy). The equilibrium is the
origin (hover). No LYAPUNOV_P: roa solves A'P + PA = -I for the linearisation."""

from roa import System

G = 9.81
K = (
    (0.0, 0.0, 1.0, 0.0, 0.0, 1.7321, 0.0, 0.0, 0.0),
    (0.0, -1.0, 0.0, 0.0, -1.4515, 0.0, 5.4294, 0.0, 0.0),
    (1.0, 0.0, 0.0, 1.4515, 0.0, 0.0, 0.0, 5.4294, 0.0),
    (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
)


def field(t, x, xp):
    u = [-sum(k * xi for k, xi in zip(row, x, strict=True) if k) for row in K]
    sphi, cphi = xp.sin(x[6]), xp.cos(x[6])
    sth, cth = xp.sin(x[7]), xp.cos(x[7])
    thrust = G + u[0]
    return (
        x[3],
        x[4],
        x[5],
        thrust * cphi * sth,
        -thrust * sphi,
        thrust * cphi * cth - G,
        u[1],
        u[2],
        u[3],
    )


SYSTEM = System(
    name="quadrotor3d",
    field=field,
    equilibrium=(0.0,) * 9,
    state_names=("x", "y", "z", "vx", "vy", "vz", "phi", "theta", "psi"),
    state_units=("m", "m", "m", "m/s", "m/s", "m/s", "rad", "rad", "rad"),
)
