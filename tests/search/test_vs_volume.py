"""The V-s iteration's volume objective (roa.search._vs_iteration, ``objective="volume"``): a
degree-4 V certified by the exact SOS route on a set larger than the best quadratic's.

poly3d (``examples/systems/poly3d.py``): with ``V = |x|^2`` the largest level is 3 exactly (AM-GM:
``V' = -2|x|^2 + 6 x1 x2 x3`` vanishes at the equilibria ``(1, 1, 1)`` and its sign flips), and no
ellipsoid avoiding those four equilibria is larger (``det S <= (trace S / 3)^3``): the quadratic's
set is the ball ``|x|^2 <= 3``. The region of attraction reaches further along the axes (``x' =
-x`` on each axis), where a quartic V may extend. Every number compared here is computed in this
file: the field written again, V evaluated from its monomials, the volumes by uniform sampling,
and the first point with ``V' >= 0`` along random rays (a point the level must stay below).
"""

from __future__ import annotations

import numpy as np
import pytest

import roa
from roa.errors import RoaInputError
from roa.options import VsOptions
from roa.proof._cover import gram_cover
from roa.search._vs_iteration import vs_search
from roa.status import SosStatus

ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]


def field(X: np.ndarray) -> np.ndarray:
    x1, x2, x3 = X.T
    return np.stack([-x1 + x2 * x3, -x2 + x1 * x3, -x3 + x1 * x2], axis=1)


def value_and_derivative(V: roa.PolynomialLyapunov, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """V and V' = grad V . f at the rows of X, from V's monomials and coefficients alone."""
    terms = V.polynomial_view()
    assert terms is not None and np.allclose(V.center, 0.0)
    F = field(X)
    powers = [[np.ones(len(X))] for _ in range(3)]
    for i in range(3):
        for _ in range(max(m[i] for m in terms)):
            powers[i].append(powers[i][-1] * X[:, i])
    val, der = np.zeros(len(X)), np.zeros(len(X))
    for m, c in terms.items():
        val += float(c) * powers[0][m[0]] * powers[1][m[1]] * powers[2][m[2]]
        for i, a in enumerate(m):
            if a:
                e = list(m)
                e[i] -= 1
                der += float(c) * a * powers[0][e[0]] * powers[1][e[1]] * powers[2][e[2]] * F[:, i]
    return val, der


def first_crossing(V: roa.PolynomialLyapunov, rays: int = 1000) -> float:
    """The least V at the first point with V' >= 0 along random rays (beyond |x| = 0.05, located
    by bisection): a point no certified level may reach (V' < 0 must hold on all of {V <= level}
    but the equilibrium)."""
    U = np.random.default_rng(3).standard_normal((rays, 3))
    U /= np.linalg.norm(U, axis=1)[:, None]
    t = np.linspace(0.05, 4.0, 200)
    der = value_and_derivative(V, (t[None, :, None] * U[:, None, :]).reshape(-1, 3))[1]
    hit = der.reshape(rays, len(t)) >= 0
    rows = np.nonzero(hit.any(axis=1) & ~hit[:, 0])[0]
    k = np.argmax(hit[rows], axis=1)
    lo, hi, U = t[k - 1], t[k], U[rows]
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        up = value_and_derivative(V, mid[:, None] * U)[1] >= 0
        lo, hi = np.where(up, lo, mid), np.where(up, mid, hi)
    return float(np.min(value_and_derivative(V, hi[:, None] * U)[0]))


def check_larger_than_the_quadratic(V: roa.PolynomialLyapunov, level: float) -> None:
    """V is a quartic, positive definite (proved exactly), its level below the first crossing
    and close to it, and {V <= level} more than twice the volume of the ball |x|^2 <= 3."""
    assert max(map(sum, V.polynomial_view() or {})) == 4
    # positive definite, proved exactly: V - lambda |x|^2 = m' Q m with Q positive definite in
    # rationals (exact LDL'); V itself is positive on sampled directions
    proved = gram_cover(V, 1.0)
    assert proved is not None and proved[1]["lambda"] > 0
    S = np.random.default_rng(5).standard_normal((2000, 3))
    assert np.all(value_and_derivative(V, S)[0] > 0)
    # the level is below every point with V' >= 0 found along rays, and close to the least
    crossing = first_crossing(V)
    assert 0.99 * crossing < level < crossing, (level, crossing)
    # volumes: uniform samples of the cube [-2 sqrt 3, 2 sqrt 3]^3, the quadratic's ball
    # |x|^2 <= 3 against {V <= level}
    n = 200_000
    X = np.random.default_rng(11).uniform(-2 * np.sqrt(3), 2 * np.sqrt(3), (n, 3))
    ball = np.einsum("ij,ij->i", X, X) <= 3.0
    quartic = value_and_derivative(V, X)[0] <= level
    ratio = quartic.mean() / ball.mean()
    err = ratio * np.sqrt((1 - ball.mean()) / ball.sum() + (1 - quartic.mean()) / quartic.sum())
    assert ratio - 3 * err > 2.0, (ratio, err)
    # the samples of {V <= level} have V' < 0 (soundness, sampled): none with V' >= 0
    inside = X[quartic & (np.einsum("ij,ij->i", X, X) > 1e-4)]
    assert np.all(value_and_derivative(V, inside)[1] < 0)


def test_one_volume_step_gives_a_quartic_the_exact_route_certifies_on_a_larger_set():
    system = roa.load_system(f"{ROOT / 'examples/systems/poly3d.py'}:SYSTEM")
    res = vs_search(system, roa.default_lyapunov(system), degree=4, objective="volume",
                    reach=1.5, rounds=1)  # fmt: skip
    assert res.status is SosStatus.SOLVED and len(res.means) == 2 and res.means[1] < res.means[0]
    V = res.best
    assert V is res.candidates[1]  # the lower mean of V ranks first
    # the V-s normalises V's SOS level to 1: 0.999 is proved by the exact route
    cert = roa.certify(system, V, level=0.999, validator=roa.SosValidator())
    assert cert.status.value == "certified" and cert.method == "sos-exact"
    check_larger_than_the_quadratic(V, 0.999)


@pytest.mark.slow
def test_certify_degree_4_volume_objective_through_the_pipeline():
    system = roa.load_system(f"{ROOT / 'examples/systems/poly3d.py'}:SYSTEM")
    vs = VsOptions(objective="volume", reach=1.5, rounds=3, budget=120.0)
    cert = roa.certify(system, degree=4, vs=vs, validator=roa.SosValidator())
    assert cert.status.value == "certified" and cert.method == "sos-exact"
    assert isinstance(cert.V, roa.PolynomialLyapunov)
    check_larger_than_the_quadratic(cert.V, float(cert.level))


def test_volume_objective_options_are_checked():
    system = roa.load_system(f"{ROOT / 'examples/systems/poly3d.py'}:SYSTEM")
    V0 = roa.default_lyapunov(system)
    with pytest.raises(RoaInputError, match="objective must be one of"):
        vs_search(system, V0, objective="area")
    with pytest.raises(RoaInputError, match="reach must be a finite number > 0"):
        vs_search(system, V0, objective="volume", reach=0.0)
