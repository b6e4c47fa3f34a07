"""Benchmark: the batch Dormand-Prince kernels of this checkout against another checkout, side by side.

Each checkout runs in its own process (``PYTHONPATH`` = the checkout, its own kernel cache
directory), alternately (this, other, other, this, ...), ``--rounds`` times; per case the best
time of every process is kept and the best over the rounds compared. Times are the process's CPU
time (``time.process_time``: the kernels and numba's compiler run on one thread), which a machine
shared with other jobs inflates far less than wall-clock time. Cases, one process and one thread each (no joblib): the IPC
closed loop on its fast path (``System.numba_fast``, njit functions inlined) and on the public
cfunc protocol (``System.numba``), the van der Pol oscillator and a damped pendulum with a margin
on kernels generated from their fields (:mod:`roa.integration._kernel_cache`), and the numpy batch
(van der Pol). For each it prints runs per second of both, the ratio (this / other: above 1 is
faster), the first compilation's seconds (numba's cache emptied before the first round) and
whether both give the same codes, stop times, end states and step counts bit for bit. numba's
caches of both checkouts (``*.nbi``, ``*.nbc`` under them) are emptied first.

    git archive main | tar -x -C /tmp/roa-main
    python benchmarks/bench_dopri_kernels.py --other /tmp/roa-main [--rounds 3] [--n 20000]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]

CHILD = r"""
import dataclasses, hashlib, json, sys, time
import numpy as np
import roa
from roa.integration._integrator import integrate_batch
from roa.status import StopRules
from roa.systems.vanderpol import vanderpol

n, repeat = int(sys.argv[1]), int(sys.argv[2])
rng = np.random.default_rng(0)


def pendulum():
    return roa.System(name="sincos", field=lambda t, x, xp: (x[1], -xp.sin(x[0]) - 0.5 * x[1]
                      + 0.2 * xp.cos(x[0]) * x[1]), equilibrium=(0.0, 0.0),
                      state_names=("theta", "omega"), margin=lambda x, xp: 4.0 - xp.abs(x[0]))


from ipc_paper import system as ipc

box = np.array([[-3, 3], [-3, 3], [-1.5, 1.5], [-3, 3]], float)
X4 = box[:, 0] + rng.random((n, 4)) * (box[:, 1] - box[:, 0])
X2 = rng.uniform(-3, 3, (n, 2))
ipc_sys = ipc.closed_loop()
cases = {
    "ipc fast path": (ipc_sys, X4, "auto", StopRules(t_final=30.0)),
    "ipc public cfuncs": (dataclasses.replace(ipc_sys, numba_fast=None), X4, "auto",
                          StopRules(t_final=30.0)),
    "vanderpol generated": (vanderpol(), X2, "numba", StopRules()),
    "pendulum generated": (pendulum(), X2, "numba", StopRules()),
    "vanderpol numpy": (vanderpol(), X2[: max(n // 10, 1)], "numpy", StopRules()),
}
out = {}
for name, (system, X, backend, rules) in cases.items():
    t0 = time.process_time()
    integrate_batch(system, X[:2], backend=backend, rules=rules)  # compile or load
    first = time.process_time() - t0
    best, res = np.inf, None
    for _ in range(repeat):
        t0 = time.process_time()
        res = integrate_batch(system, X, backend=backend, rules=rules)
        best = min(best, time.process_time() - t0)
    h = hashlib.sha256()
    for a in (res.code, res.t_end, res.x_end, res.steps):
        h.update(np.ascontiguousarray(a).tobytes())
    out[name] = {"rate": len(X) / best, "first": first, "digest": h.hexdigest()}
print(json.dumps(out))
"""


def _clear_numba_cache(tree: Path) -> None:
    for pkg in ("roa", "ipc_paper"):
        for f in list((tree / pkg).rglob("*.nbi")) + list((tree / pkg).rglob("*.nbc")):
            f.unlink()


def _child(tree: Path, cache: Path, n: int, repeat: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "ROA_KERNEL_CACHE": str(cache)}
    out = subprocess.run([sys.executable, "-c", CHILD, str(n), str(repeat)], cwd=tree, env=env,
                         capture_output=True, text=True, timeout=3600)  # fmt: skip
    if out.returncode != 0:
        raise SystemExit(out.stderr[-3000:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("--other", required=True, help="the other checkout (e.g. main)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--n", type=int, default=20000, help="initial states per case")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per case and process")
    args = ap.parse_args()
    trees = {"this": HERE, "other": Path(args.other).resolve()}
    tmp = Path(tempfile.mkdtemp(prefix="bench-dopri-"))
    best: dict[str, dict[str, dict]] = {k: {} for k in trees}
    first: dict[str, dict[str, float]] = {k: {} for k in trees}
    try:
        for tree in trees.values():
            _clear_numba_cache(tree)
        for r in range(args.rounds):
            for label, tree in list(trees.items())[:: 1 if r % 2 == 0 else -1]:
                res = _child(tree, tmp / label, args.n, args.repeat)
                for case, v in res.items():
                    if r == 0:
                        first[label][case] = v["first"]
                    old = best[label].get(case)
                    if old is None or v["rate"] > old["rate"]:
                        best[label][case] = v
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; {args.rounds} rounds, "
          f"n = {args.n} (numpy: n / 10), best of {args.repeat} per process, CPU time")  # fmt: skip
    print(f"{'case':22s} {'this runs/s':>12s} {'other runs/s':>13s} {'ratio':>6s} "
          f"{'compile this':>13s} {'other':>6s}  same bits")  # fmt: skip
    for case in best["this"]:
        a, b = best["this"][case], best["other"][case]
        same = a["digest"] == b["digest"]
        print(f"{case:22s} {a['rate']:12.0f} {b['rate']:13.0f} {a['rate'] / b['rate']:6.3f} "
              f"{first['this'][case]:12.1f}s {first['other'][case]:5.1f}s  {same}")  # fmt: skip


if __name__ == "__main__":
    main()
