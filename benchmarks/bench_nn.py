"""Neural-network controllers certified by the interval branch and bound with CROWN bounds.

Run: ``python benchmarks/bench_nn.py [--systems pendulum-tanh,quadrotor-relu] [--baseline]
[--time-limit 600]``.

Systems (``examples/systems/``): the pendulum under 2-16-1 tanh and ReLU controllers
(``pendulum_nn.py``) and the planar quadrotor (6 states, sin/cos) under 6-16-16-2 tanh and ReLU
controllers (``quadrotor_nn.py``), every V the quadratic form from ``A'P + PA = -I``. Per system,
each in a fresh process:

* ``optimum``: an independent estimate of the largest level ``c*`` with ``V' < 0`` on
  ``{V <= c*}`` minus the equilibrium, computed here with scipy and numpy only (no roa search):
  the least ``V`` over the points found by multistart SLSQP for ``min V s.t. V' >= 0,
  V >= 1e-6 c0`` and along 20000 random rays (the first point with ``V' >= 0``, bisected). Each
  such point has ``V' >= 0``, so ``c*`` is at most its ``V``;
* ``certified``: :func:`roa.proof.validate.validate_level` at ``ratio x optimum`` (0.99 for the
  pendulum, 0.95 for the quadrotor): verdict, boxes, seconds, peak resident memory of the process;
  ``local`` names the proof near the equilibrium (``hessian``: no excluded region);
* ``above``: the verdict at ``1.01 x optimum`` (a refutation carries a 50-digit witness);
* ``baseline`` (``--baseline``): the same certification without the CROWN bounds
  (:data:`roa.proof.relax_vdot.ENABLED` off), and the ratio of boxes;
* ``share``: the empirical basin share beside the certified share: 20000 uniform samples of the
  box ``3 x`` the bounding box of ``{V <= optimum}``, simulated by RK4 (numpy, step 0.01, 30 s
  pendulum / 20 s quadrotor) and counted converged when ``|x(T)| < 1e-3``; ``in_basin`` is the
  share of samples that converged, ``certified_of_basin`` the share of converged samples inside
  the certified set ``{V <= level}`` with its Clopper-Pearson 95 % interval
  (:func:`roa.montecarlo.certified_share.clopper_pearson`).

Checks (exit 1 otherwise): every certified level at most the optimum; the target ratio certified;
``1.01 x optimum`` never certified; no certified sample outside the sampled basin.
Targets (issue 36): pendulum >= 0.99 in < 60 s; quadrotor >= 0.95 in < 10 min on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import resource
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import minimize

ROOT = Path(__file__).resolve().parents[1]
SYSTEMS = {
    "pendulum-tanh": ("pendulum_nn", "SYSTEM", 0.99, 30.0),
    "pendulum-relu": ("pendulum_nn", "SYSTEM_RELU", 0.99, 30.0),
    "quadrotor-tanh": ("quadrotor_nn", "SYSTEM", 0.95, 20.0),
    "quadrotor-relu": ("quadrotor_nn", "SYSTEM_RELU", 0.95, 20.0),
}


def _load(name: str) -> Any:
    sys.path.insert(0, str(ROOT / "examples" / "systems"))
    try:
        module, attr = SYSTEMS[name][:2]
        return getattr(__import__(module), attr)
    finally:
        sys.path.pop(0)


def independent_optimum(system: Any, P: np.ndarray, seed: int = 0) -> float:
    """The least V over points with V' >= 0 found by multistart SLSQP and along rays (module doc)."""
    n = system.n

    def V(x: np.ndarray) -> np.ndarray:
        return np.einsum("...i,ij,...j->...", x, P, x)

    def Vd(x: np.ndarray) -> np.ndarray:
        return 2.0 * np.einsum("...i,ij,...j->...", x, P, system.f(x))

    rng = np.random.default_rng(seed)
    U = rng.standard_normal((20000, n))
    U /= np.sqrt(V(U))[:, None]  # V(u) = 1: x = t u has V = t^2
    t = np.geomspace(1e-3, 1e2, 400)
    with np.errstate(all="ignore"):
        up = np.stack([Vd(s * U) >= 0 for s in t], axis=1)
    hit = up.any(axis=1) & ~up[:, 0]
    k = np.argmax(up, axis=1)
    lo, hi = t[np.maximum(k - 1, 0)], t[k]
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        with np.errstate(all="ignore"):
            b = Vd(mid[:, None] * U) >= 0
        hi, lo = np.where(b, mid, hi), np.where(b, lo, mid)
    best = float(np.min(hi[hit] ** 2)) if hit.any() else np.inf
    c0 = best if np.isfinite(best) else 1.0
    for _ in range(40):
        x0 = U[rng.integers(len(U))] * np.sqrt(c0) * rng.uniform(0.5, 1.5)
        res = minimize(lambda x: float(V(x)), x0, method="SLSQP",
                       constraints=[{"type": "ineq", "fun": lambda x: float(Vd(x))},
                                    {"type": "ineq", "fun": lambda x: float(V(x)) - 1e-6 * c0}],
                       options={"maxiter": 500, "ftol": 1e-14})  # fmt: skip
        if res.success and Vd(res.x) >= 0 and V(res.x) >= 1e-6 * c0:
            best = min(best, float(V(res.x)))
    return best


def basin_share(system: Any, P: np.ndarray, optimum: float, level: float, horizon: float,
                samples: int = 20000, seed: int = 1) -> dict[str, Any]:  # fmt: skip
    """Empirical basin share and the certified share of it (module doc)."""
    from roa.montecarlo.certified_share import clopper_pearson

    Pinv = np.linalg.inv(P)
    half = 3.0 * np.sqrt(optimum * np.diag(Pinv))  # the bounding box of {V <= optimum}, x 3
    rng = np.random.default_rng(seed)
    X0 = rng.uniform(-half, half, (samples, system.n))
    x, h = X0.copy(), 0.01
    with np.errstate(all="ignore"):
        for _ in range(int(horizon / h)):
            k1 = system.f(x)
            k2 = system.f(x + 0.5 * h * k1)
            k3 = system.f(x + 0.5 * h * k2)
            k4 = system.f(x + h * k3)
            x = x + (h / 6) * (k1 + 2 * k2 + 2 * k3 + k4)
            x = np.where(np.isfinite(x), x, 1e6)
    conv = np.linalg.norm(x, axis=1) < 1e-3
    inside = np.einsum("...i,ij,...j->...", X0, P, X0) <= level
    m, k = int(conv.sum()), int((conv & inside).sum())
    return {"in_basin": m / samples, "certified_of_basin": k / m if m else None,
            "ci95": list(clopper_pearson(k, m)), "certified_not_converged":
            int((inside & ~conv).sum())}  # fmt: skip


def run(name: str, baseline: bool, time_limit: float) -> dict[str, Any]:
    import roa
    import roa.proof.relax_vdot as rv
    from roa.model.linearisation import lyapunov_matrix
    from roa.proof.validate import validate_level

    system = _load(name)
    ratio, horizon = SYSTEMS[name][2], SYSTEMS[name][3]
    P = lyapunov_matrix(system)
    V = roa.QuadraticLyapunov(P, np.zeros(system.n))
    t0 = time.perf_counter()
    opt = independent_optimum(system, P)
    out: dict[str, Any] = {"system": name, "n": system.n, "optimum": opt,
                           "optimum_s": round(time.perf_counter() - t0, 1), "ratio": ratio}  # fmt: skip
    t0 = time.perf_counter()
    cert = validate_level(system, V, ratio * opt, time_limit=time_limit)
    out.update(status=cert.status.value, level=ratio * opt, boxes=cert.boxes,
               seconds=round(time.perf_counter() - t0, 1), local=cert.meta.get("local_proof"),
               peak_mb=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1))  # fmt: skip
    above = validate_level(system, V, 1.01 * opt, time_limit=time_limit)
    out["above"] = above.status.value
    if baseline:
        rv.ENABLED = False
        t0 = time.perf_counter()
        base = validate_level(system, V, ratio * opt, time_limit=time_limit)
        rv.ENABLED = True
        out.update(baseline_status=base.status.value, baseline_boxes=base.boxes,
                   baseline_seconds=round(time.perf_counter() - t0, 1),
                   boxes_ratio=round(base.boxes / max(cert.boxes, 1), 2))  # fmt: skip
    out["share"] = basin_share(system, P, opt, ratio * opt, horizon)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--systems", default=",".join(SYSTEMS))
    ap.add_argument("--baseline", action="store_true")
    ap.add_argument("--time-limit", type=float, default=600.0)
    args = ap.parse_args(argv)
    ok = True
    ctx = mp.get_context("spawn")
    for name in args.systems.split(","):
        with ctx.Pool(1) as pool:  # a fresh process per system: its own peak memory
            r = pool.apply(run, (name, args.baseline, args.time_limit))
        print(json.dumps(r), flush=True)
        s = r["share"]
        print(f"{name}: certified {r['level']:.6g} / optimum {r['optimum']:.6g} = {r['ratio']} "
              f"[{r['status']}, local proof {r['local']}], {r['boxes']} boxes, {r['seconds']} s, "
              f"peak {r['peak_mb']} MB; 1.01 x optimum: {r['above']}; basin share of the sampled "
              f"box {s['in_basin']:.3f}, certified share of the basin "
              f"{s['certified_of_basin']:.3f} (95 % CI {s['ci95'][0]:.3f}-{s['ci95'][1]:.3f})"
              + (f"; without CROWN: {r['baseline_status']}, {r['baseline_boxes']} boxes, "
                 f"{r['baseline_seconds']} s (boxes ratio {r['boxes_ratio']})"
                 if "baseline_boxes" in r else ""))  # fmt: skip
        ok &= r["status"] == "certified" and r["above"] != "certified"
        ok &= s["certified_not_converged"] == 0
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
