"""Containment of sublevel sets for any V (roa.proof._sublevel_containment) against the exact rational
ellipsoid test (roa.proof.ellipsoid_contains): {x'Qx <= a} lies in {x'Px <= b} iff
a lambda_max(Q^-1 P) <= b, here decided 1 % either side of the threshold."""

from __future__ import annotations

import numpy as np
import pytest

import roa
from roa.lyapunov import PolynomialLyapunov
from roa.proof._containment import ellipsoid_contains
from roa.proof._sublevel_containment import sublevel_contains
from roa.search._rays import ray_box


def _as_poly(P: np.ndarray) -> PolynomialLyapunov:
    n = len(P)
    mons, coefs = [], []
    for i in range(n):
        for j in range(i, n):
            e = [0] * n
            e[i] += 1
            e[j] += 1
            mons.append(e)
            coefs.append(P[i, j] * (1 if i == j else 2))
    return PolynomialLyapunov(mons, coefs, np.zeros(n))


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("side", [0.99, 1.01])
def test_matches_exact_ellipsoid_test(seed, side):
    rng = np.random.default_rng(seed)
    n = 2 + seed % 2
    A = rng.standard_normal((n, n))
    P = A @ A.T + 0.5 * np.eye(n)
    B = rng.standard_normal((n, n))
    Q = B @ B.T + 0.5 * np.eye(n)
    a = 1.3
    thr = a * max(np.linalg.eigvals(np.linalg.solve(Q, P)).real)
    b = side * thr
    exact = ellipsoid_contains(P, b, Q, a)["status"] == "proved"
    res = sublevel_contains(
        roa.QuadraticLyapunov(Q, np.zeros(n)), a, _as_poly(P), b, cover_estimate=ray_box
    )
    assert exact == (side > 1)
    assert res["status"] == ("proved" if side > 1 else "refuted")
    if res["status"] == "refuted":  # the witness is in the inner set and outside the outer one
        w = np.asarray(res["witness"])
        assert w @ Q @ w <= a * (1 + 1e-9) and w @ P @ w > b


def test_quartic_inside_ball():
    """{x^4 + y^4 <= 1} lies in {x^2 + y^2 <= r} iff r >= sqrt(2) (max of x^2+y^2 on the curve)."""
    V = PolynomialLyapunov([[4, 0], [0, 4]], [1.0, 1.0], np.zeros(2))
    ball = roa.QuadraticLyapunov(np.eye(2), np.zeros(2))
    # V has no positive-definite Hessian: x-coordinates boxes; its cover comes from rays
    assert (
        sublevel_contains(V, 1.0, ball, 1.01 * np.sqrt(2), cover_estimate=ray_box)["status"]
        == "proved"
    )
    assert (
        sublevel_contains(V, 1.0, ball, 0.99 * np.sqrt(2), cover_estimate=ray_box)["status"]
        == "refuted"
    )
