"""Van der Pol (time-reversed): the published benchmark, level search, certificate, basin slice.

With the published P = [[1.5, -0.5], [-0.5, 1]], the largest level of V = x'Px with V' < 0 on
{V <= level} is 2.3045 (Tedrake's course notes); the certificate proves 0.999 x the level found and
refutes 1.001 x it. The basin slice shows the unstable limit cycle bounding the true basin.

    python examples/vanderpol.py [--quick] [--out results-examples]
"""

from __future__ import annotations

import time

from _gallery import parse, regions, summary, write

import roa


def main(argv: list[str] | None = None) -> dict:
    args = parse(argv, __doc__)
    started = time.perf_counter()
    system = roa.load_system("vanderpol")
    V = roa.default_lyapunov(system)  # the published P
    search = roa.level_search(system, V, shape="level", method="both")
    cert = roa.certify(system, V, candidate=search, check_above=1.001)
    n = 30 if args.quick else 150
    grid = roa.grid_slice(system, ("x1", "x2"), [(-3, 3), (-3, 3)], (n, n))
    drawn = regions(V, search, cert)
    basin = roa.basin(system, grid, run=roa.RunOptions(n_jobs=1), regions=drawn)
    return write(args.out, "vanderpol", system, summary(search, cert, basin), basin,
                 drawn, started)  # fmt: skip


if __name__ == "__main__":
    main()
