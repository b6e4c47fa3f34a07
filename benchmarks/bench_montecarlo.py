"""Benchmark: the Monte Carlo engine against a joblib loop over scipy's solve_ivp, side by side.

The same 2,000 initial conditions of the IPC closed loop (physical coordinates, uniform in
q, q' in [-3, 3], theta in [-1.5, 1.5], theta' in [-3, 3], seed 0), rtol 1e-6, atol 1e-9,
T = 30, same stop rules, on the same number of cores. Checks that the statuses agree and prints the
throughput of each and their ratio (target: engine >= 300x and >= 20,000 trajectories/s on 2 cores).

    python benchmarks/bench_montecarlo.py [--jobs 2] [--n 2000]
    python benchmarks/bench_montecarlo.py --memory [--n-memory 1000000]   # peak RSS, 10^6 streamed
"""

from __future__ import annotations

import argparse
import threading
import time

import numpy as np
import psutil
from joblib import Parallel, delayed

from roa.montecarlo import integrator as I  # noqa: N812
from roa.montecarlo.engine import run_basin
from roa.montecarlo.sampling import box_sample
from roa.simulation import simulate
from roa.status import StopRules
from roa.systems import ipc

BOX = [(-3.0, 3.0), (-3.0, 3.0), (-1.5, 1.5), (-3.0, 3.0)]
RULES = StopRules(t_final=30.0)
RTOL, ATOL = 1e-6, 1e-9


def _baseline_one(x: np.ndarray) -> str:
    system = ipc.closed_loop()
    return simulate(system, x, rules=RULES, rtol=RTOL, atol=ATOL, method="RK45").status.value


def _baseline_chunk(X: np.ndarray) -> list[str]:
    return [_baseline_one(x) for x in X]


class PeakRSS:
    """Poll the RSS of this process plus all its children (joblib workers) every 50 ms."""

    def __init__(self) -> None:
        self.peak = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        me = psutil.Process()
        while not self._stop.is_set():
            total = 0
            for p in [me, *me.children(recursive=True)]:
                try:
                    total += p.memory_info().rss
                except psutil.Error:
                    pass
            self.peak = max(self.peak, total)
            time.sleep(0.05)

    def __enter__(self) -> PeakRSS:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()


def speed(n: int, jobs: int) -> None:
    system = ipc.closed_loop()
    smp = box_sample(system, BOX, n, seed=0)
    X = smp.points(0, n)
    # warm both sides (worker start-up, numba cache load) on a few other states
    run_basin(system, box_sample(system, BOX, 64, seed=99), rules=RULES, n_jobs=jobs, chunk_size=32)
    Parallel(n_jobs=jobs)(delayed(_baseline_chunk)(c) for c in np.array_split(X[:8], jobs))

    times = []
    for _ in range(3):  # the engine is cheap to repeat: median of 3 against load noise
        t0 = time.perf_counter()
        run = run_basin(system, smp, rules=RULES, rtol=RTOL, atol=ATOL, n_jobs=jobs,
                        chunk_size=max(1, -(-n // (2 * jobs))), progress=False)  # fmt: skip
        times.append(time.perf_counter() - t0)
    t_engine = float(np.median(times))
    t0 = time.perf_counter()
    parts = Parallel(n_jobs=jobs)(delayed(_baseline_chunk)(c) for c in np.array_split(X, 8 * jobs))
    t_base = time.perf_counter() - t0
    base = [s for part in parts for s in part]
    mine = [I.CODE_STATUS[int(c)].value for c in run.code]
    agree = sum(a == b for a, b in zip(base, mine, strict=True))
    print(
        f"IPC, {n} initial conditions, rtol {RTOL:g}, atol {ATOL:g}, T = {RULES.t_final:g}, {jobs} cores"
    )
    print(f"  statuses (engine): {run.counts()}")
    print(f"  statuses agree with solve_ivp(RK45): {agree}/{n}")
    print(f"  engine  : {t_engine:8.3f} s  {n / t_engine:10.1f} trajectories/s (median of 3; best "
          f"{n / min(times):.1f}/s)")  # fmt: skip
    print(
        f"  baseline: {t_base:8.3f} s  {n / t_base:10.1f} trajectories/s  (joblib loop over solve_ivp)"
    )
    print(f"  ratio engine / baseline: {t_base / t_engine:.1f}x")
    if agree != n:
        raise SystemExit("statuses disagree")


def memory(n: int, jobs: int) -> None:
    system = ipc.closed_loop()
    smp = box_sample(system, BOX, n, seed=0)
    t0 = time.perf_counter()
    with PeakRSS() as peak:
        run = run_basin(system, smp, rules=RULES, rtol=RTOL, atol=ATOL, n_jobs=jobs, progress=True)
    dt = time.perf_counter() - t0
    print(f"{n} initial conditions streamed in {dt:.1f} s ({n / dt:.0f}/s): {run.counts()}")
    print(f"  peak RSS (this process + workers): {peak.peak / 2**30:.3f} GiB (limit 2 GiB)")
    if peak.peak >= 2 * 2**30:
        raise SystemExit("peak memory above 2 GiB")


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument(
        "--memory", action="store_true", help="stream --n-memory states, report peak RSS"
    )
    ap.add_argument("--n-memory", type=int, default=1_000_000)
    args = ap.parse_args()
    if args.memory:
        memory(args.n_memory, args.jobs)
    else:
        speed(args.n, args.jobs)


if __name__ == "__main__":
    main()
