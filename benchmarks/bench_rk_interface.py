"""Benchmark: what the array interface of the fields costs the Runge-Kutta step, side by side.

Two Dormand-Prince 5(4) loops with scipy's step-size control (the engine's, without events and
terminal sets) integrate the same IPC states (physical coordinates, bench_montecarlo.py's box,
seed 0, rtol 1e-6, atol 1e-9) to t = --t-final on one core:

* arrays (the engine's interface, ``field(t, x, params, out)``): stages in a (7, n) array, each
  stage's input and output passed as arrays (``ipc_paper.system.fast.physical_field_njit``);
* scalars: n = 4 unrolled, the field on scalars returning a tuple
  (``ipc_paper.system.fast.physical_scalar``, the same arithmetic), everything in registers.

Both take the same steps, run for run, and end on the same bits (checked); a run whose step
size underflows stops the benchmark. Prints ns per accepted step and the
ratio; the field alone (throughput of 2e6 calls) for scale.

    python benchmarks/bench_rk_interface.py [--n 4000] [--t-final 5]

Measured 2026-12-01 on the idle 2-core machine (one core; seven runs): field alone 36-48 ns;
arrays 510-626 ns/step, scalars 432-569 ns/step: x1.15-1.31. Six field calls are ~280 ns of the
step: a scalar-field protocol (n fixed at compile time) would save ~20 % per step of the engine,
not the 2x that issue 14's 3000x target needs on this machine (bench_montecarlo.py). Interleaving
2-8 runs in lockstep (to hide latency) measured no faster in a prototype (x0.8-1.3, noise).
"""

from __future__ import annotations

import argparse
import time

import bench_montecarlo as B  # noqa: N812
import numba
import numpy as np

from ipc_paper import system as ipc
from ipc_paper.system.fast import physical_field_njit as field, physical_scalar as f4
from roa.integration._dopri import ERROR_E, TABLEAU_A, TABLEAU_B, TABLEAU_C
from roa.montecarlo._sampling import box_sample

S, MAXF, MINF = 0.9, 10.0, 0.2


@numba.njit(error_model="numpy", inline="always")
def _control(en, h_abs, rejected):
    """scipy's step-size update: (accepted, new |h|); NaN is rejected, as in scipy."""
    if en < 1.0:
        factor = MAXF if en == 0.0 else min(MAXF, S * en**-0.2)
        return True, h_abs * (min(1.0, factor) if rejected else factor)
    return False, h_abs * max(MINF, S * en**-0.2)


@numba.njit(error_model="numpy", inline="always")
def _begin(t, h_abs, t_final):
    """scipy's start of a step: (step size underflowed, t_new, h), h clipped at t_final."""
    if h_abs < 10 * abs(np.nextafter(t, np.inf) - t):
        return True, t, 0.0
    t_new = min(t + h_abs, t_final)
    return False, t_new, t_new - t


@numba.njit(error_model="numpy")
def arrays(p, y0, t_final, rtol, atol, h0, y_out):
    n = y0.shape[0]
    K, y, y_new, tmp = np.empty((7, n)), y0.copy(), np.empty(n), np.empty(n)
    t, h_abs, steps = 0.0, h0, 0
    field(t, y, p, K[0])
    while t < t_final:
        rejected = False
        while True:
            bad, t_new, h = _begin(t, h_abs, t_final)
            if bad:
                return -1  # the step size underflowed (scipy: failure)
            h_abs = h
            for s in range(1, 6):
                for i in range(n):
                    acc = 0.0
                    for j in range(s):
                        acc += TABLEAU_A[s, j] * K[j, i]
                    tmp[i] = y[i] + h * acc
                field(t + TABLEAU_C[s] * h, tmp, p, K[s])
            for i in range(n):
                acc = 0.0
                for j in range(6):
                    acc += TABLEAU_B[j] * K[j, i]
                y_new[i] = y[i] + h * acc
            field(t + h, y_new, p, K[6])
            ss = 0.0
            for i in range(n):
                acc = 0.0
                for j in range(7):
                    acc += ERROR_E[j] * K[j, i]
                e = h * acc / (atol + max(abs(y[i]), abs(y_new[i])) * rtol)
                ss += e * e
            ok, h_abs = _control(np.sqrt(ss / n), h_abs, rejected)
            if ok:
                break
            rejected = True
        steps += 1
        t = t_new
        y[:] = y_new
        K[0] = K[6]
    y_out[:] = y
    return steps


@numba.njit(error_model="numpy", inline="always")
def _lin(y, h, c, k):  # y + h (c . k), summed in the order of the array loop
    acc = 0.0
    for j in range(len(c)):
        acc += c[j] * k[j]
    return y + h * acc


@numba.njit(error_model="numpy", inline="always")
def _st(y, h, c, ks):  # the four components of a stage input
    return (_lin(y[0], h, c, (ks[0][0], ks[1][0], ks[2][0], ks[3][0], ks[4][0], ks[5][0], ks[6][0])),
            _lin(y[1], h, c, (ks[0][1], ks[1][1], ks[2][1], ks[3][1], ks[4][1], ks[5][1], ks[6][1])),
            _lin(y[2], h, c, (ks[0][2], ks[1][2], ks[2][2], ks[3][2], ks[4][2], ks[5][2], ks[6][2])),
            _lin(y[3], h, c, (ks[0][3], ks[1][3], ks[2][3], ks[3][3], ks[4][3], ks[5][3], ks[6][3])))  # fmt: skip


@numba.njit(error_model="numpy", inline="always")
def _f(x, p):
    r = f4(x[0], x[1], x[2], x[3], p)
    return (r[0], r[1], r[2], r[3])


@numba.njit(error_model="numpy")
def scalars(p, y0, t_final, rtol, atol, h0, y_out):
    a, b, e = TABLEAU_A, TABLEAU_B, ERROR_E
    z = (0.0, 0.0, 0.0, 0.0)
    y = (y0[0], y0[1], y0[2], y0[3])
    k1 = _f(y, p)
    t, h_abs, steps = 0.0, h0, 0
    while t < t_final:
        rejected = False
        while True:
            bad, t_new, h = _begin(t, h_abs, t_final)
            if bad:
                return -1  # the step size underflowed (scipy: failure)
            h_abs = h
            k2 = _f(_st(y, h, (a[1, 0],), (k1, z, z, z, z, z, z)), p)
            k3 = _f(_st(y, h, (a[2, 0], a[2, 1]), (k1, k2, z, z, z, z, z)), p)
            k4 = _f(_st(y, h, (a[3, 0], a[3, 1], a[3, 2]), (k1, k2, k3, z, z, z, z)), p)
            k5 = _f(_st(y, h, (a[4, 0], a[4, 1], a[4, 2], a[4, 3]), (k1, k2, k3, k4, z, z, z)), p)
            k6 = _f(_st(y, h, (a[5, 0], a[5, 1], a[5, 2], a[5, 3], a[5, 4]),
                        (k1, k2, k3, k4, k5, z, z)), p)  # fmt: skip
            yn = _st(y, h, (b[0], b[1], b[2], b[3], b[4], b[5]), (k1, k2, k3, k4, k5, k6, z))
            k7 = _f(yn, p)
            ks = (k1, k2, k3, k4, k5, k6, k7)
            ss = 0.0
            for i in range(4):
                d = _lin(0.0, h, (e[0], e[1], e[2], e[3], e[4], e[5], e[6]),
                         (ks[0][i], ks[1][i], ks[2][i], ks[3][i], ks[4][i], ks[5][i], ks[6][i]))  # fmt: skip
                r = d / (atol + max(abs(y[i]), abs(yn[i])) * rtol)
                ss += r * r
            ok, h_abs = _control(np.sqrt(ss / 4), h_abs, rejected)
            if ok:
                break
            rejected = True
        steps += 1
        t = t_new
        y, k1 = yn, k7
    for i in range(4):
        y_out[i] = y[i]
    return steps


@numba.njit(error_model="numpy")
def batch(kind, p, X, t_final, rtol, atol, h0, Y, steps):
    for k in range(X.shape[0]):
        if kind == 0:
            steps[k] = arrays(p, X[k], t_final, rtol, atol, h0, Y[k])
        else:
            steps[k] = scalars(p, X[k], t_final, rtol, atol, h0, Y[k])


@numba.njit(error_model="numpy")
def field_alone(p, N):
    acc = 0.0
    for i in range(N):
        r = f4(0.1 + i * 1e-9, 0.2, 0.3 + i * 1e-9, 0.4, p)
        acc += r[1] + r[3]
    return acc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("--n", type=int, default=4000)
    ap.add_argument("--t-final", type=float, default=5.0)
    args = ap.parse_args()
    system = ipc.closed_loop()
    p = system.numba_fast()[2]
    X = np.ascontiguousarray(box_sample(system, B.BOX, args.n, seed=0).points(0, args.n))
    h0 = 1e-3  # the same first step for both (the engine selects it as scipy does)
    Ys = [np.empty_like(X), np.empty_like(X)]
    Ns = [np.zeros(len(X), np.int64), np.zeros(len(X), np.int64)]
    for kind in (0, 1):  # compile
        batch(kind, p, X[:4], args.t_final, B.RTOL, B.ATOL, h0, Ys[kind][:4], Ns[kind][:4])
    field_alone(p, 10)
    t0 = time.perf_counter()
    field_alone(p, 2_000_000)
    print(f"IPC field alone (physical_scalar): {(time.perf_counter() - t0) / 2e6 * 1e9:.1f} ns")
    per = []
    for kind, name in ((0, "arrays"), (1, "scalars")):
        t0 = time.perf_counter()
        batch(kind, p, X, args.t_final, B.RTOL, B.ATOL, h0, Ys[kind], Ns[kind])
        if (Ns[kind] < 0).any():
            raise SystemExit(f"{name}: the step size underflowed on {(Ns[kind] < 0).sum()} runs")
        steps = int(Ns[kind].sum())
        per.append((time.perf_counter() - t0) / steps * 1e9)
        print(f"  {name:8s} {args.n} runs to t = {args.t_final:g}: {steps} accepted steps, "
              f"{per[-1]:.0f} ns/step")  # fmt: skip
    print(f"  scalars / arrays: x{per[0] / per[1]:.2f} faster per step")
    if not (np.array_equal(Ns[0], Ns[1]) and np.array_equal(Ys[0], Ys[1], equal_nan=True)):
        raise SystemExit("the two loops take different steps or end on different states")


if __name__ == "__main__":
    main()
