"""Uncertain parameters: declaring a box, and certificates that hold for every parameter of it.

The reference numbers come from an independent computation in this file: the optimum of
``min V(x) s.t. V'(x) = 0, |x| >= r`` by multistart SLSQP (scipy) at fixed parameter values.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from references import VDP_P as P, vdp_optimum

import roa
from roa.cli import main
from roa.model._parameters import ParameterBox, over, sample_points
from roa.model._system import System
from roa.proof._interval import INTERVAL, Interval
from roa.proof._robust import validate_robust
from roa.search._candidate import as_lyapunov
from roa.search._rays import ray_box
from roa.search._robust_witness import sampled_witness
from roa.status import Verdict


def vdp(t, x, xp, p):
    return (-x[1], x[0] + p.mu * (x[0] * x[0] - 1) * x[1])


def vdp_box(low: float = 0.8, high: float = 1.2) -> System:
    return System("vdp", vdp, (0.0, 0.0), ("x1", "x2"), parameters={"mu": (low, 1.0, high)},
                  lyapunov=P)  # fmt: skip


# -- declaring parameters -------------------------------------------------------------------------
def test_box_declared_checked_and_fixed():
    s = vdp_box()
    assert s.uncertain == ("mu",)
    assert s.params["mu"] == 1.0 and s.parameters["mu"].low == 0.8
    assert s.at(mu=1.2).uncertain == () and s.at(mu=1.2).params["mu"] == 1.2
    assert s.nominal() == s.at(mu=1.0)
    f_lo, f_hi = s.at(mu=0.8).f([[0.5, 0.5]]), s.at(mu=1.2).f([[0.5, 0.5]])
    assert f_lo[0, 1] == pytest.approx(0.5 + 0.8 * (0.25 - 1) * 0.5)
    assert f_hi[0, 1] == pytest.approx(0.5 + 1.2 * (0.25 - 1) * 0.5)
    for bad, words in [((1.2, 1.0, 0.8), "low <= nominal <= high"), ((1, 1, 1), "low < high"),
                       ("x", "three finite numbers"), ((0, 1, np.inf), "three finite numbers")]:  # fmt: skip
        with pytest.raises(roa.RoaInputError, match=r"parameters\['mu'\].*" + words):
            System("v", vdp, (0.0, 0.0), ("a", "b"), parameters={"mu": bad})
    with pytest.raises(roa.RoaInputError, match=r"'mu' must be a number in \[0.8, 1.2\]"):
        s.at(mu=1.5)
    with pytest.raises(roa.RoaInputError, match="uncertain: fix it with System.at"):
        s.with_params(mu=1.1)
    fixed = System("v", vdp, (0.0, 0.0), ("a", "b"), params={"mu": 1.0})
    assert fixed.with_ranges(mu=(0.8, 1.2)).parameters["mu"] == (0.8, 1.0, 1.2)
    with pytest.raises(roa.RoaInputError, match="no parameter 'nu'"):
        fixed.with_ranges(nu=(0, 1))


def test_equilibrium_and_linearisation_checked_over_the_box():
    def moving(t, x, xp, p):  # f(0) = (0, mu - 1): an equilibrium at mu = 1 only
        return (-x[0] + x[1], -x[1] + (p.mu - 1.0))

    s = System("m", moving, (0.0, 0.0), ("a", "b"), parameters={"mu": (0.5, 1.0, 2.0)})
    with pytest.raises(roa.RoaInputError, match="parameter values mu = 0.5.*not an equilibrium"):
        roa.certify(s, level=0.1)
    with pytest.raises(roa.RoaInputError, match="parameter values mu = -0.5.*unstable"):
        roa.certify(vdp_box(-0.5, 1.2), level=0.1)


def test_interval_parameters_enclose_every_parameter_value():
    """The field over a parameter box (intervals for mu) encloses the field at sampled mu."""
    s = over(vdp_box(), ParameterBox(("mu",), (0.8,), (1.2,)))
    rng = np.random.default_rng(3)
    for _ in range(50):
        lo = rng.uniform(-2, 2, 2)
        hi = lo + rng.uniform(0, 0.5, 2)
        enc = s.field(0.0, [Interval(lo[0], hi[0]), Interval(lo[1], hi[1])], INTERVAL)
        for mu in rng.uniform(0.8, 1.2, 20):
            x = rng.uniform(lo, hi)
            f = vdp(0.0, x, None, type("p", (), {"mu": mu}))
            for k in range(2):
                assert enc[k].lo <= f[k] <= enc[k].hi


# -- robust certificates --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def worst() -> float:
    """The worst per-parameter optimum: V' is affine in mu, so the worst case is at an end."""
    return min(vdp_optimum(0.8), vdp_optimum(1.2))


def test_robust_level_is_the_worst_case(worst):
    cert = roa.certify(vdp_box(), check_above=1.005)
    assert cert.status is Verdict.CERTIFIED
    assert cert.level <= worst  # never above the true worst case
    assert cert.level == pytest.approx(worst, rel=0.01)
    assert cert.above.status is Verdict.REFUTED
    assert cert.above.witness_parameters == {"mu": 0.8}
    d = cert.to_dict()
    assert d["parameters"] == {"mu": {"low": 0.8, "nominal": 1.0, "high": 1.2}}
    # the nominal level is higher: the box costs something
    assert vdp_optimum(1.0) > 1.1 * worst


def test_nominal_level_refuted_for_the_box(worst):
    """A level valid at the nominal value but not for the box: refuted, witness names mu; the
    witness is re-checked here independently at that mu."""
    level = 1.05 * worst
    assert roa.certify(vdp_box().nominal(), level=level).status is Verdict.CERTIFIED
    cert = roa.certify(vdp_box(), level=level)
    assert cert.status is Verdict.REFUTED
    v = cert.validation
    mu = v.witness_parameters["mu"]
    assert 0.8 <= mu <= 1.2
    x = np.asarray(v.witness)
    assert x @ P @ x <= level
    f = np.array([-x[1], x[0] + mu * (x[0] ** 2 - 1) * x[1]])
    assert 2 * x @ P @ f >= 0
    assert json.loads(json.dumps(cert.to_dict()))["witness_parameters"] == {"mu": mu}


def test_wide_box_certified_below_and_refuted_above_the_worst_case():
    """A wide box (the local proof needs pieces of it): certified below the worst case, refuted
    above it at the worst end."""
    s = vdp_box(0.7, 1.5)
    V = as_lyapunov(s, P)
    lo = min(vdp_optimum(0.7), vdp_optimum(1.5))
    res = validate_robust(
        s, V, 0.99 * lo, proposal=sampled_witness(s, V, 0.99 * lo)[:2], cover_estimate=ray_box
    )
    assert res.status is Verdict.CERTIFIED
    assert res.meta["local_parameter_pieces"] >= 1
    above = validate_robust(
        s, V, 1.01 * lo, proposal=sampled_witness(s, V, 1.01 * lo)[:2], cover_estimate=ray_box
    )
    assert above.status is Verdict.REFUTED and above.witness_parameters["mu"] == 0.7


def test_box_where_v_is_not_a_lyapunov_function_is_refuted():
    """At mu = 0.5, A'P + PA (P the benchmark's) has eigenvalue 0.059 > 0: V' > 0 arbitrarily close
    to the equilibrium, so no level holds for a box reaching mu = 0.5 (the whole box's branch and
    bound would only wear its budget down: the witness is found next to the equilibrium)."""
    s = vdp_box(0.5, 1.5)
    res = validate_robust(
        s,
        as_lyapunov(s, P),
        0.05,
        proposal=sampled_witness(s, as_lyapunov(s, P), 0.05)[:2],
        cover_estimate=ray_box,
    )
    assert res.status is Verdict.REFUTED
    assert res.witness_parameters == {"mu": 0.5}
    x, mu = np.asarray(res.witness), 0.5
    assert 2 * x @ P @ np.array([-x[1], x[0] + mu * (x[0] ** 2 - 1) * x[1]]) >= 0
    assert 0 < x @ P @ x <= 0.05


def test_sample_points_cover_vertices_and_nominal():
    s = System("t", lambda t, x, xp, p: (-x[0] * p.a, -x[1] * p.b), (0.0, 0.0), ("x", "y"),
               parameters={"a": (1, 2, 3), "b": (1, 1.5, 2)})  # fmt: skip
    pts = sample_points(s)
    assert {"a": 2.0, "b": 1.5} in pts
    for v in ({"a": 1.0, "b": 1.0}, {"a": 3.0, "b": 2.0}, {"a": 1.0, "b": 2.0}):
        assert v in pts
    assert len(pts) == 5


@pytest.mark.slow
def test_robust_certificate_file_checked_for_its_box(tmp_path, worst):
    """A certificate for the box re-verifies; the same file with a raised level is refused; a
    nominal certificate is refused for the box (another fingerprint)."""
    s = vdp_box()
    cert = roa.certify(s, level=0.99 * worst)
    assert cert.certified
    data = cert.to_dict()
    again = roa.Certificate.from_dict(data, s).reverify()
    assert again.status is Verdict.CERTIFIED
    forged = {**data, "level": 1.1 * worst}
    assert roa.Certificate.from_dict(forged, s).reverify().status is not Verdict.CERTIFIED
    nominal = roa.certify(s.nominal(), level=1.1 * worst).to_dict()
    with pytest.raises(roa.RoaInputError, match="another system"):
        roa.Certificate.from_dict(nominal, s)


# -- CLI --------------------------------------------------------------------------------------------
def test_cli_param_ranges(capsys, worst):
    rc = main(["certify", "--system", "vanderpol", "--param", "mu=0.8..1.2", "--level",
               f"{1.05 * worst}", "--json"])  # fmt: skip
    out = json.loads(capsys.readouterr().out)
    assert rc == 1 and out["status"] == "refuted" and "mu" in out["witness_parameters"]
    rc = main(["certify", "--system", "vanderpol", "--param", "mu=0.8..1.2", "--nominal",
               "--level", f"{1.05 * worst}", "--json"])  # fmt: skip
    assert rc == 0 and json.loads(capsys.readouterr().out)["status"] == "certified"
    for spec, words in [("mu=abc", "not a number"), ("nu=1..2", "no parameter 'nu'"),
                        ("mu=1..2..3..4", "LOW..HIGH or LOW..NOMINAL..HIGH"),
                        ("mu=1.5..2", "low <= nominal <= high"), ("mu", "NAME=VALUE"),
                        ("mu=nan..2", "finite")]:  # fmt: skip
        assert main(["certify", "--system", "vanderpol", "--param", spec, "--level", "1"]) == 2
        assert words in capsys.readouterr().err


def test_every_proof_namespace_sees_the_box():
    """The jets of the branch and bound and the intervals see the whole range of mu; the float
    namespaces see the point; an unknown namespace is refused (never a point by default)."""
    from types import SimpleNamespace

    from roa.model._backend import NP
    from roa.proof._jet import Jet
    from roa.proof._jet_net import JET

    s = over(vdp_box(), ParameterBox(("mu",), (0.8,), (1.2,)))
    x = Jet.variables(np.array([[1.0, 1.0]]), np.array([[1.0, 1.0]]), order=2)  # x = (1, 1)
    j = s.field(0.0, x, JET)[1]  # x1 + mu (x1^2 - 1) x2 = 1 + 0 mu: use d/dx1 = 1 + 2 mu x1 x2
    g = Interval.of(j.g[0])
    assert float(g.lo[0]) <= 1 + 2 * 0.8 and float(g.hi[0]) >= 1 + 2 * 1.2
    assert s.f([[1.0, 1.0]])[0, 1] == pytest.approx(1.0)
    assert s.f([[2.0, 1.0]])[0, 1] == pytest.approx(2.0 + 1.0 * 3.0)  # the midpoint mu = 1
    with pytest.raises(roa.RoaInputError, match="cannot be evaluated in namespace 'other'"):
        s.field(0.0, [1.0, 1.0], SimpleNamespace(name="other"))
    assert NP.name == "numpy"


@pytest.mark.slow
def test_level_search_and_simulation_over_a_box(capsys):
    """The level search reports the worst sample point with every point's level; a trajectory
    needs one parameter value (no silent nominal)."""
    s = vdp_box()
    res = roa.level_search(s, P, method="sampled")
    per = res.details["per_parameter"]
    assert {tuple(r["parameters"].items()) for r in per} == {(("mu", v),) for v in (0.8, 1.0, 1.2)}
    assert res.level == min(r["level"] for r in per)
    assert res.details["parameters"] == {"mu": 0.8}
    assert res.level == pytest.approx(vdp_optimum(0.8), rel=1e-3)
    with pytest.raises(roa.RoaInputError, match=r"uncertain parameters \(mu in \[0.8, 1.2\]\)"):
        roa.simulate(s, [0.5, 0.5])
    assert roa.simulate(s.at(mu=1.2), [0.5, 0.5]).status.value == "converged"
    rc = main(["khalil", "--system", "vanderpol", "--param", "mu=0.8..1.2", "--shape", "level",
               "--method", "sampled", "--json"])  # fmt: skip
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and out["parameters"] == {"mu": 0.8} and len(out["per_parameter"]) == 3


def poly(t, x, xp, p):
    A = 1 - (2 * p.a - 1) ** 2  # largest (1) at a = 1/2, inside the box
    return (-x[0] + A * x[0] ** 3 + 1.5 * x[0] * x[1] ** 2, -x[1] + 0.6 * x[1] ** 3
            + 1.5 * x[0] ** 2 * x[1])  # fmt: skip


@pytest.mark.slow
def test_worst_case_inside_the_box_is_never_exceeded():
    """V = |x|^2: with u = x1^2 = s r, x2^2 = (1 - s) r, V'/2 = -r + r^2 q(s), q(s) = A s^2 +
    0.6 (1 - s)^2 + 3 s (1 - s), so the largest level is 1 / max q, smallest at A = 1 (a = 1/2):
    q'(s) = 0 at s = 2.4 / 3.2 = 0.75, max q = 1.1786 = 33/28, worst level 28/33. The sample points
    (nominal 0.2, ends 0 and 0.9, axis points 0.225, 0.45, 0.675) miss a = 1/2; the level is
    certified below 28/33 (backing off where the proposal was too high) and never above it."""
    s = System("poly", poly, (0.0, 0.0), ("x1", "x2"), parameters={"a": (0.0, 0.2, 0.9)})
    itv = roa.IntervalOptions(max_boxes=200_000)
    cert = roa.certify(s, np.eye(2), method="interval", interval=itv)
    worst = 28 / 33
    assert cert.status is Verdict.CERTIFIED
    assert 0.85 * worst <= cert.level <= worst
    assert cert.level_source == "backoff" and "not a bound between them" in cert.message
    above = roa.certify(s, np.eye(2), level=1.01 * worst, interval=itv)
    assert above.status is not Verdict.CERTIFIED
