"""A python-control model: a pendulum balanced on a cart, LQR from ``control.lqr``.

The plant is a ``control.nlsys`` written with numpy, as python-control users write it: the pendulum
angle theta from upright (rad) and its rate omega (rad/s), driven by the cart's acceleration a
(m/s^2), ``theta'' = (g sin(theta) - a cos(theta)) / l - b omega``. The gain comes from
``control.lqr`` on the linearisation, and ``roa.System.from_control`` builds the closed loop
a = -K x (it traces the numpy updfcn into an expression roa evaluates with intervals, and checks it
against the updfcn). The model holds while the pendulum is above the horizontal (|theta| < pi/2,
the domain), where the cart's acceleration loses its grip (cos(theta) -> 0).

Needs python-control: ``pip install ".[control]"`` in a clone of roa (or ``pip install control``).

    python examples/control_pendulum.py [--quick] [--out results-examples]
"""

from __future__ import annotations

import time

import control
import numpy as np
from _gallery import parse, regions, summary, write

import roa

PARAMS = {"g": 9.81, "l": 0.5, "b": 0.1}


def updfcn(t, x, u, params):
    g, l, b = params["g"], params["l"], params["b"]
    return [x[1], (g * np.sin(x[0]) - u[0] * np.cos(x[0])) / l - b * x[1]]


def closed_loop() -> tuple[roa.System, np.ndarray]:
    plant = control.nlsys(updfcn, None, inputs=["a"], states=["theta", "omega"],
                          params=PARAMS, name="pendulum-on-cart")  # fmt: skip
    linear = plant.linearize([0.0, 0.0], [0.0])
    K, _, _ = control.lqr(linear, np.diag([1.0, 0.1]), np.eye(1))
    system = roa.System.from_control(plant, K, state_units=("rad", "rad/s"),
                                     margin=lambda x, xp: xp.cos(x[0]),
                                     domain_description="|theta| < pi/2")  # fmt: skip
    return system, K


def main(argv: list[str] | None = None) -> dict:
    args = parse(argv, __doc__)
    started = time.perf_counter()
    system, K = closed_loop()
    V = roa.default_lyapunov(system)
    search = roa.level_search(system, V, shape="level", method="both")
    cert = roa.certify(system, V, candidate=search, check_above=1.001)
    n = 15 if args.quick else 120
    grid = roa.grid_slice(system, ("theta", "omega"), [(-1.6, 1.6), (-6.0, 6.0)], (n, n))
    drawn = regions(V, search, cert)
    basin = roa.basin(system, grid, run=roa.RunOptions(n_jobs=1), regions=drawn)
    data = summary(search, cert, basin)
    data["gain"] = np.asarray(K).tolist()
    return write(args.out, "control_pendulum", system, data, basin, drawn, started)  # fmt: skip


if __name__ == "__main__":
    main()
