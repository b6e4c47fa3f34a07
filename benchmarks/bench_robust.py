"""Benchmark of robust certificates: time and certified level against the number of uncertain
parameters and the width of the box, against certifying at a grid of parameter values.

Run: ``python benchmarks/bench_robust.py [--quick] [--grid 2,3]``.

Cases (V fixed, quadratic):

* **Van der Pol** ``x1' = -x2, x2' = x1 + mu (x1^2 - 1) x2`` with the benchmark's
  ``P = [[1.5, -0.5], [-0.5, 1]]`` and ``mu`` uncertain in boxes of growing width around 1.
  Independent worst case: ``V'`` is affine in ``mu``, so for each ``x`` its largest value over the
  box is at an end, and the robust optimum is the smaller of the two ends' optima
  ``min V s.t. V' = 0, |x| >= 0.3``, each found by multistart SLSQP (scipy; no roa code).
* **poly**: ``x1' = -x1 + A(a) x1^3 + (c/2) x1 x2^2``, ``x2' = -x2 + b x2^3 + (c/2) x1^2 x2`` with
  ``A(a) = 1 - (2a - 1)^2`` and ``V = |x|^2``, with 1, 2 or 3 of ``a in [0, 1]``,
  ``b in [0.2, 0.6]``, ``c in [2, 3]`` uncertain (the others fixed at ``b = 0.6``, ``c = 3``).
  Closed form: with ``u = x1^2 = s r``, ``v = x2^2 = (1 - s) r``, ``r = V``,
  ``V'/2 = -r + r^2 q(s)``, ``q(s) = A s^2 + b (1 - s)^2 + c s (1 - s)``, so the optimum is
  ``1 / max_{s in [0, 1]} q(s)``; ``q`` grows with ``A``, ``b`` and ``c``, so the worst case is
  ``A = 1`` (``a = 1/2``, *inside* the box), ``b = 0.6``, ``c = 3``: ``33/28 = 1.17857...``
  for ``max q`` and ``28/33 = 0.848485`` for the level, the same for every case.

Per case: ``roa.certify(box, V)`` (the robust pipeline: a level proposed at the box's sample
points, validated for every parameter of the box), ``roa.certify`` at ``0.99 x`` the
independent worst case for the box (the branch and bound's validation alone), the exact SOS
validator (``roa.SosValidator``, parameters as indeterminates, :class:`roa.proof.ParameterBox`) at
``0.99 x`` and at ``1.01 x`` the worst case (``sos99``, ``t_sos``, ``sos101``); the naive alternative certifies at a
grid of ``G`` values per uncertain parameter, ``roa.certify(box.at(...), V)`` at each (its own
level), and takes the minimum, which proves nothing between grid points: the last column asks
``roa.certify(box, V, level=that minimum)`` whether it holds for the box.

Checks (exit 1 otherwise): no certified robust level above the independent worst case; the Van der
Pol robust level within 1 % of it; the box certified at 0.99 x the worst case; the SOS validator
never certifies 1.01 x it. Times are for the
machine at hand and are not checked.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import minimize

import roa
from roa.lyapunov import QuadraticLyapunov
from roa.model._system import System

P_VDP = np.array([[1.5, -0.5], [-0.5, 1.0]])


def vdp(t: Any, x: Any, xp: Any, p: Any) -> tuple:
    return (-x[1], x[0] + p.mu * (x[0] * x[0] - 1) * x[1])


def poly(t: Any, x: Any, xp: Any, p: Any) -> tuple:
    A = 1 - (2 * p.a - 1) ** 2  # a appears once: its interval enclosure is exact
    return (-x[0] + A * x[0] ** 3 + p.c * x[0] * x[1] ** 2 / 2,
            -x[1] + p.b * x[1] ** 3 + p.c * x[0] ** 2 * x[1] / 2)  # fmt: skip


def vdp_optimum(mu: float, starts: int = 60) -> float:
    """min x'Px s.t. V'(x) = 0, |x| >= 0.3 at ``mu`` by multistart SLSQP (independent of roa)."""

    def vdot(x: np.ndarray) -> float:
        f = np.array([-x[1], x[0] + mu * (x[0] ** 2 - 1) * x[1]])
        return float(2 * x @ P_VDP @ f)

    rng = np.random.default_rng(1)
    best = np.inf
    for _ in range(starts):
        x0 = rng.normal(size=2)
        x0 *= rng.uniform(0.5, 2.5) / np.linalg.norm(x0)
        res = minimize(lambda x: float(x @ P_VDP @ x), x0, method="SLSQP",
                       constraints=[{"type": "eq", "fun": vdot},
                                    {"type": "ineq", "fun": lambda x: x @ x - 0.09}],
                       options={"ftol": 1e-14, "maxiter": 500})  # fmt: skip
        if res.success and abs(vdot(res.x)) < 1e-9:
            best = min(best, float(res.x @ P_VDP @ res.x))
    return best


def poly_optimum(A: float, b: float, c: float) -> float:
    """``1 / max_{s in [0, 1]} q(s)`` in closed form (module doc)."""
    cands = [A, b]  # s = 1, s = 0
    kappa = A + b - c  # q(s) = kappa s^2 + (c - 2 b) s + b
    if kappa < 0:
        s = (2 * b - c) / (2 * kappa)
        if 0 < s < 1:
            cands.append(kappa * s * s + (c - 2 * b) * s + b)
    return 1.0 / max(cands)


def poly_worst(box: dict[str, tuple[float, float]], fixed: dict[str, float]) -> float:
    rng = {**{k: (v, v) for k, v in fixed.items()}, **box}
    a_lo, a_hi = rng["a"]
    A = 1.0 if a_lo <= 0.5 <= a_hi else max(1 - (2 * a_lo - 1) ** 2, 1 - (2 * a_hi - 1) ** 2)
    return poly_optimum(A, rng["b"][1], rng["c"][1])


@dataclass
class Case:
    name: str
    system: System
    V: Any
    worst: float
    within: float | None  # relative target for the robust level (None: none)


def cases(quick: bool) -> list[Case]:
    out = []
    widths = (0.4,) if quick else (0.2, 0.4, 0.6)
    for w in widths:
        lo, hi = 1.0 - w / 2, 1.0 + w / 2
        s = System("vdp", vdp, (0.0, 0.0), ("x1", "x2"), parameters={"mu": (lo, 1.0, hi)})
        worst = min(vdp_optimum(lo), vdp_optimum(hi))  # V' affine in mu: an end
        out.append(Case(f"vdp mu in [{lo:g}, {hi:g}]", s, QuadraticLyapunov(P_VDP, [0, 0]),
                        worst, 0.01))  # fmt: skip
    ranges = {"a": (0.0, 0.25, 1.0), "b": (0.2, 0.4, 0.6), "c": (2.0, 2.5, 3.0)}
    for k in (1,) if quick else (1, 2, 3):
        names = list(ranges)[:k]
        fixed = {n: ranges[n][2] for n in ranges if n not in names}
        box = {n: ranges[n] for n in names}
        s = System("poly", poly, (0.0, 0.0), ("x1", "x2"), params=fixed or None, parameters=box)
        worst = poly_worst({n: (r[0], r[2]) for n, r in box.items()}, fixed)
        out.append(Case(f"poly {k} param ({','.join(names)})", s,
                        QuadraticLyapunov(np.eye(2), [0, 0]), worst, None))  # fmt: skip
    return out


def timed(fn: Callable[[], Any]) -> tuple[Any, float]:
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def naive(case: Case, per_axis: int) -> tuple[float, float, int]:
    """min over a grid of per-point certified levels, its time, and the grid's size."""
    box = case.system.parameters
    axes = [np.linspace(r.low, r.high, per_axis) for r in box.values()]
    levels, t0 = [], time.perf_counter()
    for point in itertools.product(*axes):
        fixed = case.system.at(**{k: float(v) for k, v in zip(box, point, strict=True)})
        cert = roa.certify(fixed, case.V)
        if cert.status is roa.Verdict.CERTIFIED:
            levels.append(float(cert.level))
    return (min(levels) if levels else float("nan")), time.perf_counter() - t0, len(levels)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("--quick", action="store_true", help="one Van der Pol box, one poly case")
    ap.add_argument("--grid", default=None, help="values per parameter of the naive grid, e.g. 2,3")
    args = ap.parse_args()
    grids = [int(g) for g in (args.grid or ("2" if args.quick else "2,3")).split(",")]
    failures = []
    head = (f"{'case':<28} {'worst':>8} {'robust':>13} {'t_rob':>6} {'0.99w':>9} {'t_099':>6} "
            f"{'sos99':>9} {'t_sos':>6} {'sos101':>9} {'G':>2} {'naive min':>9} {'t_naive':>7} {'rob/naive':>9} {'rob/worst':>9} "
            f"{'t_rob/t_naive':>13} {'naive min for box':>17}")  # fmt: skip
    print(head)
    sos = roa.SosValidator(fallback=False)
    for case in cases(args.quick):
        rob, t_rob = timed(lambda c=case: roa.certify(c.system, c.V))
        at99, t99 = timed(lambda c=case: roa.certify(c.system, c.V, level=0.99 * c.worst))
        sos99, t_sos = timed(lambda c=case: sos.check(c.system, c.V, 0.99 * c.worst))
        sos101 = sos.check(case.system, case.V, 1.01 * case.worst)
        if sos101.status is roa.Verdict.CERTIFIED:
            failures.append(f"{case.name}: SOS certified 1.01 x the worst case")
        level = float(rob.level) if rob.status is roa.Verdict.CERTIFIED else float("nan")
        if rob.status is roa.Verdict.CERTIFIED and level > case.worst * (1 + 1e-9):
            failures.append(f"{case.name}: robust level {level} above the worst case {case.worst}")
        if case.within is not None and not abs(level / case.worst - 1) <= case.within:
            failures.append(f"{case.name}: robust level {level} not within {case.within:.0%} of "
                            f"{case.worst}")  # fmt: skip
        if at99.status is not roa.Verdict.CERTIFIED:
            failures.append(f"{case.name}: 0.99 x worst case {at99.status.value}")
        for g in grids:
            low, t_naive, _ = naive(case, g)
            check = roa.certify(case.system, case.V, level=low).status.value
            print(f"{case.name:<28} {case.worst:8.5f} {level:8.5f} {rob.status.value[:4]:>4} "
                  f"{t_rob:6.1f} {at99.status.value[:9]:>9} {t99:6.1f} "
                  f"{sos99.status.value[:9]:>9} {t_sos:6.2f} {sos101.status.value[:9]:>9} {g:2d} {low:9.5f} "
                  f"{t_naive:7.1f} {level / low:9.4f} {level / case.worst:9.4f} "
                  f"{t_rob / t_naive:13.2f} {check:>17}", flush=True)  # fmt: skip
    for f in failures:
        print("FAILED:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
