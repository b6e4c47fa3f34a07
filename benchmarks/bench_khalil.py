"""Khalil's search (3.15) for the IPC: both methods, both shapes, vs a plain scipy multi-start.

Baseline: ``scipy.optimize.minimize`` (SLSQP, finite-difference gradients) on the same problem
(min s(x) s.t. V'(x)/s(x) >= 0) from the same number of starting points at violating states.
Prints the time of each and the ratio baseline / ours. Target: all four runs < 10 s on 2 cores.

    python benchmarks/bench_khalil.py
"""

from __future__ import annotations

import time

import numpy as np
from scipy.optimize import minimize

from ipc_paper.system import lyapunov as ly
from roa.search._levelset import casadi_level, sampled_level


def scipy_baseline(shape: str, n_starts: int = 16, seed: int = 1) -> tuple[float, int]:
    system, V = ly.flat_system(), ly.paper_lyapunov()
    S = ly.shape_matrix(shape)
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((8000, 4))
    X /= np.sqrt(np.einsum("ij,jk,ik->i", X, S, X))[:, None]
    X *= np.exp(rng.uniform(np.log(0.1), np.log(30.0), (8000, 1)))
    starts = X[V.derivative(system, X) > 0][:n_starts]

    def s(x):
        return float(x @ S @ x)

    def g(x):
        return float(V.derivative(system, x[None, :])[0]) / s(x)

    best, ok = np.inf, 0
    for x0 in starts:
        res = minimize(
            s,
            x0,
            method="SLSQP",
            constraints=[{"type": "ineq", "fun": g}],
            options={"ftol": 1e-12, "maxiter": 300},
        )
        if res.success and abs(float(V.derivative(system, res.x[None, :])[0])) < 1e-6:
            ok += 1
            best = min(best, res.fun)
    return best, ok


def main() -> None:
    ly.flat_system()
    casadi_level(ly.flat_system(), ly.paper_lyapunov(), np.eye(4), n_starts=1)  # warm imports
    total = 0.0
    print(f"{'shape':6s} {'method':8s} {'value':>14s} {'time s':>8s}")
    base_total = 0.0
    cas_total = 0.0
    for shape in ly.SHAPES:
        args = (ly.flat_system(), ly.paper_lyapunov(), ly.shape_matrix(shape))
        for name, fn in (("sampled", sampled_level), ("casadi", casadi_level)):
            t0 = time.perf_counter()
            r = fn(*args, shape=shape)
            dt = time.perf_counter() - t0
            total += dt
            cas_total += dt if name == "casadi" else 0.0
            print(f"{shape:6s} {name:8s} {r.value:14.10f} {dt:8.3f}")
        t0 = time.perf_counter()
        val, ok = scipy_baseline(shape)
        dt = time.perf_counter() - t0
        base_total += dt
        print(
            f"{shape:6s} {'scipy':8s} {val:14.10f} {dt:8.3f}   (SLSQP baseline, {ok}/16 converged)"
        )
    print(f"total ours (both methods, both shapes): {total:.2f} s (target < 10 s)")
    print(f"scipy SLSQP baseline (both shapes):     {base_total:.2f} s")
    print(
        f"ratio scipy baseline / CasADi (same problem, same starts): {base_total / cas_total:.2f}"
    )
    print(f"ratio scipy baseline / ours total (both methods):        {base_total / total:.2f}")


if __name__ == "__main__":
    main()
