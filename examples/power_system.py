"""Two-machine power system (swing equation), LyZNet's ``ex2_two_machine_power``.

x1 is the rotor angle deviation from the operating point delta = pi/3 (rad), x2 the speed
deviation (per unit)::

    x1' = x2,   x2' = -0.5 x2 - (sin(x1 + delta) - sin(delta))

The sine is expanded, sin(x1 + delta) - sin(delta) = cos(delta) sin(x1) + sin(delta) (cos(x1) - 1)
with cos(delta) = 1/2 and sin(delta) = sqrt(3)/2 exact, so that x1 = 0 is an equilibrium in exact
arithmetic (with a rounded sin(pi/3) it is not, and no certificate can hold near it). The basin is
bounded by the stable manifold of the saddle at x1 = pi/3; beyond it the machine slips poles. The
domain -4 < x1 < 5 rad ends those runs as left_domain.

    python examples/power_system.py [--quick] [--out results-examples]
"""

from __future__ import annotations

import time

import sympy as sp
from _gallery import parse, regions, summary, write

import roa


def power_system() -> roa.System:
    x1, x2 = sp.symbols("x1 x2")
    cos_d, sin_d = sp.Rational(1, 2), sp.sqrt(3) / 2
    field = [x2, -x2 / 2 - (cos_d * sp.sin(x1) + sin_d * (sp.cos(x1) - 1))]
    return roa.System.from_sympy(
        field,
        [x1, x2],
        name="two-machine-power",
        state_units=("rad", "pu"),
        margin=lambda x, xp: (x[0] + 4.0) * (5.0 - x[0]),
        domain_description="-4 < x1 < 5 rad",
    )


def main(argv: list[str] | None = None) -> dict:
    args = parse(argv, __doc__)
    started = time.perf_counter()
    system = power_system()
    V = roa.default_lyapunov(system)
    search = roa.level_search(system, V, shape="level", method="both")
    cert = roa.certify(system, V, candidate=search, check_above=1.001)
    n = 30 if args.quick else 150
    grid = roa.grid_slice(system, ("x1", "x2"), [(-2.0, 3.0), (-3.0, 1.5)], (n, n))
    drawn = regions(V, search, cert)
    basin = roa.basin(system, grid, run=roa.RunOptions(n_jobs=1), regions=drawn)
    return write(args.out, "power_system", system, summary(search, cert, basin), basin,
                 drawn, started)  # fmt: skip


if __name__ == "__main__":
    main()
