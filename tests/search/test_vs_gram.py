"""A positive definite Gram matrix for a searched polynomial V (roa.search._vs_iteration.attach_gram), read by the
exact cover (roa.proof.gram_cover) that the exact SOS route needs."""

from __future__ import annotations

import numpy as np
import pytest

from roa.lyapunov import PolynomialLyapunov
from roa.proof._cover import gram_cover
from roa.search._vs_iteration import attach_gram


def _V(terms: dict[tuple[int, int], float]) -> PolynomialLyapunov:
    return PolynomialLyapunov(list(terms), list(terms.values()), (0.0, 0.0), "V")


def test_a_strictly_sos_quartic_gets_a_gram_matrix_the_exact_cover_proves():
    # V = x^2 + y^2 + x^4 + x^2 y^2 + y^4 = m' Q m with Q = I over (x, y, x^2, xy, y^2)
    V = _V({(2, 0): 1.0, (0, 2): 1.0, (4, 0): 1.0, (2, 2): 1.0, (0, 4): 1.0})
    assert gram_cover(V, 1.0) is None  # no Gram matrix yet: the exact route would refuse V
    assert attach_gram(V)
    basis, Q = V.gram
    assert np.linalg.eigvalsh(Q)[0] > 0
    half, _ = gram_cover(V, 1.0)
    # {V <= 1} lies in |x|, |y| <= 1 (V >= x^2 and >= y^2): the proved cube holds it
    assert np.all(half >= 1.0 - 1e-9)


@pytest.mark.parametrize("terms", [
    {(2, 0): 1.0, (0, 2): 1.0, (4, 0): -1.0},  # negative for large x: no Gram matrix at all
    {(2, 0): 1.0, (0, 2): 1.0, (2, 2): 1.0},  # x^4, y^4 absent: only singular Gram matrices
])  # fmt: skip
def test_no_positive_definite_gram_matrix_none_attached(terms):
    V = _V(terms)
    assert not attach_gram(V)
    assert V.gram is None and gram_cover(V, 1.0) is None
