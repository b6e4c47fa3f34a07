"""Reductions of the exact SOS problem (:mod:`roa.proof._reductions`): accepts / apply / invert."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from sos_systems import poly3d_block as _poly3d

import roa
from roa.proof._reductions import IndependentBlocks, Rescale
from roa.proof._sos_check import exact_data


def _data(field, n):
    system = roa.System("s", field, (0.0,) * n, tuple(f"x{i}" for i in range(n)))
    return exact_data(system, roa.QuadraticLyapunov(np.eye(n), np.zeros(n)))


def test_independent_blocks_split_and_invert_to_named_parts():
    data = _data(lambda t, x, xp: _poly3d(x, 0) + _poly3d(x, 3), 6)
    split = IndependentBlocks()
    assert split.accepts(data)
    subs, parts = split.apply(data)
    assert parts == [(0, 1, 2), (3, 4, 5)] and [s.n for s in subs] == [3, 3]
    # each block's V' is poly3d's own: -2 |x|^2 + 6 x1 x2 x3 (derived by hand)
    want = {(2, 0, 0): -2, (0, 2, 0): -2, (0, 0, 2): -2, (1, 1, 1): 6}
    assert all(s.Vdot == {m: Fraction(c) for m, c in want.items()} for s in subs)
    out = split.invert([{"grams": []}, {"grams": []}], parts)
    assert [p["variables"] for p in out["parts"]] == [[0, 1, 2], [3, 4, 5]]
    coupled = _data(lambda t, x, xp: _poly3d(x, 0), 3)
    assert not split.accepts(coupled)
    with pytest.raises(ValueError, match="couples"):  # a stored partition that a monomial couples
        IndependentBlocks(((0,), (1, 2))).apply(coupled)


def test_rescale_substitutes_exactly_and_is_stored():
    data = _data(lambda t, x, xp: (-x[0] + x[0] ** 3, -x[1]), 2)
    assert not Rescale((Fraction(1), Fraction(1))).accepts(data)
    scale = (Fraction(2), Fraction(1, 4))
    r = Rescale(scale)
    assert r.accepts(data)
    (scaled,), inverse = r.apply(data)
    # V = d1^2 + d2^2 with d = diag(2, 1/4) y: 4 y1^2 + y2^2 / 16; V' = -2 d1^2 + 2 d1^4 - 2 d2^2
    assert scaled.V == {(2, 0): Fraction(4), (0, 2): Fraction(1, 16)}
    assert scaled.Vdot == {(2, 0): Fraction(-8), (4, 0): Fraction(32), (0, 2): Fraction(-1, 8)}
    assert r.invert([{"grams": []}], inverse) == {"parts": [{"grams": []}], "scale": ["2", "1/4"]}
