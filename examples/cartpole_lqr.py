"""A cart-pole under an LQR gain from python-control: the Riccati solution S as the Lyapunov function.

The plant is the textbook cart-pole as a ``control.nlsys`` written with numpy: a cart of mass
M = 1 kg at position p (m) and velocity v (m/s), pushed by a force F (N), carrying a point mass
m = 0.1 kg on a massless rod of length l = 0.5 m at angle theta from upright (rad) with rate omega
(rad/s). ``control.lqr`` on its linearisation at the upright equilibrium with Q = I, R = 1 returns
(K, S, E); ``roa.System.from_control(plant, (K, S, E))`` builds the closed loop F = -K x and keeps
the Riccati solution S as its Lyapunov candidate V = x'Sx (the LQR cost-to-go). The state and input
names come from the model; the units are given.

The largest certified level of V = x'Sx is about 3.40 (0.999 x the level search's 3.4033; 1.001 x is
refuted), against about 0.087 for the candidate of A'P + PA = -I on the same loop: S is shaped by
the loop (it weighs the slow cart directions), the identity's solution is not. The basin slice in
(theta, omega) at p = v = 0 shows both certified sets; the share of the converged points inside
each is printed over the slice and over seeded uniform samples of the 4-dimensional box
|p|, |v| <= 1, |theta| <= 1.5, |omega| <= 7.

Needs python-control: ``pip install ".[control]"`` in a clone of roa (or ``pip install control``).

    python examples/cartpole_lqr.py [--quick] [--out results-examples]

The closed loop for the CLI (``u(t)`` is drawn below the states):

    roa simulate --system examples/cartpole_lqr.py:cartpole --x0 0,0,0.5,0 --plot cartpole.png
"""

from __future__ import annotations

import time

import control
import numpy as np

import roa
from roa.lyapunov import Region
from roa.model import lyapunov_matrix

M, MASS, LENGTH, G = 1.0, 0.1, 0.5, 9.81
Q, R = np.eye(4), np.eye(1)


def updfcn(t, x, u, params):
    """The cart-pole x = (p, v, theta, omega), u = (F,), theta from upright."""
    s, c = np.sin(x[2]), np.cos(x[2])
    d = M + MASS * s * s
    v_dot = (u[0] + MASS * s * (LENGTH * x[3] ** 2 - G * c)) / d
    omega_dot = (-u[0] * c - MASS * LENGTH * x[3] ** 2 * c * s + (M + MASS) * G * s) / (LENGTH * d)
    return [x[1], v_dot, x[3], omega_dot]


def plant() -> control.NonlinearIOSystem:
    return control.nlsys(updfcn, None, inputs=["F"], states=["p", "v", "theta", "omega"],
                         name="cartpole")  # fmt: skip


def lqr() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``control.lqr`` on the linearisation at the upright equilibrium: (K, S, E)."""
    return control.lqr(plant().linearize(np.zeros(4), [0.0]), Q, R)


def cartpole() -> roa.System:
    """The closed loop F = -K x with V = x'Sx (S of control.lqr) as its candidate."""
    return roa.System.from_control(plant(), lqr(), state_units=("m", "m/s", "rad", "rad/s"),
                                   input_units=("N",), meta={"time_unit": "s"})  # fmt: skip


def main(argv: list[str] | None = None) -> dict:
    from _gallery import box_shares, parse, summary, write  # here: roa loads cartpole() anywhere

    args = parse(argv, __doc__)
    started = time.perf_counter()
    system = cartpole()
    S_V = roa.default_lyapunov(system)  # S of control.lqr
    I_V = roa.QuadraticLyapunov.for_system(system, lyapunov_matrix(system),
                                           name="P from A'P + PA = -I")  # fmt: skip
    found = {}
    for key, V in (("riccati", S_V), ("identity", I_V)):
        search = roa.level_search(system, V, shape="level", method="both")
        cert = roa.certify(system, V, candidate=search, check_above=1.001)
        found[key] = (V, search, cert)
        print(f"cartpole_lqr: {V.name}: certified {cert.level:.6g} ({cert.method}; 1.001 x the "
              f"level search's {search.level:.6g} is {cert.above.status.value})")  # fmt: skip
    n = 15 if args.quick else 101
    grid = roa.grid_slice(system, ("theta", "omega"), [(-1.5, 1.5), (-7.0, 7.0)], (n, n))
    drawn = [Region.from_lyapunov(f"x'Sx <= {found['riccati'][2].level:.4g} (certified, S of lqr)",
                                  S_V, found["riccati"][2].level, "certified"),
             Region.from_lyapunov(f"x'Px <= {found['identity'][2].level:.3g} (certified, "
                                  "A'P + PA = -I)", I_V, found["identity"][2].level,
                                  "certified")]  # fmt: skip
    basin = roa.basin(system, grid, run=roa.RunOptions(n_jobs=1), regions=drawn)
    data = summary(found["riccati"][1], found["riccati"][2], basin)
    data["identity_candidate"] = summary(found["identity"][1], found["identity"][2], None)
    K, S, _ = lqr()
    data["gain"], data["riccati_S"] = np.asarray(K).tolist(), np.asarray(S).tolist()
    # the same shares over the 4-dimensional box, by seeded uniform samples
    box = [(-1.0, 1.0), (-1.0, 1.0), (-1.5, 1.5), (-7.0, 7.0)]
    in_box = box_shares(system, box, drawn, 400 if args.quick else 20000)
    data["box"] = dict(zip(system.state_names, map(list, box), strict=True))
    return write(args.out, "cartpole_lqr", system, data, basin, drawn, started, in_box)


if __name__ == "__main__":
    main()
