"""Planar quadrotor under LQR, written in sympy (as LyZNet and Drake users write it).

Six states (x, y, theta, vx, vy, omega), gravity 9.81, mass and inertia 1, inputs u1 (thrust
beyond hover) and u2 (torque) under LyZNet's gain u = -K x (``examples/systems/quadrotor2d.py``
is the same model as a user file). ``roa.System.from_sympy`` compiles the expressions for every
namespace. The level search of V (A'P + PA = -I) gives about 0.130; the exact SOS certificate
(sin/cos recast, python-flint) proves a fraction of it (0.9 x, 0.5 x with ``--quick``). The slice
is the position plane (x, y) at zero attitude and velocity.

    python examples/quadrotor2d_sympy.py [--quick] [--out results-examples]
"""

from __future__ import annotations

import time

import sympy as sp
from _gallery import parse, regions, summary, write

import roa

G = sp.Rational(981, 100)  # exact 9.81: the certificate is about this rational field
K = (
    (0.0, 1.0, 0.0, 0.0, 1.7321, 0.0),
    (1.0, 0.0, 13.5165, 1.938, 0.0, 5.2946),
)


def quadrotor() -> roa.System:
    x, y, theta, vx, vy, omega = states = sp.symbols("x y theta vx vy omega")
    u1, u2 = (-sum(k * s for k, s in zip(row, states, strict=True)) for row in K)
    field = [
        vx,
        vy,
        omega,
        G * sp.sin(theta) + u1 * sp.sin(theta),
        -G + G * sp.cos(theta) + u1 * sp.cos(theta),
        u2,
    ]
    return roa.System.from_sympy(field, states, name="quadrotor2d-lqr",
                                 state_units=("m", "m", "rad", "m/s", "m/s", "rad/s"))  # fmt: skip


def main(argv: list[str] | None = None) -> dict:
    args = parse(argv, __doc__)
    started = time.perf_counter()
    system = quadrotor()
    V = roa.default_lyapunov(system)
    sampled = roa.SampledOptions(n_directions=4000) if args.quick else None
    search = roa.level_search(system, V, method="sampled", sampled=sampled)
    fraction = 0.5 if args.quick else 0.9
    cert = roa.certify(system, V, level=fraction * search.level, validator="sos")
    n = 15 if args.quick else 80
    grid = roa.grid_slice(system, ("x", "y"), [(-2, 2), (-2, 2)], (n, n))
    drawn = regions(V, search, cert)
    basin = roa.basin(system, grid, run=roa.RunOptions(n_jobs=1), regions=drawn)
    data = summary(search, cert, basin)
    data["certificate"]["fraction_of_search_level"] = fraction
    return write(args.out, "quadrotor2d_sympy", system, data, basin, drawn, started)  # fmt: skip


if __name__ == "__main__":
    main()
