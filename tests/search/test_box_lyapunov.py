"""A quadratic V designed for a whole parameter box (issue 37, item 2): common Lyapunov LMIs at
the box's points propose V (roa.search._box_lyapunov), the robust branch and bound decides."""

from __future__ import annotations

import numpy as np
import pytest

import roa
from roa.cli import main
from roa.search._box_lyapunov import box_lyapunov, is_affine
from roa.search._candidate import as_lyapunov, worst_linearisation
from roa.status import Verdict

P_BENCH = np.array([[1.5, -0.5], [-0.5, 1.0]])  # vanderpol's own V (designed at mu = 1)


def vdp(lo: float, hi: float) -> roa.System:
    return roa.load_system("vanderpol").with_ranges(mu=(lo, hi))


def A_vdp(mu: float) -> np.ndarray:
    """d/dx of (-x2, x1 + mu (x1^2 - 1) x2) at 0, by hand."""
    return np.array([[0.0, -1.0], [1.0, -mu]])


def vdot(P: np.ndarray, X: np.ndarray, mu: float) -> np.ndarray:
    """V'(x) = 2 x' P f(x) of V = x' P x, written out independently of roa."""
    f = np.stack([-X[:, 1], X[:, 0] + mu * (X[:, 0] ** 2 - 1) * X[:, 1]], axis=1)
    return 2 * np.einsum("ij,jk,ik->i", X, P, f)


def test_nominal_v_fails_at_mu_05_by_hand():
    """The premise: the benchmark's P is not a Lyapunov matrix at mu = 0.5 (eigenvalue > 0)."""
    lam = np.linalg.eigvalsh(A_vdp(0.5).T @ P_BENCH + P_BENCH @ A_vdp(0.5)).max()
    assert lam == pytest.approx(0.05902, abs=1e-5)
    s = vdp(0.5, 1.5)
    p, lam_roa = worst_linearisation(s, as_lyapunov(s, P_BENCH))
    assert p == {"mu": 0.5} and lam_roa == pytest.approx(lam, rel=1e-9)
    assert worst_linearisation(vdp(0.8, 1.2), as_lyapunov(vdp(0.8, 1.2), P_BENCH)) is None


def test_lmi_solution_is_a_common_lyapunov_matrix_at_vertices_and_between():
    s = vdp(0.5, 1.5)
    res = box_lyapunov(s)
    assert res.feasible and res.affine and res.margin > 0
    P = res.P
    assert np.allclose(P, P.T) and np.linalg.eigvalsh(P)[0] > 0
    assert np.trace(P) == pytest.approx(2.0)
    # every vertex, and 201 interior points (the LMIs were solved at 5 points only)
    for mu in [0.5, 1.5, *np.linspace(0.5, 1.5, 201)]:
        assert np.linalg.eigvalsh(A_vdp(mu).T @ P + P @ A_vdp(mu)).max() < 0, mu
    # the reported eigenvalues are those of the hand-written A at the solved points
    for p, lam in zip(res.points, res.max_eig, strict=True):
        M = A_vdp(p["mu"]).T @ P + P @ A_vdp(p["mu"])
        assert lam == pytest.approx(np.linalg.eigvalsh(M).max(), rel=1e-9, abs=1e-12)
    # the margin is the common decay: A'P + PA <= -t I at the points, to solver accuracy
    assert max(res.max_eig) == pytest.approx(-res.margin, rel=1e-4)


def test_lmi_infeasible_where_the_box_holds_an_unstable_linearisation():
    """At mu = -0.5 A has eigenvalues with real part 0.25 > 0: no P > 0 with A'P + PA < 0."""
    assert np.linalg.eigvals(A_vdp(-0.5)).real.max() == pytest.approx(0.25)
    res = box_lyapunov(vdp(-0.5, 1.5))
    assert not res.feasible
    assert "mu = -0.5" in res.message


def test_affinity_check():
    assert is_affine(vdp(0.5, 1.5))
    quad = roa.System("q", lambda t, x, xp, p: (-x[1], x[0] - p.mu**2 * x[1]), (0.0, 0.0),
                      ("x1", "x2"), parameters={"mu": (0.5, 1.0, 1.5)})  # fmt: skip
    assert not is_affine(quad)
    res = box_lyapunov(quad)
    assert res.feasible and not res.affine and "nothing claimed between" in res.message


def test_default_v_is_designed_for_the_box_only_when_the_nominal_one_fails():
    assert np.allclose(roa.default_lyapunov(vdp(0.8, 1.2)).P, P_BENCH)  # unchanged there
    V = roa.default_lyapunov(vdp(0.5, 1.5))
    assert "LMI" in V.name and not np.allclose(V.P, P_BENCH)
    assert np.allclose(V.P, box_lyapunov(vdp(0.5, 1.5)).P, rtol=1e-6)


def test_certify_without_v_certifies_the_box_and_sampling_agrees():
    s = vdp(0.5, 1.5)
    cert = roa.certify(s)
    assert cert.status is Verdict.CERTIFIED and cert.method == "interval"
    assert cert.level > 1.0  # measured 1.639
    P, c = cert.V.P, cert.level
    # independent check: V' < 0 on {V <= c} \ {0} at many points and parameter values
    rng = np.random.default_rng(1)
    U = rng.standard_normal((20000, 2))
    L = np.linalg.cholesky(P)
    X = np.linalg.solve(L.T, (U / np.linalg.norm(U, axis=1, keepdims=True)).T).T
    X *= np.sqrt(c * rng.uniform(1e-6, 1.0, (len(X), 1)))
    assert np.all(np.einsum("ij,jk,ik->i", X, P, X) <= c * (1 + 1e-12))
    for mu in np.linspace(0.5, 1.5, 11):
        assert np.all(vdot(P, X, mu) < 0), mu


def test_certify_names_the_parameter_where_a_given_v_fails():
    s = vdp(0.5, 1.5)
    cert = roa.certify(s, P_BENCH)
    assert cert.status is Verdict.INCONCLUSIVE and cert.level is None
    assert cert.method == "linearisation"
    assert "mu = 0.5" in cert.message and "0.05902" in cert.message
    given = roa.certify(s, P_BENCH, level=1.0)  # a given level: refuted, and why
    assert given.status is Verdict.REFUTED and given.validation.witness_parameters == {"mu": 0.5}
    assert "not negative definite at the equilibrium for mu = 0.5" in given.message


def test_cli_robust_vanderpol_without_v(capsys):
    rc = main(["certify", "--system", "vanderpol", "--param", "mu=0.5..1.5"])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "certified: level 1.6" in out and "common Lyapunov LMIs" in out
