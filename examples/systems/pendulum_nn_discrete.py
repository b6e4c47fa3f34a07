"""The neural-network pendulum of ``pendulum_nn.py`` in discrete time: one Euler step of
``h = 0.05 s`` per sample, ``x+ = x + h f(x, net(x))``.

The controller ``u = net(x) - net(0)`` (the committed tanh network) is evaluated at the sample and
held over the step: the map is the loop a digital controller runs. ``roa`` certifies the map itself
(``Delta V = V(F(x)) - V(x) < 0`` on ``{V <= c}``, ``V`` from ``A'PA - P = -I``), with no hole at
the origin (the Hessian of ``Delta V`` bounded over a box around it), and iterates it for basins::

    roa certify --system examples/systems/pendulum_nn_discrete.py:SYSTEM --level 300
    roa basin --system examples/systems/pendulum_nn_discrete.py:SYSTEM ...

``SYSTEM_RK4`` is the classical Runge-Kutta step of the same loop (the network evaluated at each
stage: four network evaluations per step, so its branch and bound costs about four times more).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pendulum_nn import load  # noqa: E402

from roa.model import discretise  # noqa: E402

#: The sample time (s).
H = 0.05

SYSTEM = discretise(load("tanh"), H, "euler", name="pendulum-nn-tanh-euler")
SYSTEM_RK4 = discretise(load("tanh"), H, "rk4", name="pendulum-nn-tanh-rk4")
