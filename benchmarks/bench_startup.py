"""Benchmark of start-up: ``import roa``, ``roa --help`` and ``roa certify --help``.

Run: ``python benchmarks/bench_startup.py [--repeat N] [--root DIR]`` (``--root``: time another
checkout, e.g. the commit before the lazy imports, for a before/after). Each command runs ``N`` times in a fresh
interpreter (the best time is kept, as ``timeit`` does) and is printed beside the baseline
``python -c pass`` as a ratio. Targets (#25): ``import roa`` under 1 s, each ``--help`` under
0.5 s. Nothing is asserted (times depend on the machine's load); tests/api/test_startup.py checks the
cause instead: no heavy module is imported by any of these.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CLI = "import sys; from roa.cli import main; sys.exit(main())"
CASES = {
    "python -c pass (baseline)": ["-c", "pass"],
    "import roa": ["-c", "import roa"],
    "roa --help": ["-c", CLI, "--help"],
    "roa certify --help": ["-c", CLI, "certify", "--help"],
    "import roa; roa.certify (loads the analyses)": ["-c", "import roa; roa.certify"],
    "roa.load_system('ipc') (study, numba kernels)": ["-c", "import roa; roa.load_system('ipc')"],
}
TARGETS = {"import roa": 1.0, "roa --help": 0.5, "roa certify --help": 0.5}


def best_time(args: list[str], repeat: int, root: Path = ROOT) -> float:
    """The shortest wall time of ``repeat`` runs of ``python ARGS`` (output discarded)."""
    env = {**os.environ, "PYTHONPATH": str(root)}
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, *args], cwd=root, env=env, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="runs per command (default 5)")
    ap.add_argument("--root", type=Path, default=ROOT, help="checkout to time (default: this one)")
    a = ap.parse_args()
    print(f"checkout {a.root}, best of {a.repeat}")
    base = None
    print(f"{'command':48s} {'best [s]':>9s} {'x baseline':>11s}  target")
    for name, args in CASES.items():
        t = best_time(args, a.repeat, a.root)
        base = t if base is None else base
        target = TARGETS.get(name)
        mark = "" if target is None else f"< {target:.1f} s {'ok' if t < target else 'MISSED'}"
        print(f"{name:48s} {t:9.3f} {t / base:11.1f}  {mark}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
