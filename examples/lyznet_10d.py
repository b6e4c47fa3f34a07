"""The 10-state system of LyZNet (HSCC'24 example 4), loaded from its user file.

Five coupled 2-state linear blocks with quadratic couplings (``examples/systems/lyznet_10d.py``).
V from A'P + PA = -I; the sampled level search finds its level, and the exact SOS certificate
(python-flint; its cost grows with the Gram basis, not exponentially with the dimension as the
branch and bound's boxes do) proves 0.99 x it. The slice is (x1, x2) with the other eight states
at zero.

    python examples/lyznet_10d.py [--quick] [--out results-examples]
"""

from __future__ import annotations

import time
from pathlib import Path

from _gallery import parse, regions, summary, write

import roa

SPEC = str(Path(__file__).resolve().parent / "systems" / "lyznet_10d.py") + ":SYSTEM"


def main(argv: list[str] | None = None) -> dict:
    args = parse(argv, __doc__)
    started = time.perf_counter()
    system = roa.load_system(SPEC)
    V = roa.default_lyapunov(system)
    sampled = roa.SampledOptions(n_directions=4000) if args.quick else None
    search = roa.level_search(system, V, method="sampled", sampled=sampled)
    cert = roa.certify(system, V, level=0.99 * search.level, validator="sos")
    n = 20 if args.quick else 100
    grid = roa.grid_slice(system, ("x1", "x2"), [(-25, 25), (-25, 25)], (n, n))
    drawn = regions(V, search, cert)
    basin = roa.basin(system, grid, run=roa.RunOptions(n_jobs=1), regions=drawn)
    return write(args.out, "lyznet_10d", system, summary(search, cert, basin), basin,
                 drawn, started)  # fmt: skip


if __name__ == "__main__":
    main()
