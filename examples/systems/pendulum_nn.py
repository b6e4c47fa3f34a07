"""A damped pendulum under neural-network controllers: ``theta'' = -sin(theta) - 0.1 theta' + u``.

``u = net(x) - net(0)`` with ``net`` a 2-16-1 multilayer perceptron trained by
``examples/train_pendulum_nn.py`` (least squares imitation of the LQR law of the linearisation);
the weights are committed next to this file (``pendulum_nn_tanh.npz``, ``pendulum_nn_relu.npz``).
Centring the network (:meth:`roa.nn.MLP.centred`) makes the origin an exact equilibrium.

* ``SYSTEM``: tanh hidden layer (smooth: the local proof near the equilibrium bounds the Hessian
  of V' with second-order jets through the network);
* ``SYSTEM_RELU``: ReLU hidden layer. No bias is 0, so no unit is at its kink at the origin and
  the network is affine on a neighbourhood of it: on a small enough box around the origin every
  unit's phase is decided by intervals, the jets take the linear branch and the same Hessian
  proof applies (the kinks elsewhere are handled by generalised gradients in the branch and
  bound).

No LYAPUNOV_P: roa solves A'P + PA = -I for the closed loop's Jacobian (CasADi, through the
network). ``load(activation, path)`` builds the system from another weight file.
"""

from __future__ import annotations

from pathlib import Path

from roa import System
from roa.nn import MLP

HERE = Path(__file__).resolve().parent
DAMPING = 0.1


def load(activation: str = "tanh", path: str | Path | None = None) -> System:
    """The closed loop with the network of ``path`` (default: the committed weights)."""
    net = MLP.load(path or HERE / f"pendulum_nn_{activation}.npz").centred([0.0, 0.0])

    def field(t, x, xp):
        u = net([x[0], x[1]], xp)[0]
        return (x[1], -xp.sin(x[0]) - DAMPING * x[1] + u)

    return System(
        name=f"pendulum-nn-{activation}",
        field=field,
        equilibrium=(0.0, 0.0),
        state_names=("theta", "omega"),
        state_units=("rad", "rad/s"),
    )


SYSTEM = load("tanh")
SYSTEM_RELU = load("relu")
