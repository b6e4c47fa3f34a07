"""Membership in a polynomial terminal set (roa/integration/_terminal_poly.py).

* the numpy and numba versions give the same answer, point for point, on random points, on points
  next to the level set (bisected onto it in float) and next to the box's faces, and on inf/NaN;
* every point counted inside has, in exact rational arithmetic (python's Fraction, the float
  point taken exactly), V <= level (1 - 1e-9) and z = Mi (y - c) in the box: the float test never
  lets a point outside count;
* a V with heavy cancellation (terms of 1e8 summing to ~1) shows the rounding allowance at work:
  a point whose float V is below the threshold but whose allowance is not is refused.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from roa.integration._terminal import TerminalSet
from roa.integration._terminal_poly import member_numba, member_numpy
from roa.lyapunov import PolynomialLyapunov

#: A degree-4 V in 3 variables with cross terms (positive definite quadratic part).
MONO = [[2, 0, 0], [0, 2, 0], [0, 0, 2], [1, 1, 0], [0, 1, 1], [4, 0, 0], [2, 2, 0], [1, 1, 2],
        [0, 0, 4], [3, 1, 0]]  # fmt: skip
COEF = [1.0, 2.0, 1.5, 0.4, -0.3, 0.25, 0.5, -0.2, 0.3, 0.1]
CENTER = np.array([0.1, -0.2, 0.05])
LEVEL = 1.3


def _term():
    V = PolynomialLyapunov(MONO, COEF, CENTER)
    frame = np.array([[1.0, 0.2, 0.0], [0.0, 0.8, 0.1], [0.0, 0.0, 1.2]])
    box = (np.array([-0.9, -1.0, -0.7]), np.array([0.8, 0.95, 0.9]))
    return V, TerminalSet.polynomial(V, LEVEL, frame=frame, box=box)


def _numba_all(term, Y):
    c, (Mi, E, A, B, g, D) = term.center, term.poly
    d, pw = np.empty(len(c)), np.empty((len(c), D + 1))
    return np.array([member_numba(y, c, Mi, E, A, B, term.threshold, g, d, pw) for y in Y])


def _points(V, rng):
    Y = CENTER + rng.uniform(-1.0, 1.0, (3000, 3))
    # onto the level set along rays (float bisection): the hard cases
    U = rng.standard_normal((1000, 3))
    lo, hi = np.zeros(1000), np.full(1000, 4.0)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        ok = V.value(CENTER + mid[:, None] * U) <= LEVEL * (1 - 1e-9)
        lo, hi = np.where(ok, mid, lo), np.where(ok, hi, mid)
    edge = CENTER + lo[:, None] * U
    special = np.array([[np.nan, 0, 0], [np.inf, 0, 0], [0, -np.inf, 0], CENTER])
    return np.concatenate([Y, edge, np.nextafter(edge, np.inf), special])


def _exact_inside(term, y):
    c = [Fraction(float(v)) for v in term.center]
    d = [Fraction(float(v)) - ci for v, ci in zip(y, c, strict=True)]
    Mi, E, A, B, _, _ = term.poly
    for i in range(len(d)):
        z = sum(Fraction(float(Mi[i, j])) * d[j] for j in range(len(d)))
        if not Fraction(float(B[0, i])) <= z <= Fraction(float(B[1, i])):
            return False
    v = Fraction(0)
    for e, a in zip(E, A, strict=True):
        m = Fraction(float(a))
        for di, k in zip(d, e, strict=True):
            m *= di ** int(k)
        v += m
    return v <= Fraction(LEVEL) * (1 - Fraction(1, 10**9))


def test_numpy_and_numba_agree_point_for_point():
    V, term = _term()
    Y = _points(V, np.random.default_rng(3))
    a, b = member_numpy(Y, term.center, term.poly, term.threshold), _numba_all(term, Y)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(term.contains(Y), a)
    assert 500 < a.sum() < len(Y) - 500  # both sides well represented
    assert not a[-4:-1].any() and a[-1]  # NaN and inf outside, the centre inside


def test_float_membership_is_sound_in_exact_arithmetic():
    V, term = _term()
    rng = np.random.default_rng(4)
    Y = _points(V, rng)
    inside = term.contains(Y)
    idx = np.flatnonzero(inside)
    sample = np.concatenate([idx[-600:], rng.choice(idx, 200, replace=False)])
    assert all(_exact_inside(term, Y[i]) for i in sample)
    # the box matters: points with V well below the level but outside the box are out
    with np.errstate(invalid="ignore"):
        z = (Y - term.center) @ term.poly.Mi.T
        low = V.value(Y) < 0.9 * LEVEL
    out_box = ~((z >= term.box[0]) & (z <= term.box[1])).all(axis=1)
    assert (out_box & low).sum() > 20 and not inside[out_box].any()


def test_rounding_allowance_refuses_cancelling_terms():
    """V = x^2 + y^2 written as (1e8 + 1) x^2 - 1e8 x^2 + y^2: float V can be off by ~1e-8 at
    x = 0.9, so a point with exact V = threshold - 1e-8 is refused (the allowance g S, S ~ 1.6e8,
    is ~3e-7), while the same point with V written plainly (S ~ 1) counts."""
    V = PolynomialLyapunov([[2, 0], [0, 2]], [1.0, 1.0], [0.0, 0.0])
    box = (np.array([-10.0, -10.0]), np.array([10.0, 10.0]))
    term = TerminalSet.polynomial(V, 1.0, frame=np.eye(2), box=box)
    assert term.poly.g == 2 * (2 + 2 + 2 + 1) * 2.0**-53  # K + degree + n + 1, doubled
    t = np.sqrt(term.threshold - 1e-8 - 0.81)
    y = np.array([[0.9, t]])
    exact = Fraction(0.9) ** 2 + Fraction(float(t)) ** 2
    assert exact < Fraction(term.threshold)
    assert member_numpy(y, term.center, term.poly, term.threshold)[0]
    cancel = term.poly._replace(E=np.array([[2, 0], [2, 0], [0, 2]]),
                                A=np.array([1e8 + 1.0, -1e8, 1.0]))  # fmt: skip
    assert not member_numpy(y, term.center, cancel, term.threshold)[0]
    d, pw = np.empty(2), np.empty((2, 3))
    Mi, E, A, B, g, _ = cancel
    assert not member_numba(y[0], term.center, Mi, E, A, B, term.threshold, g, d, pw)
