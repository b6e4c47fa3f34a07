"""Planar quadrotor under neural-network controllers: 6 states, sin/cos of the pitch angle.

The model of ``examples/systems/quadrotor2d.py`` (states ``(x, y, theta, x', y', theta')``,
``g = 9.81``, mass and inertia 1; ``u1`` thrust beyond hover, ``u2`` torque)::

    x''     = g sin(theta) + u1 sin(theta)
    y''     = -g + g cos(theta) + u1 cos(theta)
    theta'' = u2,                 (u1, u2) = net(x) - net(0),

with ``net`` a 6-16-16-2 multilayer perceptron trained by ``examples/train_quadrotor_nn.py``
(imitation of the LQR law of the linearisation at hover); the weights are committed next to this
file (``quadrotor_nn_tanh.npz``, ``quadrotor_nn_relu.npz``). Centring the network makes hover an
exact equilibrium. Every hidden unit's pre-activation at hover is at least 0.1 away from 0, so
the ReLU network is affine on a neighbourhood of the equilibrium and the Hessian proof near it
applies (as for ``pendulum_nn.py``).

* ``SYSTEM``: tanh hidden layers; ``SYSTEM_RELU``: ReLU hidden layers.

No LYAPUNOV_P: roa solves A'P + PA = -I for the closed loop's Jacobian.
"""

from __future__ import annotations

from pathlib import Path

from roa import System
from roa.nn import MLP

HERE = Path(__file__).resolve().parent
G = 9.81


def load(activation: str = "tanh", path: str | Path | None = None) -> System:
    """The closed loop with the network of ``path`` (default: the committed weights)."""
    net = MLP.load(path or HERE / f"quadrotor_nn_{activation}.npz").centred([0.0] * 6)

    def field(t, x, xp):
        u1, u2 = net(list(x[:6]), xp)
        s, c = xp.sin(x[2]), xp.cos(x[2])
        return (x[3], x[4], x[5], G * s + u1 * s, -G + G * c + u1 * c, u2)

    return System(
        name=f"quadrotor-nn-{activation}",
        field=field,
        equilibrium=(0.0,) * 6,
        state_names=("x", "y", "theta", "vx", "vy", "omega"),
        state_units=("m", "m", "rad", "m/s", "m/s", "rad/s"),
    )


SYSTEM = load("tanh")
SYSTEM_RELU = load("relu")
