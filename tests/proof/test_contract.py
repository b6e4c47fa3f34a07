"""Boxes shrunk to the part that can meet {V <= level} (roa.proof._contract): every point of the
box with V <= level (exact rational V at dense samples) stays in the shrunk box, an emptied box
has no such point, and a box across the level surface of |x|^2 shrinks to the closed form."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import roa
from roa.proof._contract import contract
from roa.proof._validate import QuadraticForm


def _exact_v(P: np.ndarray, x: np.ndarray) -> Fraction:
    xs = [Fraction(float(v)) for v in x]
    n = len(xs)
    return sum((Fraction(float(P[i, j])) * xs[i] * xs[j] for i in range(n) for j in range(n)),
               Fraction(0))  # fmt: skip


@pytest.mark.parametrize("seed", range(4))
def test_contracted_boxes_keep_every_point_of_the_sublevel_set(seed):
    rng = np.random.default_rng(seed)
    n = 3
    # near-diagonal forms (as in the branch and bound's whitened coordinates) make the bounds
    # tight, so a contraction cutting into the set shows; a general form for the odd seeds
    A = rng.standard_normal((n, n))
    P = (
        A @ A.T + 0.3 * np.eye(n)
        if seed % 2
        else np.diag(rng.uniform(0.5, 2, n)) + 0.01 * (A + A.T)
    )
    V = roa.QuadraticLyapunov(P, np.zeros(n))
    quad = QuadraticForm.of(V)
    assert quad is not None
    level = 1.0
    mid = rng.uniform(-1.5, 1.5, (60, n))
    rad = rng.uniform(0.05, 0.8, (60, n))
    lo, hi = mid - rad, mid + rad
    lo2, hi2, empty = contract(quad, lo, hi, level)
    assert np.all(lo2 >= lo) and np.all(hi2 <= hi)
    shrunk = np.any((lo2 > lo) | (hi2 < hi), axis=1) | empty
    assert shrunk.sum() >= 10  # the test exercises the contraction
    # points on the level surface (just inside): where a too-tight contraction shows first
    U = rng.standard_normal((200000, n))
    surf = U * (np.sqrt(level / np.einsum("ki,ij,kj->k", U, P, U)) * (1 - 1e-9))[:, None]
    inside = 0
    for b in range(60):
        near = surf[np.all((surf >= lo[b]) & (surf <= hi[b]), axis=1)][:200]
        pts = np.concatenate([rng.uniform(lo[b], hi[b], (200, n)), near])
        for x in pts:
            if _exact_v(P, x) <= level:
                inside += 1
                assert not empty[b]
                assert np.all(lo2[b] <= x) and np.all(x <= hi2[b])
    assert inside > 500


def test_a_box_across_the_unit_sphere_shrinks_to_the_closed_form():
    V = roa.QuadraticLyapunov(np.eye(2), np.zeros(2))
    quad = QuadraticForm.of(V)
    lo, hi = np.array([[0.6, -0.5], [2.0, 2.0]]), np.array([[1.4, 0.5], [3.0, 3.0]])
    lo2, hi2, empty = contract(quad, lo, hi, 1.0)
    assert list(empty) == [False, True]  # the second box lies outside the disc
    # first box: x0 <= sqrt(1 - 0) = 1, then |x1| <= sqrt(1 - 0.36) = 0.8 (not binding: 0.5)
    assert hi2[0, 0] == pytest.approx(1.0, abs=1e-12) and hi2[0, 0] >= 1.0
    assert lo2[0, 0] == 0.6 and lo2[0, 1] == -0.5 and hi2[0, 1] == 0.5
