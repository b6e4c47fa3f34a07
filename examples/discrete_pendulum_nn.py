"""The tanh-network pendulum in discrete time (Euler step, h = 0.05 s): level search on
``Delta V = V(F(x)) - V(x)``, a certificate down to the fixed point with a refutation just above,
and the basin slice by iterating the map.

The certified set ``{V <= c}`` (``V`` from ``A'PA - P = -I``) is proved invariant under the map
and every orbit from it converges to the origin; the slice shows how much of the map's basin it
holds (runs of 60 s = 1200 steps).

    python examples/discrete_pendulum_nn.py [--quick] [--out results-examples]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from _gallery import parse, regions, summary, write

import roa

sys.path.insert(0, str(Path(__file__).resolve().parent / "systems"))
from pendulum_nn_discrete import SYSTEM  # noqa: E402


def main(argv: list[str] | None = None) -> dict:
    args = parse(argv, __doc__)
    started = time.perf_counter()
    system = SYSTEM
    V = roa.default_lyapunov(system)  # A'PA - P = -I
    search = roa.level_search(system, V, shape="level", method="sampled")
    assert search.level is not None, search.message
    # the certificate at 0.99 x the search's level, then 1.01 x it refuted (50-digit witness)
    cert = roa.certify(system, V, level=0.99 * search.level, check_above=1.01 / 0.99)
    n = 40 if args.quick else 160
    grid = roa.grid_slice(system, ("theta", "omega"), [(-6, 6), (-9, 9)], (n, n))
    drawn = regions(V, search, cert)
    rules = roa.StopRules(t_final=60.0, converge_tol=1e-3, diverge_bound=1e3)
    basin = roa.basin(system, grid, rules=rules, run=roa.RunOptions(n_jobs=1), regions=drawn)
    return write(args.out, "discrete_pendulum_nn", system, summary(search, cert, basin), basin,
                 drawn, started)  # fmt: skip


if __name__ == "__main__":
    main()
