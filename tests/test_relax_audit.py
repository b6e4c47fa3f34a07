"""Adversarial soundness audit of the linear relaxations (roa.proof.relax) and CROWN.

Each case is one an audit found or probed: a bound of :mod:`roa.proof.relax` checked against
the exact value at the box's points, computed independently of the code under test (Python
Fractions for piecewise-linear networks and affine expressions: exact; mpmath at 60 digits for
the smooth functions). The affine bounds themselves are evaluated exactly (Fractions), so a
violation cannot hide in the checker's rounding."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from roa.nn import MLP
from roa.nn.mlp import Affine
from roa.proof.relax import LINEAR, Lin, variables


def _exact_affine(A: np.ndarray, c: float, d: list[Fraction]) -> Fraction:
    return Fraction(float(c)) + sum(
        (Fraction(float(a)) * di for a, di in zip(A, d, strict=True)), Fraction(0)
    )


def _assert_encloses(q: Lin, k: int, x: list[float], mid: np.ndarray, exact: Fraction) -> None:
    """Box ``k`` of ``q``: lower affine <= exact <= upper affine at ``x``, and inside bounds()."""
    d = [Fraction(float(p)) - Fraction(float(m)) for p, m in zip(x, mid[k], strict=True)]
    lo = _exact_affine(q.lA[k], q.lc[k], d)
    hi = _exact_affine(q.uA[k], q.uc[k], d)
    assert lo <= exact, f"lower bound {float(lo)!r} above the exact value {float(exact)!r} at {x}"
    assert exact <= hi, f"upper bound {float(hi)!r} below the exact value {float(exact)!r} at {x}"
    b_lo, b_hi = q.bounds()
    assert Fraction(float(b_lo[k])) <= exact <= Fraction(float(b_hi[k])), (b_lo[k], b_hi[k])


def _exact_pwl_net(net: MLP, x: list[float]) -> list[Fraction]:
    """A network of affine maps, ReLU, leaky ReLU and clip in exact rational arithmetic."""
    h = [Fraction(float(v)) for v in x]
    for op in net.ops:
        if isinstance(op, Affine):
            h = [
                sum((Fraction(float(w)) * v for w, v in zip(row, h, strict=True)), Fraction(0))
                + Fraction(float(b))
                for row, b in zip(op.W, op.b, strict=True)
            ]
        elif op.name == "relu":
            h = [max(v, Fraction(0)) for v in h]
        elif op.name == "leaky_relu":
            a = Fraction(float(op.args[0]))
            h = [max(v, Fraction(0)) + a * min(v, Fraction(0)) for v in h]
        elif op.name == "clip":
            lo, hi = (Fraction(float(v)) for v in op.args)
            h = [min(max(v, lo), hi) for v in h]
        else:
            raise AssertionError(op.name)
    return h


# -- underflow of coefficients over wide boxes ------------------------------------------------------
# A coefficient that underflows (1e-200 * 1e-200 -> 0) loses its whole term, and over a box of
# radius 1e300 that term is 1e-100, far beyond the old absolute allowance (k 2^-1022). The
# underflow error is now scaled by 1 + sum of the magnitudes it multiplies.
def test_a_product_whose_coefficient_underflows_is_still_enclosed_on_a_wide_box():
    lo, hi = np.array([[-1e300]]), np.array([[1e300]])
    X, mid = variables(lo, hi)
    q = (X[0] * 1e-200) * 1e-200  # exactly x 1e-200 1e-200 (each float product rounded)
    for x in (-1e300, -1.0, 0.0, 3e299, 1e300):
        exact = Fraction(x) * Fraction(1e-200) * Fraction(1e-200)
        _assert_encloses(q, 0, [x], mid, exact)


@pytest.mark.parametrize("act", ["relu", ("leaky_relu", 0.5), None])
def test_crown_back_substitution_whose_coefficient_underflows_is_still_enclosed(act):
    W = np.array([[1e-200]])
    net = MLP([(W, np.zeros(1)), (W, np.zeros(1))], [act, None])
    lo, hi = np.array([[-1e300]]), np.array([[1e300]])
    X, mid = variables(lo, hi)
    q = net(X, LINEAR)[0]
    for x in (-1e300, -2.5e299, 0.0, 1e299, 1e300):
        _assert_encloses(q, 0, [x], mid, _exact_pwl_net(net, [x])[0])
