"""Neural-network controllers certified by the interval branch and bound with CROWN bounds.

Run: ``python benchmarks/bench_nn.py [--systems pendulum-tanh,quadrotor-relu] [--baseline]
[--time-limit 600] [--workers 2]``.

Systems (``examples/systems/``): the pendulum under 2-16-1 tanh and ReLU controllers
(``pendulum_nn.py``) and the planar quadrotor (6 states, sin/cos) under 6-16-16-2 tanh and ReLU
controllers (``quadrotor_nn.py``), every V the quadratic form from ``A'P + PA = -I`` (or, with
``--lyapunov conditioned``, :func:`roa.search.conditioned_lyapunov`'s). Per system,
each in a fresh process:

* ``optimum``: an independent estimate of the largest level ``c*`` with ``V' < 0`` on
  ``{V <= c*}`` minus the equilibrium, computed here with scipy and numpy only (no roa search):
  the least ``V`` over points with ``V' >= 0`` found along 20000 random rays (the first point
  with ``V' >= 0``, bisected), the best 16 rays' directions polished by an evolution strategy
  and SLSQP for ``min V s.t. V' >= 0`` from the polished points (:func:`independent_optimum`).
  Each such point has ``V' >= 0``, so ``c*`` is at most its ``V``; the best point is re-checked
  at 50 digits, moved out along its ray by a relative ``1e-15 2^k`` when it sits on ``V' = 0``
  with ``V' < 0`` exactly (``optimum_50_digits``: a refutation of every level from ``optimum``
  up, :func:`confirmed_optimum`);
* ``certified``: :func:`roa.proof.validate_level` at ``ratio x optimum`` (0.99 for the
  pendulum, 0.95 for the quadrotor) with ``--workers`` processes (default 2): verdict, boxes,
  wall seconds, CPU seconds (the process and its workers), peak resident memory of the process
  (``peak_mb``) and of its largest reaped worker (``peak_worker_mb``); on an inconclusive run the
  share of the cover's volume decided and the search's estimate of the boxes a full run needs;
  ``local`` names the proof near the equilibrium (``hessian``: no excluded region);
* ``above``: the verdict at ``1.01 x optimum`` (a refutation carries a 50-digit witness);
* ``baseline`` (``--baseline``): the same certification without the CROWN bounds
  (:data:`roa.proof._relax_vdot.ENABLED` off), and the ratio of boxes;
* ``share``: the empirical basin share beside the certified share: 20000 uniform samples of the
  box ``3 x`` the bounding box of ``{V <= optimum}``, simulated by RK4 (numpy, step 0.01, 30 s
  pendulum / 20 s quadrotor) and counted converged when ``|x(T)| < 1e-3``; ``in_basin`` is the
  share of samples that converged, ``certified_of_basin`` the share of converged samples inside
  the certified set ``{V <= level}`` with its Clopper-Pearson 95 % interval
  (:func:`roa.montecarlo.clopper_pearson`).

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
from concurrent.futures import ProcessPoolExecutor
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


def independent_optimum(system: Any, P: np.ndarray, seed: int = 0, rays: int = 20000,
                        rounds: int = 40) -> tuple[float, np.ndarray]:  # fmt: skip
    """The least V over points with V' >= 0 (module doc): ``(level, point)``.

    Along ``rays`` random directions the first crossing of ``V' >= 0`` (a scan, then bisection);
    the best 16 directions are then polished by an evolution strategy on the direction (batches
    of perturbed directions, each scanned below the best level so far; the step shrinks when no
    batch improves): the crossing level is piecewise smooth in the direction for a ReLU network,
    where SLSQP on ``min V s.t. V' >= 0`` stalls at kinks; SLSQP from the polished points last.
    Every point kept has ``V' >= 0`` in floats, so each is an upper bound of ``c*`` up to
    rounding (the benchmark re-checks the best at 50 digits)."""
    n = system.n
    rng = np.random.default_rng(seed)

    def V(x: np.ndarray) -> np.ndarray:
        return np.einsum("...i,ij,...j->...", x, P, x)

    def Vd(x: np.ndarray) -> np.ndarray:
        return 2.0 * np.einsum("...i,ij,...j->...", x, P, system.f(x))

    def crossing(D: np.ndarray, t_max: float, steps: int) -> tuple[np.ndarray, np.ndarray]:
        """Per direction the level ``V`` of the first point with ``V' >= 0`` up to ``V = t_max^2``
        (inf when none) and that point."""
        U = D / np.sqrt(V(D))[:, None]  # V(u) = 1: x = t u has V = t^2
        t = np.geomspace(1e-3, t_max, steps)
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
        return np.where(hit, hi**2, np.inf), U * hi[:, None]

    D = rng.standard_normal((rays, n))
    lev, X = crossing(D, 1e2, 400)
    if not np.isfinite(lev).any():
        return np.inf, np.zeros(n)
    order = np.argsort(lev)[:16]
    D, lev, X = D[order] / np.sqrt(V(D[order]))[:, None], lev[order], X[order]
    sigma = 0.05
    for _ in range(rounds):
        trial = D[:, None, :] + sigma * rng.standard_normal((len(D), 64, n))
        tl, tx = crossing(trial.reshape(-1, n), float(np.sqrt(lev.max())) * 1.01, 120)
        tl, tx = tl.reshape(len(D), 64), tx.reshape(len(D), 64, n)
        j = np.argmin(tl, axis=1)
        better = tl[np.arange(len(D)), j] < lev
        if not better.any():
            sigma *= 0.5
            continue
        rows = np.flatnonzero(better)
        D[rows] = trial[rows, j[rows]] / np.sqrt(V(trial[rows, j[rows]]))[:, None]
        lev[rows], X[rows] = tl[rows, j[rows]], tx[rows, j[rows]]
    best, point = float(lev.min()), X[np.argmin(lev)]
    floor = 1e-6 * best  # away from the equilibrium (V' = 0 there)
    for x0 in X[np.argsort(lev)[:8]]:
        res = minimize(lambda x: float(V(x)), x0, method="SLSQP",
                       constraints=[{"type": "ineq", "fun": lambda x: float(Vd(x))},
                                    {"type": "ineq", "fun": lambda x: float(V(x)) - floor}],
                       options={"maxiter": 500, "ftol": 1e-14})  # fmt: skip
        if Vd(res.x) >= 0 and floor <= V(res.x) < best:
            best, point = float(V(res.x)), res.x
    return best, point


def confirmed_optimum(system: Any, V: Any, opt: float, point: np.ndarray
                      ) -> tuple[float, np.ndarray, dict[str, Any]]:  # fmt: skip
    """``(level, point, check)``: the optimum's point re-checked at 50 digits
    (:func:`roa.proof.recheck_witness`); a point found on the surface ``V' = 0`` may have
    ``V' < 0`` exactly, so it is moved out along its ray from the equilibrium (``V'`` turns
    positive past the first crossing) by ``1e-15 2^k`` relative until confirmed; the level is
    then ``V`` there (``opt`` and ``point`` unchanged when none is confirmed)."""
    from roa.proof._witness import recheck_witness

    c = np.asarray(V.center, dtype=float)
    check: dict[str, Any] = {}
    for k in range(40):
        x = c + (point - c) * (1 + 1e-15 * 2.0**k)
        level = float(V.value(x[None])[0]) * (1 + 1e-12)
        check = recheck_witness(system, V, x, level)
        if check["confirmed"]:
            return max(opt, level), x, {**check, "moved_out": 1e-15 * 2.0**k}
    return opt, point, check


def basin_share(system: Any, P: np.ndarray, optimum: float, level: float, horizon: float,
                samples: int = 20000, seed: int = 1) -> dict[str, Any]:  # fmt: skip
    """Empirical basin share and the certified share of it (module doc)."""
    from roa.montecarlo._certified_share import clopper_pearson

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


def _cpu() -> float:
    """CPU seconds of this process and its reaped children (the forked box workers)."""
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def run(name: str, baseline: bool, time_limit: float, workers: int = 2,
        lyapunov: str = "lyapunov") -> dict[str, Any]:  # fmt: skip
    import roa
    import roa.proof._relax_vdot as rv
    from roa.model._linearisation import lyapunov_matrix
    from roa.proof._validate import validate_level
    from roa.search._rays import ray_box

    system = _load(name)
    ratio, horizon = SYSTEMS[name][2], SYSTEMS[name][3]
    if lyapunov == "conditioned":  # the best-conditioned decrease (roa.search._conditioned)
        from roa.search import conditioned_lyapunov

        V = conditioned_lyapunov(system)
        P = np.asarray(V.P)
    else:
        P = lyapunov_matrix(system)
        V = roa.QuadraticLyapunov(P, np.zeros(system.n))
    t0 = time.perf_counter()
    opt, point = independent_optimum(system, P)
    opt, point, witness = confirmed_optimum(system, V, opt, point)
    out: dict[str, Any] = {"system": name, "n": system.n, "V": V.name, "optimum": opt,
                           "optimum_s": round(time.perf_counter() - t0, 1), "ratio": ratio,
                           "optimum_point": point.tolist(), "optimum_50_digits": witness}  # fmt: skip
    t0, c0 = time.perf_counter(), _cpu()
    cert = validate_level(
        system, V, ratio * opt, time_limit=time_limit, workers=workers, cover_estimate=ray_box
    )
    out.update(status=cert.status.value, level=ratio * opt, boxes=cert.boxes,
               seconds=round(time.perf_counter() - t0, 1), cpu_s=round(_cpu() - c0, 1),
               workers=workers, local=cert.meta.get("local_proof"),
               peak_mb=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
               peak_worker_mb=round(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024, 1),
               volume_decided=cert.meta.get("volume_decided"),
               boxes_estimate=cert.meta.get("boxes_estimate"))  # fmt: skip
    above = validate_level(
        system, V, 1.01 * opt, time_limit=time_limit, workers=workers, cover_estimate=ray_box
    )
    out["above"] = above.status.value
    if baseline:
        rv.ENABLED = False
        t0 = time.perf_counter()
        base = validate_level(
            system, V, ratio * opt, time_limit=time_limit, workers=workers, cover_estimate=ray_box
        )
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
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--lyapunov", choices=("lyapunov", "conditioned"), default="lyapunov",
                    help="V: A'P + PA = -I, or the best-conditioned decrease "
                    "(roa.search.conditioned_lyapunov)")  # fmt: skip
    args = ap.parse_args(argv)
    ok = True
    ctx = mp.get_context("spawn")
    for name in args.systems.split(","):
        # a fresh (non-daemonic) process per system: its own peak memory, and it may fork workers
        with ProcessPoolExecutor(1, mp_context=ctx) as pool:
            r = pool.submit(run, name, args.baseline, args.time_limit, args.workers,
                            args.lyapunov).result()  # fmt: skip
        print(json.dumps(r), flush=True)
        s = r["share"]
        print(f"{name} ({r['V']}): certified {r['level']:.6g} / optimum {r['optimum']:.6g} = {r['ratio']} "
              f"(optimum point V' >= 0 at 50 digits: {r['optimum_50_digits']['confirmed']}) "
              f"[{r['status']}, local proof {r['local']}], {r['boxes']} boxes, {r['seconds']} s "
              f"({r['cpu_s']} s CPU, {r['workers']} workers), "
              f"peak {r['peak_mb']} MB; 1.01 x optimum: {r['above']}; basin share of the sampled "
              f"box {s['in_basin']:.3g}, certified share of the basin "
              f"{s['certified_of_basin']:.3g} (95 % CI {s['ci95'][0]:.3g}-{s['ci95'][1]:.3g})"
              + (f"; without CROWN: {r['baseline_status']}, {r['baseline_boxes']} boxes, "
                 f"{r['baseline_seconds']} s (boxes ratio {r['boxes_ratio']})"
                 if "baseline_boxes" in r else ""))  # fmt: skip
        ok &= r["status"] == "certified" and r["above"] != "certified"
        ok &= s["certified_not_converged"] == 0 and r["optimum_50_digits"]["confirmed"]
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
