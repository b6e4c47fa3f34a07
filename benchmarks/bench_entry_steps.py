"""Benchmark: how many accepted steps per run a larger certified terminal set would save, against
the certified degree-4 set of bench_montecarlo.py, side by side (issue 14's 3000x question).

The runs of bench_montecarlo.py's box (IPC, physical coordinates, seed 0, rtol 1e-6, atol 1e-9)
are integrated once by scipy's solve_ivp (RK45: the engine's step sequence, bit for bit) without a
terminal set; each accepted step's state is tested against

* the certified degree-4 set {V4 <= c} (flat coordinates; results/degrees) -- the baseline row,
  whose entry steps must equal the engine's, run for run (checked);
* its union with the certified degree-4 set of the hybrid coordinates and the certified quadratic
  set (results/certify): any union of certified sets is a valid terminal set;
* {V4 <= k c} for k > 1: NOT certified (the validation refutes just above c); an upper bound on
  what a larger certified set of the same shape could save.

Prints steps/run (all runs, those that start inside cost 0) and the ratio to the baseline row.

    python benchmarks/bench_entry_steps.py [--n 3000] [--outside 600]

Measured 2026-12-01 (3000 states, 600 of the runs that start outside; the degree-4 V of round 30,
level 1.02706): the certified degree-4 set 21.4 steps/run (61.9 % start inside; the engine, run
for run: the same); its union with the hybrid degree-4 and the quadratic sets 21.4 (x1.00: 62.0 %
inside, and the runs enter them at the same step); {V4 <= k c} for k = 1.25 / 1.5 / 2 / 3 / 5 /
10: 20.3 / 19.6 / 18.5 / 17.0 / 15.4 / 13.3 (x1.05-x1.60). The runs that take longest start near
|theta| = pi/2 and swing the cart far out (|q'| up to ~440) before settling: their ~60 % share of
the steps is spent where no sublevel set of V4 reaches.
"""

from __future__ import annotations

import argparse

import bench_montecarlo as B  # noqa: N812
import numpy as np

from ipc_paper import system as ipc
from roa.integration import _integrator as I  # noqa: N812
from roa.integration._simulation import simulate
from roa.integration._terminal import coords_map
from roa.montecarlo._sampling import box_sample

KS = (1.25, 1.5, 2.0, 3.0, 5.0, 10.0)


def first(mask: np.ndarray) -> int:
    """Index of the first accepted step inside (the run's steps if it never enters)."""
    return int(np.argmax(mask)) if mask.any() else len(mask) - 1


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("--n", type=int, default=3000, help="states of the box")
    ap.add_argument("--outside", type=int, default=600, help="runs starting outside to integrate")
    args = ap.parse_args()
    system = ipc.closed_loop()
    X = box_sample(system, B.BOX, args.n, seed=0).points(0, args.n)
    t4, th, tq = B.degree4_set(), B.degree4_set("hybrid"), B.certified_set("optimised")
    run = I.integrate_batch(system, X, rules=B.RULES, rtol=B.RTOL, atol=B.ATOL, terminal=t4)
    flat = coords_map(system, "flat")
    c = t4.level
    v0, in4 = t4.value(flat(X)), t4.contains(flat(X))
    out = np.flatnonzero(run.steps > 0)[: args.outside]
    share_out = float((run.steps > 0).mean())
    rows: dict[str, list[int]] = {"certified V4 <= c": [], "union (+ hybrid V4, quadratic)": []}
    rows.update({f"V4 <= {k:g} c (not certified)": [] for k in KS})
    bh, bq = th.bind(system), tq.bind(system)
    for i in out:
        tr = simulate(system, X[i], rules=B.RULES, rtol=B.RTOL, atol=B.ATOL, method="RK45")
        a = t4.contains(flat(tr.x))
        rows["certified V4 <= c"].append(first(a))
        rows["union (+ hybrid V4, quadratic)"].append(first(a | bh.inside(tr.x) | bq.inside(tr.x)))
        v = t4.value(flat(tr.x))
        for k in KS:
            rows[f"V4 <= {k:g} c (not certified)"].append(first(v <= k * c))
    mine = np.array(rows["certified V4 <= c"])
    if not np.array_equal(mine, run.steps[out]):  # the same step sequence: the same entry step
        bad = int(np.sum(mine != run.steps[out]))
        raise SystemExit(f"solve_ivp's entry steps disagree with the engine's on {bad} runs")
    inside0 = {
        "certified V4 <= c": float(in4.mean()),
        "union (+ hybrid V4, quadratic)": float((in4 | bh.inside(X) | bq.inside(X)).mean()),
    }
    inside0.update({f"V4 <= {k:g} c (not certified)": float((v0 <= k * c).mean()) for k in KS})
    base = share_out * float(np.mean(mine))
    print(f"IPC box {B.BOX}, {args.n} states, {len(out)} of the runs starting outside integrated")
    print(f"  engine with the certified set: {float(run.steps.mean()):.1f} steps/run")
    print(f"  {'terminal set':36s} {'inside at t=0':>13s} {'steps/run':>9s} {'x fewer':>8s}")
    for name, f in rows.items():  # a run inside at t = 0 enters at step 0
        steps = share_out * float(np.mean(f))
        ratio = f"{base / steps:7.2f}x" if steps > 0 else "    inf"
        print(f"  {name:36s} {inside0[name]:13.3f} {steps:9.1f} {ratio}")


if __name__ == "__main__":
    main()
