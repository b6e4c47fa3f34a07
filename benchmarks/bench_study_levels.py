"""The certify study's committed levels re-validated with the one interval loop (read-only).

Run: ``python benchmarks/bench_study_levels.py [--cases vanderpol,ipc_paper,...] [--baseline]``.

For each case of ``results/certify/evidence.json`` with a ``below``/``above`` pair (the
certified level and the refuted level just above the sampled optimum), the system and V are
rebuilt as ipc_paper/certify_cases.py builds them (the paper's V, or the quadratic ``P`` of the
case's search block; flat, hybrid or saturated flat coordinates) and
:func:`roa.proof.validate_level` (``max_boxes`` 3 M, the study's budget) is run at

* the committed certified level (expected: certified),
* the committed refuted level (expected: refuted),
* 1.001 x the certified level (no committed verdict: it may lie below the true optimum);
  ``--baseline`` adds the quadratic-only loop it replaced (the copy in
  ``bench_validator_parity.py``) at that level for comparison.

Nothing is written; exit 1 if a committed verdict is not reproduced.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from roa.lyapunov import QuadraticLyapunov
from roa.proof._validate import validate_level
from roa.search._rays import ray_box

ROOT = Path(__file__).resolve().parents[1]


def case_system_and_v(key: str, blk: dict):
    from ipc_paper.system import transformed
    from ipc_paper.system.hybrid import hybrid
    from ipc_paper.system.lyapunov import paper_lyapunov
    from roa.systems.vanderpol import P_BENCHMARK, vanderpol

    if key == "vanderpol":
        s = vanderpol()
        return s, QuadraticLyapunov.for_system(s, P_BENCHMARK, "benchmark")
    if key == "ipc_paper":
        return transformed(), paper_lyapunov()
    if "saturation" in blk:
        s = transformed(saturation=float(blk["saturation"]))
    else:
        s = {"flat": transformed, "hybrid": hybrid}[blk["coords"]]()
    return s, QuadraticLyapunov(np.asarray(blk["search"]["P"]), np.zeros(4), f"optimised ({key})")


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--cases", default="", help="comma-separated case keys (default: all)")
    ap.add_argument("--baseline", action="store_true", help="the old loop at 1.001 x too")
    ap.add_argument("--max-boxes", type=int, default=3_000_000)
    args = ap.parse_args()
    ev = json.loads((ROOT / "results/certify/evidence.json").read_text())
    keys = [k for k, v in ev.items() if isinstance(v, dict) and "below" in v and "above" in v]
    if args.cases:
        keys = [k for k in keys if k in args.cases.split(",")]
    if args.baseline:
        sys.path.insert(0, str(ROOT / "benchmarks"))
        from bench_validator_parity import validate_quadratic_baseline
    print(
        f"{'case':<18} {'what':<12} {'level':>12} {'committed':<10} {'one loop':<13} "
        f"{'boxes':>8} {'s':>6} {'committed boxes':>15}  {'baseline':<13}"
    )
    bad = []
    for key in keys:
        blk = ev[key]
        system, V = case_system_and_v(key, blk)
        rows = [
            ("certified", blk["below"]["level"], blk["below"]["status"], blk["below"]["boxes"]),
            ("refuted", blk["above"]["level"], blk["above"]["status"], blk["above"]["boxes"]),
            ("1.001 x cert", 1.001 * blk["below"]["level"], "-", None),
        ]
        for what, level, committed, cboxes in rows:
            r = validate_level(system, V, level, max_boxes=args.max_boxes, cover_estimate=ray_box)
            base = ""
            if args.baseline and committed == "-":
                b = validate_quadratic_baseline(system, V, level, max_boxes=args.max_boxes)
                base = f"{b.status.value} ({b.boxes})"
            if committed != "-" and r.status.value != committed:
                bad.append(f"{key} {what} {level}: {r.status.value} (committed {committed})")
            print(
                f"{key:<18} {what:<12} {level:>12.7f} {committed:<10} {r.status.value:<13} "
                f"{r.boxes:>8} {r.seconds:>6.1f} {cboxes if cboxes is not None else '':>15}  "
                f"{base}",
                flush=True,
            )
    if bad:
        print("NOT reproduced: " + "; ".join(bad))
        sys.exit(1)


if __name__ == "__main__":
    main()
