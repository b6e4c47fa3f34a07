"""Discrete-time systems: certified level against an independent optimum, and the basin runs
against a plain numpy iteration.

Per system: the level certified by ``roa.certify`` at 0.99 x the independent optimum (the closed
form of the cubic map; multistart SLSQP on ``V(F(x)) - V(x)`` for the sampled NN pendulum), its
ratio to the optimum, boxes and seconds, the refutation at 1.01 x; then a Monte Carlo box sample
iterated by ``roa.basin`` and by a plain numpy loop (the baseline): the statuses must agree run for
run, every sample of the certified set must converge, and the time ratio is printed (for the cheap
cubic map it is the fixed cost of a basin run: checks, chunks, fingerprints). Exits non-zero when a check fails.

    python benchmarks/bench_discrete.py [--samples 20000] [--rk4]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples" / "systems"))

import roa  # noqa: E402
from roa.systems.cubic_map import cubic_map, optimum  # noqa: E402


def slsqp_optimum(step, P: np.ndarray, box: float, starts: int = 40) -> float:
    from scipy.optimize import minimize

    def dv(x: np.ndarray) -> float:
        y = step(x[None])[0]
        return float(y @ P @ y - x @ P @ x)

    rng = np.random.default_rng(0)
    best = np.inf
    for _ in range(starts):
        res = minimize(lambda x: float(x @ P @ x), rng.uniform(-box, box, 2), method="SLSQP",
                       constraints=[{"type": "ineq", "fun": dv},
                                    {"type": "ineq", "fun": lambda x: float(x @ x) - 0.05**2}],
                       options={"maxiter": 300, "ftol": 1e-12})  # fmt: skip
        if res.success and dv(res.x) >= -1e-9:
            best = min(best, float(res.fun))
    return best


def numpy_codes(step, X: np.ndarray, steps: int, tol: float, bound: float) -> np.ndarray:
    """The baseline: the map iterated on the whole batch in plain numpy (0 converged,
    2 diverged, 3 undecided), each row stopping at its first event."""
    code = np.full(len(X), -1)
    Y = X.copy()
    live = np.arange(len(X))
    for k in range(steps + 1):
        with np.errstate(all="ignore"):
            big = ~np.isfinite(Y).all(axis=1) | ~(np.linalg.norm(Y, axis=1) < bound)
            near = ~big & (np.linalg.norm(Y, axis=1) <= tol)
        code[live[big]], code[live[near]] = 2, 0
        keep = ~(big | near)
        live, Y = live[keep], Y[keep]
        if k == steps or not live.size:
            break
        with np.errstate(all="ignore"):
            Y = step(Y)
    code[live] = 3
    return code


def run(name: str, system, step, c_opt: float, box: float, samples: int, steps: int) -> bool:
    V = roa.default_lyapunov(system)
    t0 = time.perf_counter()
    cert = roa.certify(system, V, level=0.99 * c_opt)
    above = roa.certify(system, V, level=1.01 * c_opt)
    ok = cert.certified and above.status is roa.Verdict.REFUTED
    print(
        f"{name}: optimum {c_opt:.6g}; certified {cert.status.value} at "
        f"{cert.level / c_opt:.3f} x optimum ({cert.validation.boxes} boxes, "
        f"{cert.seconds:.1f} s); 1.01 x: {above.status.value}; {time.perf_counter() - t0:.1f} s"
    )
    rules = roa.StopRules(t_final=steps * (system.sample_time or 1.0), converge_tol=1e-3,
                          diverge_bound=1e3)  # fmt: skip
    sampler = roa.box_sample(system, [(-box, box)] * 2, samples, seed=0)
    t0 = time.perf_counter()
    res = roa.basin(system, sampler, rules=rules, run=roa.RunOptions(n_jobs=1))
    t_roa = time.perf_counter() - t0
    X = sampler.points(0, samples)
    t0 = time.perf_counter()
    base = numpy_codes(step, X, steps, 1e-3, 1e3)
    t_np = time.perf_counter() - t0
    same = bool(np.array_equal(res.code, base))
    inside = V.value(X) <= cert.level
    share = float(np.mean(inside[res.code == 0])) if np.any(res.code == 0) else float("nan")
    print(
        f"{name}: basin of {samples} samples: {res.counts['converged']} converged "
        f"(empirical share {res.counts['converged'] / samples:.3f}); certified set holds "
        f"{share:.3f} of them; statuses equal to the numpy baseline: {same}; "
        f"time roa / numpy = {t_roa / t_np:.2f}"
    )
    return ok and same and bool(np.all(res.code[inside] == 0))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=20000)
    parser.add_argument("--rk4", action="store_true", help="also the RK4 step (slower proof)")
    args = parser.parse_args(argv)
    ok = True
    cubic = cubic_map()
    ok &= run("cubic-map", cubic, cubic.step, optimum(), 2.5, args.samples, 60)
    import pendulum_nn_discrete as ex

    systems = [("pendulum-nn-euler", ex.SYSTEM)]
    if args.rk4:
        systems.append(("pendulum-nn-rk4", ex.SYSTEM_RK4))
    for name, s in systems:
        P = roa.default_lyapunov(s).P
        ok &= run(name, s, s.step, slsqp_optimum(s.step, P, 4.0), 6.0, args.samples, 1200)
    print("all checks passed" if ok else "A CHECK FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
