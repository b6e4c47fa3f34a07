"""The V-s iteration over a parameter box (issue 37, item 2): V's decrease is imposed at the box's
vertices (a field affine in the parameters) with one multiplier per vertex and one common V.

Checked independently of roa's SOS code: V and V' are evaluated from the candidate's monomials and
coefficients with numpy on the hand-written Van der Pol field, at 11 values of mu across the box,
on 20000 points of {V <= 1}; the largest level of the certified V at each mu is bounded by scipy's
SLSQP minimum of V on {V' >= 0}, and 1.01 x its lowest is refuted.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

import roa
from roa.cli import main
from roa.search._candidate import as_lyapunov
from roa.search._vs_iteration import parameter_points, vs_search
from roa.status import SosStatus, Verdict

P_BENCH = np.array([[1.5, -0.5], [-0.5, 1.0]])  # designed at mu = 1; not a Lyapunov P at mu = 0.5


def vdp(lo: float, hi: float) -> roa.System:
    return roa.load_system("vanderpol").with_ranges(mu=(lo, hi))


def field(X: np.ndarray, mu: float) -> np.ndarray:
    return np.stack([-X[:, 1], X[:, 0] + mu * (X[:, 0] ** 2 - 1) * X[:, 1]], axis=1)


def value_and_vdot(V, X: np.ndarray, mu: float) -> tuple[np.ndarray, np.ndarray]:
    """V(x) and V'(x) = grad V . f from the monomials and coefficients (centre 0), numpy only."""
    val = np.zeros(len(X))
    grad = np.zeros_like(X)
    for m, c in zip(V.monomials, V.coefficients, strict=True):
        val += c * X[:, 0] ** m[0] * X[:, 1] ** m[1]
        if m[0]:
            grad[:, 0] += c * m[0] * X[:, 0] ** (m[0] - 1) * X[:, 1] ** m[1]
        if m[1]:
            grad[:, 1] += c * m[1] * X[:, 0] ** m[0] * X[:, 1] ** (m[1] - 1)
    return val, np.einsum("ij,ij->i", grad, field(X, mu))


def sublevel_points(V, level: float, n: int = 20000) -> np.ndarray:
    """Points of {V <= level} \\ {0}: random directions scaled inside (V is a positive definite
    quadratic here, V(s d) = s^2 V(d))."""
    rng = np.random.default_rng(1)
    D = rng.standard_normal((n, 2))
    vd, _ = value_and_vdot(V, D, 1.0)
    return D * np.sqrt(level * rng.uniform(1e-6, 1.0, (n, 1)) / vd[:, None])


def test_parameter_points_are_the_vertices_of_an_affine_field():
    pts, how = parameter_points(vdp(0.5, 1.5))
    assert pts == [{"mu": 0.5}, {"mu": 1.5}] and "affine" in how
    quad = roa.System("q", lambda t, x, xp, p: (-x[1], x[0] - p.mu**2 * x[1]), (0.0, 0.0),
                      ("x1", "x2"), parameters={"mu": (0.5, 1.0, 1.5)})  # fmt: skip
    pts, how = parameter_points(quad)
    assert {p["mu"] for p in pts} == {0.5, 1.0, 1.5} and "not affine" in how
    assert parameter_points(roa.load_system("vanderpol")) == ([], "none")


def test_vs_over_the_box_gives_a_v_that_decreases_for_every_mu():
    s = vdp(0.5, 1.5)
    res = vs_search(s, as_lyapunov(s, P_BENCH), degree=2, rounds=3)
    assert res.status is SosStatus.SOLVED and res.candidates
    # P_BENCH fails at mu = 0.5, so the iteration started from the box's LMI solution
    assert "LMI" in res.sizes["seed"]
    assert res.sizes["parameter_points"] == [{"mu": 0.5}, {"mu": 1.5}]
    assert "V' < 0 imposed at 2 parameter points (mu = 0.5; mu = 1.5)" in res.message
    V = res.best
    X = sublevel_points(V, 1.0)
    for mu in np.linspace(0.5, 1.5, 11):
        val, vd = value_and_vdot(V, X, mu)
        assert np.all(val <= 1.0 + 1e-9) and np.all(vd < 0), mu
    # the same iteration at the nominal value only: its V is not a Lyapunov function at mu = 0.5
    nominal = vs_search(s.nominal(), as_lyapunov(s, P_BENCH), degree=2, rounds=3).best
    _, vd = value_and_vdot(nominal, sublevel_points(nominal, 1.0), 0.5)
    assert np.any(vd > 0)


def _c_star(V, mu: float) -> float:
    """min V on {V' >= 0, |x| >= 0.01} at mu by SLSQP from 40 starts (scipy and numpy only)."""

    def vv(x):
        return value_and_vdot(V, x[None, :], mu)

    cons = [{"type": "ineq", "fun": lambda x: vv(x)[1][0]},
            {"type": "ineq", "fun": lambda x: x @ x - 1e-4}]  # fmt: skip
    best = np.inf
    rng = np.random.default_rng(0)
    for _ in range(40):
        r = minimize(lambda x: vv(x)[0][0], 2 * rng.standard_normal(2), constraints=cons,
                     method="SLSQP", options={"maxiter": 500, "ftol": 1e-12})  # fmt: skip
        if r.success and vv(r.x)[1][0] >= -1e-9 and r.x @ r.x > 1e-5:
            best = min(best, float(vv(r.x)[0][0]))
    return best


@pytest.mark.slow
def test_certify_degree_2_over_the_box_and_refute_above(capsys):
    s = vdp(0.5, 1.5)
    cert = roa.certify(s, P_BENCH, degree=2)
    assert cert.status is Verdict.CERTIFIED and cert.method == "interval"
    V, c = cert.V, cert.level
    X = sublevel_points(V, c)
    for mu in np.linspace(0.5, 1.5, 11):
        assert np.all(value_and_vdot(V, X, mu)[1] < 0), mu
    c_star = min(_c_star(V, mu) for mu in np.linspace(0.5, 1.5, 5))
    assert c <= c_star
    above = roa.certify(s, V, level=1.01 * c_star)
    assert above.status is Verdict.REFUTED
    assert (
        main(["certify", "--system", "vanderpol", "--param", "mu=0.5..1.5", "--degree", "2"]) == 0
    )
    assert "certified: level" in capsys.readouterr().out
