"""Audit of the box contraction (roa.proof._contract) against an independent reference in mpmath
interval arithmetic at 200 bits (outward rounded by mpmath, so its box is a rigorous enclosure
of the exact step-by-step contraction, tight to ~1e-55).

The reference repeats the module's argument coordinate by coordinate: ``c_ii d_i^2 <= level -
R_i`` with ``R_i`` the sum of the other terms over the current box (squares of intervals tight,
products of intervals by their four corners), then ``d_i`` in ``[-sqrt(u), sqrt(u)]``. The
float contraction must hold the reference box (each of its steps runs on a box at least as wide,
so its bounds are at least as wide: monotone), be within a few ulps of it (tight, so the audit
can see a rounding error), and declare a box empty only when the reference does. The same
checker is then shown to catch a contraction rounded inward and a box shrunk by one ulp.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

import roa
import roa.proof._contract as C
from roa.proof._validate import QuadraticForm

iv = mp.iv


def _forms(seed: int, n: int = 4) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    return [
        np.diag(rng.uniform(0.3, 3.0, n)),  # diagonal: the contraction is the exact projection
        np.diag(rng.uniform(0.5, 2, n)) + 0.02 * (A + A.T),  # near-diagonal (whitened frames)
        A @ A.T + 0.3 * np.eye(n),  # general
    ]


def _boxes(rng: np.random.Generator, n: int, m: int = 150) -> tuple[np.ndarray, np.ndarray]:
    mid = rng.uniform(-1.2, 1.2, (m, n))
    rad = rng.uniform(0.01, 0.9, (m, n))
    return mid - rad, mid + rad


def _reference(quad: QuadraticForm, lo: np.ndarray, hi: np.ndarray, level: float):
    """``(box, empty)``: the contraction of one box in mpmath intervals (module doc)."""
    n = quad.n
    c = [mp.mpf(float(v)) for v in quad.center]
    coef = {}
    for (p, q), v in quad.coef.items():
        e = roa.proof.Interval.of(v)
        coef[p, q] = iv.mpf([float(np.ravel(e.lo)[0]), float(np.ravel(e.hi)[0])])
    box = [[iv.mpf(float(lo[i])), iv.mpf(float(hi[i]))] for i in range(n)]  # end points
    for i in range(n):
        cii = coef.get((i, i))
        if cii is None or not cii.a > 0:
            continue
        d = [iv.mpf([box[j][0].a, box[j][1].b]) - c[j] for j in range(n)]
        rest = iv.mpf(0)
        for (p, q), cpq in coef.items():
            if p == q == i:
                continue
            rest += (d[p] ** 2 if p == q else d[p] * d[q]) * cpq
        u = (iv.mpf(level) - rest.a) / cii.a  # its upper end bounds d_i^2
        if u.b < 0:
            return box, True
        s = iv.sqrt(iv.mpf([0, u.b]))
        new_lo = iv.mpf(c[i]) - s.b  # the lower end of this is the bound
        new_hi = iv.mpf(c[i]) + s.b
        lo_i = box[i][0] if box[i][0].a >= new_lo.a else iv.mpf(new_lo.a)
        hi_i = box[i][1] if box[i][1].b <= new_hi.b else iv.mpf(new_hi.b)
        if lo_i.a > hi_i.b:
            return box, True
        box[i] = [lo_i, hi_i]
    return box, False


def _violations(contract, P: np.ndarray, seed: int, level: float = 1.0) -> dict[str, int]:
    """Counts of unsound bounds, loose bounds (more than 1e-11 relative past the reference) and
    wrong empties."""
    n = len(P)
    quad = QuadraticForm.of(roa.QuadraticLyapunov(P, np.zeros(n)))
    assert quad is not None
    rng = np.random.default_rng(seed)
    lo, hi = _boxes(rng, n)
    lo2, hi2, empty = contract(quad, lo, hi, level)
    out = {"unsound": 0, "loose": 0, "wrong_empty": 0, "cut": 0, "empty": int(empty.sum())}
    with mp.workprec(200):
        for b in range(len(lo)):
            ref, ref_empty = _reference(quad, lo[b], hi[b], level)
            if empty[b]:
                out["wrong_empty"] += not ref_empty
                continue
            if ref_empty:
                continue  # the float steps, on wider boxes, may not see it: sound
            for i in range(n):
                rlo, rhi = ref[i][0].a, ref[i][1].b
                out["cut"] += bool(lo2[b, i] > lo[b, i]) + bool(hi2[b, i] < hi[b, i])
                out["unsound"] += bool(mp.mpf(lo2[b, i]) > rlo) + bool(mp.mpf(hi2[b, i]) < rhi)
                tol = 1e-11 * max(abs(lo2[b, i]), abs(hi2[b, i]), 1.0)
                out["loose"] += bool(mp.mpf(lo2[b, i]) < rlo - tol)
                out["loose"] += bool(mp.mpf(hi2[b, i]) > rhi + tol)
    return out


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("kind", range(3), ids=["diagonal", "near-diagonal", "general"])
def test_contraction_holds_and_is_tight_to_the_mpmath_interval_reference(seed, kind):
    P = _forms(seed)[kind]
    out = _violations(C.contract, P, seed)
    assert out["cut"] >= 40 and out["empty"] >= 5, out  # the contraction is exercised
    assert out["unsound"] == 0 and out["wrong_empty"] == 0, out
    # tight: 5 to ~1100 ulps above the reference on the cut bounds (measured), the float steps'
    # rounding amplified by 1 / (2 sqrt(u)) near the centre; nowhere near the original box
    assert out["loose"] == 0, out


def _inward(x, ulps=1):  # for round_up
    return np.nextafter(np.asarray(x, dtype=float), -np.inf)


def _outward_to_inward(x, ulps=1):  # for round_down
    return np.nextafter(np.asarray(x, dtype=float), np.inf)


@pytest.mark.parametrize("rounding", ["inward", "nearest"])
def test_the_audit_catches_inward_rounding(monkeypatch, rounding):
    """``round_up`` and ``round_down`` of the contraction replaced by one-ulp steps inward, or by
    no rounding at all (round-to-nearest results): the same checker finds bounds cutting into
    the reference box (measured: 536 inward, 118 nearest over these six cases)."""
    up, down = (_inward, _outward_to_inward) if rounding == "inward" else (_nearest, _nearest)
    monkeypatch.setattr(C, "round_up", up)
    monkeypatch.setattr(C, "round_down", down)
    found = sum(_violations(C.contract, _forms(s)[k], s)["unsound"]
                for s in range(2) for k in range(3))  # fmt: skip
    assert found >= 20


def _nearest(x, ulps=1):
    return np.asarray(x, dtype=float)


def test_the_audit_catches_a_shrunk_box():
    """Every upper bound the contraction moved, moved 64 ulps further in (the outward rounding's
    slack is 5 to ~1100 ulps): caught."""

    def shrunk(quad, lo, hi, level):
        lo2, hi2, empty = C.contract(quad, lo, hi, level)
        cut = hi2 < hi  # the bounds the contraction moved
        return lo2, np.where(cut, hi2 - 64 * np.spacing(hi2), hi2), empty

    found = sum(_violations(shrunk, _forms(s)[k], s)["unsound"] for s in range(2)
                for k in range(3))  # fmt: skip
    assert found >= 20
