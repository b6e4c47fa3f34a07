"""Benchmark: the Monte Carlo engine, plain and with a certified terminal set, against a joblib loop
over scipy's solve_ivp, side by side.

The same initial conditions of the IPC closed loop (physical coordinates, uniform in q, q' in
[-3, 3], theta in [-1.5, 1.5], theta' in [-3, 3], seed 0), rtol 1e-6, atol 1e-9, T = 30, same stop
rules, on the same number of cores. The engine runs --n-engine states in each mode (plain; with the
certified flat-coordinate V of results/certify/certified.json as terminal set, roa/montecarlo/
terminal.py); the baseline runs their first --n. Prints trajectories/s, the ratio to the baseline
and checks that the statuses of both modes agree with the baseline's. Targets (issue 14): plain
>= 20,000/s on 2 cores; with the terminal set >= 100,000/s and >= 3,000x the baseline.

    python benchmarks/bench_montecarlo.py [--jobs 2] [--n 2000] [--n-engine 100000]
    python benchmarks/bench_montecarlo.py --memory [--n-memory 1000000]   # peak RSS, 10^6 streamed

The engine takes the IPC's fast path (System.numba_fast: njit functions compiled into a
kernel of their own, roa/integration/_integrator.py compile_kernel); --public adds both modes with the
public cfunc protocol of user systems (System.numba), same statuses bit for bit.

Profile of the physical numba kernel (issue 14, item 2): one core of the 2-core machine, 20,000
states of the box, thread CPU time, best of 9 (whole kernel), micro-benchmarks of 2e6 calls in a
compiled loop, `perf record` for the libm share. Per RHS evaluation (6 per accepted step; 111.6
accepted steps per run plain, 33.2 with the terminal set):

    item                                     public cfuncs          fast path (inlined)
    whole kernel, plain                      ~94-97 ns (565-580     ~79-88 ns (473-525
                                             ns/step, 15-16 k       ns/step, 17-19 k
                                             runs/s per core)       runs/s per core)
    whole kernel, with the terminal set      ~115-117 ns (690-700   ~88-91 ns (525-547
                                             ns/step, 43 k runs/s)  ns/step, 55-57 k runs/s)
    the physical field                       ~50 ns (call through   ~37 ns (inlined)
                                             its pointer, array
                                             structs passed)
    terminal-set test, per step              ~61 ns (physical ->    ~14 ns + V: the flat map
                                             flat map with sin,     fused into the field's last
                                             cos, log + V, 16       stage (same sin, cos, log;
                                             multiply-adds)         bit for bit the same map)

* trig and log in the field: sin and cos ~13 ns together (LLVM calls glibc's sincos), log ~5 ns
  (arsinh(tan) written with the same sin, cos and one log); the controller's coordinate map (2.2)
  is folded into the field (no tan, arsinh or sqrt). libm is ~40 % of the kernel's time (sincos
  ~17 %, log ~16 %, pow ~6 %): the floor of this kernel, with scipy's step sequence;
* step-size control per step (not per RHS): en ** -0.2 (pow) ~14 ns, nextafter ~7 ns, the error
  norm one sqrt: kept as they are (identical to scipy's RK45, so statuses agree bit for bit);
* stop tests per step: margin ~5 ns (inlined on the fast path), two norms (two sqrt); the terminal
  set ends runs ~3.4x sooner (33.2 instead of 111.6 steps);
* memory layout: states are rows of a C-contiguous (m, n) array, each run works in its own small
  scratch arrays (7 x n stages): allocation is per run, not per step (scratch allocated once per
  chunk measured no faster);
* unrolled Runge-Kutta stages (constant coefficients) and a compile-time n = 4 measured no faster
  while the field takes and fills arrays; a field on scalars returning a tuple, everything in
  registers, is x1.15-1.31 faster per step (benchmarks/bench_rk_interface.py, same steps, same
  bits): the cost of the array interface (FIELD_SIGNATURE), kept for user systems; interleaving
  runs in lockstep measured no faster (each stage waits for the previous field);
* chunk size and work balance: the benchmark runs 4 chunks per worker (CHUNKS_PER_JOB; 1 to 12
  per worker measure the same within noise on an idle machine, and on a shared one a worker that
  is slowed down leaves less idle time at the end); joblib's process start-up and dispatch cost
  ~0.1-0.3 s per run, hence runs of < 12,000 states stay in one process (engine SMALL_RUN) and the
  throughputs here are for 10^5 states;
* thread vs process pool: the kernel holds the GIL (no nogil), so the threading backend runs one
  core; processes (loky, reused between runs) are used.

Throughputs measured 2026-12-01 on this session's idle 2-core machine (default arguments,
--public; median of 3 engine runs, best in brackets; two runs): baseline 103-108 trajectories/s
(this machine runs solve_ivp ~3.7x faster than the one of 2026-11-29, which measured 28.4/s);
fast path plain 52.5-53.7 k/s (488-521x); with the quadratic terminal set (T:optimised, 33.2
accepted steps per run) 125-129 k/s (1164-1254x); with the certified degree-4 V of
results/degrees (T:degree4, level 0.996294, share 1.000 of the reference box, 22.1 steps per
run; the polynomial test of roa/integration/_terminal_poly.py in the kernel) 147-161 k/s (160-164 k
best, 1424-1495x); public cfuncs plain 49.0 k/s, T:optimised 86.5 k/s, T:degree4 115 k/s;
statuses 2000/2000 identical to the baseline in every mode. The same machine kind ran ~2.2x
slower for both sides later that day (a new session, 2.1 GHz; four runs): baseline 40.5-47.2/s,
plain 23.3-25.8 k/s (518-615x), T:optimised 51.7-57.4 k/s (1097-1419x), T:degree4 65.9-70.0 k/s
(1461-1629x; the last two runs with the regenerated degree-4 V of round 30, level 1.02706, 21.9
steps per run): the ratios hold, the absolute rates move with the machine. Targets: plain
>= 20 k/s met on both (23-54 k/s); terminal >= 100 k/s met on the fast machine (161 k/s), not on
the slow one (70 k/s); >= 3000x not met on either (1424-1629x). 3000x needs about half the time
per run: at ~0.55 us per accepted step (fast machine), 322 k/s would be ~11 steps per run
instead of 22. Neither lever gets there: benchmarks/bench_entry_steps.py shows that a union with
the other certified sets saves nothing and even {V4 <= 10 c} (not certified) only x1.6 of the
steps (13.3 per run), as the slowest runs swing far out of every sublevel set of V4 before
settling; benchmarks/bench_rk_interface.py shows that a scalar-field step would be x1.15-1.31
faster. Looser tolerances than the baseline's would not be a like-for-like comparison.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import threading
import time
from pathlib import Path

import numpy as np
import psutil
from joblib import Parallel, delayed

from ipc_paper import system as ipc
from roa.integration import _integrator as I  # noqa: N812
from roa.integration._simulation import simulate
from roa.integration._terminal import TerminalSet
from roa.montecarlo._engine import run_basin
from roa.montecarlo._sampling import box_sample
from roa.search._rays import component_candidates, ray_box
from roa.status import StopRules

BOX = [(-3.0, 3.0), (-3.0, 3.0), (-1.5, 1.5), (-3.0, 3.0)]
RULES = StopRules(t_final=30.0)
RTOL, ATOL = 1e-6, 1e-9
CERTIFIED = Path(__file__).resolve().parents[1] / "results/certify/certified.json"
DEGREES = Path(__file__).resolve().parents[1] / "results/degrees/evidence.json"
#: Chunks per worker process (work balance: a worker slowed down leaves less idle time at the end).
CHUNKS_PER_JOB = 4


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


def certified_set(which: str) -> TerminalSet:
    """The IPC's certified flat-coordinate V from results/certify/certified.json (ipc_paper/certified.py).

    ``which``: ``paper`` (V (3.11)) or ``optimised`` (the quadratic V maximising the box fraction).
    """
    prefix = {"paper": "paper V", "optimised": "optimised quadratic V (box fraction)"}[which]
    data = json.loads(CERTIFIED.read_text())
    for e in data["regions"]:
        if e["name"].startswith(prefix) and e["status"] == "certified":
            coords = e.get("coords", "flat")
            return TerminalSet(e["P"], np.zeros(4), e["level"], coords=coords, name=e["name"])
    raise SystemExit(f"{CERTIFIED}: no certified entry {prefix!r}")


def degree4_set(coords: str = "flat") -> TerminalSet:
    """The IPC's certified degree-4 V in ``coords`` (flat or hybrid) of
    results/degrees/evidence.json, as a polynomial terminal set (its certified component,
    roa/proof/_component.py)."""
    from roa.lyapunov import from_json as lyapunov_from_json

    key = {"flat": "ipc", "hybrid": "ipc_hybrid"}[coords]
    row = json.loads(DEGREES.read_text())[key]["degrees"]["4 (sampled)"]
    if row["status"] != "certified":
        raise SystemExit(f"{DEGREES}: the {coords} degree-4 V is {row['status']}, not certified")
    from roa.proof._reverify import reverify

    V = lyapunov_from_json(row["V"], np.zeros(4), name=row["V"]["lyapunov"])
    name = f"{row['V']['lyapunov']} <= {row['level']:.6g}"
    analysis = ipc.closed_loop().analysis_coords.system(coords)
    proof = reverify(
        analysis, V, row["level"], cover_estimate=ray_box
    )  # its frame; cached after the first run
    if not proof.certified:
        raise SystemExit(f"{DEGREES}: the {coords} degree-4 V did not re-verify: {proof.message}")
    return TerminalSet.polynomial(V, row["level"], coords=coords, name=name, frame=proof.frame,
                                  propose=component_candidates)  # fmt: skip


def terminal_set(which: str) -> TerminalSet:
    return degree4_set() if which == "degree4" else certified_set(which)


def _public(system):
    """The system without its fast path: the kernel takes the public cfuncs (System.numba)."""
    return dataclasses.replace(system, numba_fast=None)


def _engine(system, smp, jobs, terminal=None, repeat=3):
    chunk = max(1, -(-smp.n // (CHUNKS_PER_JOB * jobs)))
    times, run = [], None
    for _ in range(repeat):  # the engine is cheap to repeat: median against load noise
        t0 = time.perf_counter()
        run = run_basin(system, smp, rules=RULES, rtol=RTOL, atol=ATOL, n_jobs=jobs,
                        chunk_size=chunk, progress=False, terminal=terminal)  # fmt: skip
        times.append(time.perf_counter() - t0)
    return run, float(np.median(times)), min(times)


def speed(n: int, n_engine: int, jobs: int, which: list[str], public: bool) -> None:
    system = ipc.closed_loop()
    terminals = {w: terminal_set(w) for w in which}
    smp = box_sample(system, BOX, n_engine, seed=0)
    X = smp.points(0, n)  # the baseline runs the first n of the engine's samples
    modes = [("plain", system, None), *((f"T:{w}", system, t) for w, t in terminals.items())]
    if public:  # the same with the public cfuncs (the protocol of user systems)
        modes += [("plain-pub", _public(system), None),
                  *((f"T:{w}-pub", _public(system), t) for w, t in terminals.items())]  # fmt: skip
    # warm both sides (worker start-up, numba cache load) on a few other states
    warm = box_sample(system, BOX, 64, seed=99)
    for _, sys_, term in modes:  # 8 chunks: every worker loads the kernels
        run_basin(sys_, warm, rules=RULES, n_jobs=jobs, chunk_size=8, terminal=term)
    Parallel(n_jobs=jobs)(delayed(_baseline_chunk)(c) for c in np.array_split(X[:8], jobs))

    rows = [(mode, *_engine(sys_, smp, jobs, term)) for mode, sys_, term in modes]
    steps = {
        mode: float(
            I.integrate_batch(
                sys_, X, rules=RULES, rtol=RTOL, atol=ATOL, terminal=term
            ).steps.mean()
        )
        for mode, sys_, term in modes
    }  # accepted steps per run (the baseline's states)
    t0 = time.perf_counter()
    parts = Parallel(n_jobs=jobs)(delayed(_baseline_chunk)(c) for c in np.array_split(X, 8 * jobs))
    t_base = time.perf_counter() - t0
    base = [s for part in parts for s in part]
    rate_base = n / t_base
    print(f"IPC (physical coordinates), box {BOX}, rtol {RTOL:g}, atol {ATOL:g}, "
          f"T = {RULES.t_final:g}, {jobs} cores")  # fmt: skip
    for w, t in terminals.items():
        print(f"terminal set T:{w}: {t.name} (flat coordinates, degree {t.degree}, "
              "V <= level (1 - 1e-9))")  # fmt: skip
    print(f"  baseline (joblib loop over solve_ivp RK45): {n} states in {t_base:.2f} s = "
          f"{rate_base:.1f} trajectories/s")  # fmt: skip
    print(f"  {'mode':9s} {'states':>8s} {'seconds':>8s} {'traj/s':>10s} {'best/s':>10s} "
          f"{'x baseline':>10s} {'agree':>11s}  entered  steps/run")  # fmt: skip
    bad = False
    for mode, run, t_med, t_best in rows:
        mine = [I.CODE_STATUS[int(c)].value for c in run.code[:n]]
        agree = sum(a == b for a, b in zip(base, mine, strict=True))
        bad |= agree != n
        rate = n_engine / t_med
        print(f"  {mode:9s} {n_engine:8d} {t_med:8.3f} {rate:10.0f} {n_engine / t_best:10.0f} "
              f"{rate / rate_base:9.0f}x {agree:5d}/{n:<5d}  {run.entered_certified_set:7d}  "
              f"{steps[mode]:.1f}")  # fmt: skip
    for mode, run, *_ in rows:
        print(f"  statuses ({mode}): {run.counts()}")
    print("  targets: plain >= 20,000/s; terminal >= 100,000/s and >= 3,000x the baseline")
    if bad:
        raise SystemExit("statuses disagree with solve_ivp")


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
    ap.add_argument("--n", type=int, default=2000, help="states of the solve_ivp baseline")
    ap.add_argument(
        "--n-engine",
        type=int,
        default=100_000,
        help="states of the engine runs (the baseline's n are their first rows)",
    )
    ap.add_argument(
        "--terminal",
        choices=("paper", "optimised", "degree4"),
        nargs="+",
        default=["optimised", "degree4"],
        help="terminal sets, each a mode: a quadratic V of results/certify/certified.json "
        "(paper, optimised) or the degree-4 V of results/degrees/evidence.json",
    )
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument(
        "--public",
        action="store_true",
        help="also run the public cfunc protocol (no fast path) in both modes",
    )
    ap.add_argument(
        "--memory", action="store_true", help="stream --n-memory states, report peak RSS"
    )
    ap.add_argument("--n-memory", type=int, default=1_000_000)
    args = ap.parse_args()
    if args.memory:
        memory(args.n_memory, args.jobs)
    else:
        speed(args.n, max(args.n, args.n_engine), args.jobs, args.terminal, args.public)


if __name__ == "__main__":
    main()
