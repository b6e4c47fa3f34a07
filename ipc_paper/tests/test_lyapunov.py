"""The Lyapunov setting of Section 3.3: (3.9)-(3.12) against the closed loop (3.8), and the regions."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from ipc_paper import estimates as est
from ipc_paper.system import lyapunov as ly


@pytest.fixture(scope="module")
def points() -> np.ndarray:
    rng = np.random.default_rng(3)
    return rng.standard_normal((2000, 4)) * rng.uniform(0.1, 3.0, (2000, 1))


def test_310_is_the_closed_loop_38_in_q(points):
    system = ly.flat_system()
    lhs = ly.q_dot(ly.to_q(points))
    rhs = system.f(points) @ ly.T.T  # q' = T xi'
    assert np.max(np.abs(lhs - rhs) / (1 + np.abs(rhs))) < 1e-12


def test_312_is_vdot_of_311(points):
    system, V = ly.flat_system(), ly.paper_lyapunov()
    q = ly.to_q(points)
    # V of (3.11) written out, against x'Px with P = T' P_q T
    v311 = 0.5 * np.sum(q * q, axis=1) + 0.5 * (q[:, 2] - q[:, 3]) ** 2
    assert np.allclose(V.value(points), v311, rtol=1e-12, atol=0)
    vd = V.derivative(system, points)
    assert np.max(np.abs(ly.Phi(q) - vd) / (1 + np.abs(vd))) < 1e-12


def test_M_and_its_smallest_eigenvalue():
    # M = (I + 11')/2 has eigenvalues 1/2 (x3, on 1-perp) and 5/2 (on 1)
    lam = np.linalg.eigvalsh(ly.M)
    assert np.allclose(lam, [0.5, 0.5, 0.5, 2.5], atol=1e-14)
    assert ly.lambda_min_M() == pytest.approx(0.5, abs=1e-14)


def test_sector_of_paper_ball_in_closed_form():
    # q = q' = theta' = 0: ||q||^2 = (arsinh(tan th) + 3 tan th)^2 + 5 tan^2 th
    def g(th):
        w = np.tan(th)
        return (np.arcsinh(w) + 3 * w) ** 2 + 5 * w * w - 4.89

    expected = brentq(g, 1e-6, 1.5, xtol=1e-14)
    region = next(r for r in est.ipc_regions() if r.name.startswith("paper (3.15)"))
    assert est.sector_theta(region) == pytest.approx(expected, abs=1e-9)
    assert np.degrees(expected) < 30  # far from the paper's 60 deg


def test_regions_are_consistent():
    regions = {r.name: r for r in est.ipc_regions()}
    assert len(regions) == 8
    sound = next(r for n, r in regions.items() if n.startswith("ours: V <="))
    proved = next(r for n, r in regions.items() if n.startswith("corrected bound: V"))
    # certified by the independent interval validation, not by the hand proof alone
    assert proved.status == "certified" and sound.status == "sampled"
    assert "interval" in proved.meta["source"]
    # the hand proof (V < 27/32) must lie inside the numerically largest level set
    assert proved.level == pytest.approx(27 / 32, rel=1e-14)
    assert proved.level < sound.level
    # physical states map through (2.2): the origin is inside every set, |theta| >= pi/2 in none
    x = np.array([[0.0, 0, 0, 0], [0.0, 0, np.pi / 2, 0]])
    for r in regions.values():
        assert r.contains(x).tolist() == [True, False]
