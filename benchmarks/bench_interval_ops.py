"""Benchmark of interval products and sums, and of the SOS route's refusal of a network's field.

Run: ``python benchmarks/bench_interval_ops.py``.

Baselines, run side by side:

* interval product: the four endpoint products stacked, NaN (``0 * inf``) set to 0, min and max
  along the stack, each bound rounded outward in its own error-state switch (what
  :class:`roa.proof._interval.Interval` did before); checked to give the same bits.
* refusal of a field the SOS route cannot take (the pendulum's tanh and ReLU controllers):
  converting every float of the field to an exact rational and writing it in the offsets from
  the equilibrium before looking for functions of the state, against
  :func:`roa.proof._sos_check.state_functions` (the same substitution on the field as written,
  its coefficients left as floats). sympy's cache is cleared before each run.
"""

from __future__ import annotations

import timeit
from pathlib import Path

import numpy as np

import roa
from roa.proof._interval import Interval, round_down, round_up

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def baseline_product(a: Interval, b: Interval) -> tuple[np.ndarray, np.ndarray]:
    with np.errstate(invalid="ignore", over="ignore"):
        p = np.stack([a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi])
    p = np.where(np.isnan(p), 0.0, p)
    return round_down(p.min(axis=0)), round_up(p.max(axis=0))


def baseline_sum(a: Interval, b: Interval) -> tuple[np.ndarray, np.ndarray]:
    return round_down(a.lo + b.lo), round_up(a.hi + b.hi)


def _per_call(f, number: int) -> float:
    return min(timeit.repeat(f, number=number, repeat=5)) / number * 1e6


def intervals() -> None:
    rng = np.random.default_rng(0)
    print(f"{'size':>6} {'op':>4} {'baseline us':>12} {'roa us':>8} {'ratio':>6}")
    for size in (1, 16, 256, 4096):
        x, y = rng.standard_normal(size), rng.standard_normal(size)
        a, b = Interval(x - 0.5, x), Interval(y, y + 0.25)
        for op, base in (("*", baseline_product), ("+", baseline_sum)):
            ours = (lambda a=a, b=b: a * b) if op == "*" else (lambda a=a, b=b: a + b)
            lo, hi = base(a, b)
            r = ours()
            assert np.array_equal(lo, r.lo) and np.array_equal(hi, r.hi)  # the same bits
            n = 20000 if size < 1000 else 2000
            t0 = _per_call(lambda base=base, a=a, b=b: Interval(*base(a, b)), n)
            t1 = _per_call(ours, n)
            print(f"{size:>6} {op:>4} {t0:>12.2f} {t1:>8.2f} {t0 / t1:>6.2f}")


def refusals() -> None:
    import sympy as sp

    from roa.model._backend import namespace
    from roa.model._sympy_eval import exact_rationals
    from roa.proof._sos_check import state_functions

    print(f"\n{'field':>12} {'convert first s':>16} {'floats s':>13} {'ratio':>6}")
    for name in ("SYSTEM", "SYSTEM_RELU"):
        system = roa.load_system(f"{EXAMPLES / 'systems' / 'pendulum_nn.py'}:{name}")
        xs = list(sp.symbols(f"x0:{system.n}", real=True))
        with sp.evaluate(False):
            f = system.field(0.0, xs, namespace("sympy"))

        d = list(sp.symbols(f"d0:{system.n}", real=True))
        shift = {x: di + 0 for x, di in zip(xs, d, strict=True)}  # the equilibrium is 0

        def convert_first(f=f, shift=shift):
            g = [exact_rationals(sp.sympify(fi)).xreplace(shift) for fi in f]
            return {a for gi in g for a in gi.atoms(sp.Function, sp.Min, sp.Max) if a.free_symbols}

        def as_written(f=f, shift=shift):
            return state_functions(f, shift)

        assert len(convert_first()) == len(as_written()) > 0
        clear = sp.core.cache.clear_cache
        t0 = min(timeit.repeat(convert_first, setup=clear, number=1, repeat=3))
        t1 = min(timeit.repeat(as_written, setup=clear, number=1, repeat=3))
        print(f"{name:>12} {t0:>16.3f} {t1:>13.3f} {t0 / t1:>6.1f}")


if __name__ == "__main__":
    intervals()
    refusals()
