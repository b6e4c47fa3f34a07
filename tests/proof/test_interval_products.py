"""Products and sums of :class:`roa.proof._interval.Interval` arrays: each entry encloses the exact
products of its endpoints (Fractions), ``0 * inf`` counts as 0, and an entry's bounds do not
depend on the other entries of its array (a batch holding a ``0 * inf`` entry takes another code
path than one without)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from roa.proof._interval import Interval

SPECIAL = np.array([0.0, -0.0, 1.0, -1.0, 1e-310, -1e-310, 1e300, -1e300, np.inf, -np.inf])


def _intervals(rng: np.random.Generator, size: int) -> tuple[np.ndarray, np.ndarray]:
    x = np.where(rng.random(size) < 0.5, rng.standard_normal(size) * 10.0 ** rng.integers(-20, 20, size),
                 rng.choice(SPECIAL, size))  # fmt: skip
    y = np.where(
        rng.random(size) < 0.5, rng.choice(SPECIAL, size), x + np.abs(rng.standard_normal(size))
    )
    return np.minimum(x, y), np.maximum(x, y)


def _exact_products(a: tuple[float, float], b: tuple[float, float]) -> list[Fraction | float]:
    """The four endpoint products, exact where finite; ``0 * inf`` is 0 (a factor exactly 0)."""
    out: list[Fraction | float] = []
    for u in a:
        for v in b:
            if u == 0.0 or v == 0.0:
                out.append(Fraction(0))
            elif np.isinf(u) or np.isinf(v):
                out.append(float(np.sign(u) * np.sign(v) * np.inf))
            else:
                out.append(Fraction(u) * Fraction(v))
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_products_enclose_the_exact_endpoint_products_and_ignore_other_entries(seed):
    rng = np.random.default_rng(seed)
    alo, ahi = _intervals(rng, 200)
    blo, bhi = _intervals(rng, 200)
    whole = Interval(alo, ahi) * Interval(blo, bhi)
    assert np.isnan(whole.lo).sum() == 0 and (whole.lo <= whole.hi).all()
    for k in range(200):
        exact = _exact_products((alo[k], ahi[k]), (blo[k], bhi[k]))
        assert whole.lo[k] <= min(exact) and whole.hi[k] >= max(exact)
        # the same bounds for the entry alone (a batch of one, with and without 0 * inf)
        alone = Interval(alo[k : k + 1], ahi[k : k + 1]) * Interval(blo[k : k + 1], bhi[k : k + 1])
        assert (alone.lo[0], alone.hi[0]) == (whole.lo[k], whole.hi[k])


def test_zero_times_an_unbounded_interval():
    a = Interval(np.array([0.0, 1.0]), np.array([1.0, 2.0]))
    b = Interval(np.array([2.0, 3.0]), np.array([np.inf, 4.0]))
    p = a * b  # entry 0 holds 0 * inf: [0, inf] exactly, widened outward
    assert p.lo[0] <= 0.0 and p.lo[0] > -1e-300 and p.hi[0] == np.inf
    assert p.lo[1] <= 3.0 < 3.0 + 1e-14 and 8.0 <= p.hi[1] < 8.0 + 1e-14


def test_sums_and_differences_enclose_the_exact_results():
    rng = np.random.default_rng(3)
    alo, ahi = _intervals(rng, 300)
    blo, bhi = _intervals(rng, 300)
    finite = np.isfinite(alo) & np.isfinite(ahi) & np.isfinite(blo) & np.isfinite(bhi)
    s = Interval(alo, ahi) + Interval(blo, bhi)
    d = Interval(alo, ahi) - Interval(blo, bhi)
    for k in np.flatnonzero(finite):
        f = Fraction
        assert s.lo[k] <= f(alo[k]) + f(blo[k]) and s.hi[k] >= f(ahi[k]) + f(bhi[k])
        assert d.lo[k] <= f(alo[k]) - f(bhi[k]) and d.hi[k] >= f(ahi[k]) - f(blo[k])
