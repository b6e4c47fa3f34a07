"""Benchmark of the certification: interval B&B vs a naive uniform-grid interval check, SOS times.

Run: ``python benchmarks/bench_certify.py [--no-symmetry]`` (the option adds the SOS baseline
without the even/odd block split). Targets: IPC paper's V at 0.999 of the sampled
optimum certified in < 60 s on 2 cores; SOS level of the IPC's quadratic V in < 30 s; Van der Pol
against the published rho = 2.3045 (Drake notes).

Baseline: the same interval evaluation (:func:`roa.proof.evaluate_boxes`, the same tests
per box over the same cover and local box) on a *uniform* grid of boxes (no branch and bound) of
increasing resolution, stopped at the first resolution that proves every box or after a budget.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from ipc_paper.system import transformed
from ipc_paper.system.lyapunov import paper_lyapunov
from roa.lyapunov import QuadraticLyapunov
from roa.proof._cover import prove_cover
from roa.proof._local import local_box
from roa.proof._validate import evaluate_boxes, validate_level
from roa.proof._whiten import Whitened, whitened_system, whitening_for
from roa.search._levelset import level_search
from roa.search._rays import ray_box
from roa.search._sos import sos_level
from roa.systems.vanderpol import P_BENCHMARK, RHO_BENCHMARK, vanderpol


def uniform_grid(system, V, level, *, max_boxes=4_000_000):
    """Uniform grids of k^n boxes (k = 4, 8, ...) over the validation's cover in its whitened frame,
    with the same tests per box as the branch and bound; status and boxes."""
    M = whitening_for(V)
    W = V if M is None else Whitened(V, system, M)
    S = system if M is None else whitened_system(system, W)
    (lo0, hi0), _, _ = prove_cover(W, level, None, estimate=ray_box)
    found = local_box(S, W, lo0, hi0)
    loc_lo, loc_hi = (W.center, W.center) if found is None else found[:2]
    n, total, k = V.n, 0, 4
    t0 = time.perf_counter()
    while k**n <= max_boxes:
        edges = np.linspace(lo0, hi0, k + 1)
        idx = np.stack(np.meshgrid(*[np.arange(k)] * n, indexing="ij"), -1).reshape(-1, n)
        ok = True
        for chunk in np.array_split(idx, max(1, len(idx) // 100_000)):
            lo = edges[chunk, np.arange(n)]
            hi = edges[chunk + 1, np.arange(n)]
            Vi, Vd, F_hi, _, margin = evaluate_boxes(S, W, lo, hi, level)
            total += len(lo)
            inside = np.ones(len(lo), bool) if margin is None else margin.lo > 0
            in_local = np.all((lo >= loc_lo) & (hi <= loc_hi), axis=1)
            if np.any(~((Vi.lo > level) | in_local | (((Vd.hi < 0) | (F_hi < 0)) & inside))):
                ok = False
                break
        if ok:
            return "certified", total, time.perf_counter() - t0
        k *= 2
    return "inconclusive", total, time.perf_counter() - t0


def row(name, status, boxes, secs):
    print(f"{name:<52} {status:<13} {boxes:>10} {secs:>9.2f}")


def main() -> None:
    print(f"{'case':<52} {'status':<13} {'boxes':>10} {'seconds':>9}")
    vdp = vanderpol()
    Vv = QuadraticLyapunov.for_system(vdp, P_BENCHMARK)
    t = time.perf_counter()
    s = sos_level(vdp, Vv)
    row(
        f"VdP SOS rho = {s.level:.5f} (published {RHO_BENCHMARK})",
        s.status,
        0,
        time.perf_counter() - t,
    )
    for f in (0.999, 1.001):
        v = validate_level(vdp, Vv, f * RHO_BENCHMARK, cover_estimate=ray_box)
        row(f"VdP interval B&B at {f} x 2.3045", v.status, v.boxes, v.seconds)
    st, b, sec = uniform_grid(vdp, Vv, 0.999 * RHO_BENCHMARK)
    row("VdP baseline uniform grid at 0.999 x 2.3045", st, b, sec)

    ipc = transformed()
    Vp = paper_lyapunov()
    t = time.perf_counter()
    opt = float(level_search(ipc, Vp, shape="level", method="sampled").level)
    row(f"IPC sampled optimum {opt:.6f}", "sampled", 0, time.perf_counter() - t)
    v = validate_level(ipc, Vp, 0.999 * opt, cover_estimate=ray_box)
    row("IPC interval B&B at 0.999 x optimum (target 60 s)", v.status, v.boxes, v.seconds)
    st, b, sec = uniform_grid(ipc, Vp, 0.999 * opt, max_boxes=2_000_000)
    row("IPC baseline uniform grid at 0.999 x optimum", st, b, sec)
    print(f"ratio baseline/B&B time: {sec / v.seconds:.1f}x ({'baseline ' + st})")
    v2 = validate_level(ipc, Vp, 1.001 * opt, cover_estimate=ray_box)
    row("IPC interval B&B at 1.001 x optimum", v2.status, v2.boxes, v2.seconds)
    s = sos_level(ipc, Vp, recast_mode="enclosure")
    row(f"IPC SOS enclosure rho = {s.level}", s.status, 0, s.seconds)
    ex = sos_level(ipc, Vp, recast_mode="exact", aux_degree=2)
    row(f"IPC SOS exact, even/odd blocks rho = {ex.level} (target 30 s)", ex.status, 0, ex.seconds)
    if "--no-symmetry" in sys.argv:  # baseline: the full Gram matrix (about 150 s, inaccurate)
        base = sos_level(
            ipc, Vp, recast_mode="exact", symmetry=False, solver_options={"time_limit": 300}
        )
        row(f"IPC SOS exact, one Gram block rho = {base.level}", base.status, 0, base.seconds)
        print(f"ratio one-block/blocks SOS time: {base.seconds / ex.seconds:.1f}x")


if __name__ == "__main__":
    main()
