"""Discrete-time systems ``x+ = F(x)``: the representation, the level search against independent
optima, certification with the interval branch and bound (down to the fixed point), refutation
with 50-digit witnesses, the invariance precondition, tampered certificates, and Monte Carlo
runs that iterate the map.

References are independent of roa's analyses: the closed-form optimum of the cubic map
(:mod:`roa.systems.cubic_map`), multistart SLSQP (scipy) on ``V(F(x)) - V(x)`` written in plain
numpy, and orbits iterated in plain numpy."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

import roa
import roa.io
from roa.errors import RoaInputError
from roa.search._rays import ray_box
from roa.status import Verdict
from roa.systems.cubic_map import cubic_map, optimum

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "systems"
LAM, MU, THETA = 0.5, 1.0, 0.7


def F_numpy(x: np.ndarray, lam: float = LAM, mu: float = MU, theta: float = THETA) -> np.ndarray:
    """The cubic map written again in plain numpy (rows of states)."""
    x = np.atleast_2d(x)
    g = lam + mu * x[:, 0] ** 2
    c, s = math.cos(theta), math.sin(theta)
    return np.stack([g * (c * x[:, 0] - s * x[:, 1]), g * (s * x[:, 0] + c * x[:, 1])], axis=1)


def slsqp_optimum(F, P: np.ndarray, box: float, starts: int = 40, seed: int = 0,
                  r0: float = 0.05) -> float:  # fmt: skip
    """min V = x'Px subject to V(F(x)) - V(x) >= 0 and |x| >= r0 (multistart SLSQP from
    [-box, box]^2): the largest level whose set has Delta V < 0 away from the fixed point."""
    from scipy.optimize import minimize

    def dv(x):
        y = F(x[None])[0]
        return float(y @ P @ y - x @ P @ x)

    rng = np.random.default_rng(seed)
    best = np.inf
    for _ in range(starts):
        res = minimize(lambda x: float(x @ P @ x), rng.uniform(-box, box, 2), method="SLSQP",
                       constraints=[{"type": "ineq", "fun": dv},
                                    {"type": "ineq", "fun": lambda x: float(x @ x) - r0**2}],
                       options={"maxiter": 300, "ftol": 1e-12})  # fmt: skip
        if res.success and dv(res.x) >= -1e-9 and res.x @ res.x >= r0**2 - 1e-9:
            best = min(best, float(res.fun))
    return best


# -- the representation -----------------------------------------------------------------------------
def test_a_map_is_a_system_whose_field_refuses_to_be_a_derivative():
    s = cubic_map()
    assert s.time == "discrete" and s.sample_time == 1.0
    X = np.random.default_rng(0).uniform(-2, 2, (50, 2))
    np.testing.assert_allclose(s.step(X), F_numpy(X), rtol=1e-15, atol=0)
    np.testing.assert_allclose(s.residual(X), F_numpy(X) - X, rtol=1e-15, atol=0)
    with pytest.raises(RoaInputError, match="discrete-time"):
        s.f(X)  # an analysis of flows fails loudly, never reads F as f
    with pytest.raises(RoaInputError, match="discrete-time"):
        roa.certify(s, degree=4)
    with pytest.raises(RoaInputError, match="not both"):
        roa.System(name="x", field=lambda t, x, xp: x, equilibrium=(0.0,), state_names=("a",),
                   map=lambda t, x, xp: x)  # fmt: skip
    with pytest.raises(RoaInputError, match="sample_time"):
        roa.System.discrete(lambda t, x, xp: [x[0] / 2], name="x", equilibrium=(0.0,),
                            state_names=("a",), sample_time=-1.0)  # fmt: skip
    # parameters: with_params changes the map, and the fingerprint sees it
    from roa.model._fingerprint import system_fingerprint

    other = s.with_params(mu=2.0)
    np.testing.assert_allclose(other.step(X), F_numpy(X, mu=2.0), rtol=1e-15)
    assert system_fingerprint(other) != system_fingerprint(s)


def test_default_candidate_solves_the_discrete_lyapunov_equation():
    """A = lam R with R a rotation: A'PA - P = -I has the solution P = I / (1 - lam^2)."""
    from roa.model._linearisation import linearise

    s = cubic_map()
    lin = linearise(s)
    assert lin.kind == "schur" and lin.stable
    np.testing.assert_allclose(np.abs(lin.eigenvalues), [LAM, LAM], rtol=1e-12)
    P = roa.default_lyapunov(s).P
    np.testing.assert_allclose(P, np.eye(2) / (1 - LAM**2), atol=1e-12)
    bad = roa.System.discrete(lambda t, x, xp: [1.5 * x[0], 0.5 * x[1]], name="unstable",
                              equilibrium=(0.0, 0.0), state_names=("a", "b"))  # fmt: skip
    with pytest.raises(RoaInputError, match="not Schur"):
        roa.default_lyapunov(bad)


# -- level search, certification, refutation -------------------------------------------------------
def test_level_search_of_the_map_matches_the_closed_form_and_slsqp():
    s = cubic_map()
    P = roa.default_lyapunov(s).P
    c_star = optimum(LAM, MU)  # 1 / (mu (1 + lam)) = 2/3
    c_slsqp = slsqp_optimum(F_numpy, P, 2.0)
    assert abs(c_slsqp - c_star) <= 1e-6 * c_star
    for method in ("sampled", "casadi"):
        r = roa.level_search(s, shape="level", method=method)
        assert r.level is not None and abs(r.level - c_star) <= 1e-4 * c_star, (method, r)


def test_map_certified_at_099_refuted_at_101_with_a_50_digit_witness():
    s = cubic_map()
    c_star = optimum(LAM, MU)
    cert = roa.certify(s, level=0.99 * c_star)
    assert cert.certified, cert.message
    meta = cert.to_dict()
    assert meta["local_proof"] == "hessian"  # no hole at the fixed point
    assert meta["cover"].startswith("global") and "invariance" in meta
    above = roa.certify(s, level=1.01 * c_star)
    assert above.status is Verdict.REFUTED, above.message
    w = np.array(above.witness)
    P = np.eye(2) / (1 - LAM**2)
    y = F_numpy(w)[0]
    assert w @ P @ w <= 1.01 * c_star * (1 + 1e-12) and y @ P @ y - w @ P @ w >= 0
    assert above.validation.witness_check["confirmed"]  # 50 digits


def test_certify_proposes_and_refutes_above_on_its_own():
    s = cubic_map()
    cert = roa.certify(s, check_above=1.01)
    assert cert.certified and 0.99 * optimum() <= cert.level <= optimum(), cert.message
    assert cert.above is not None and cert.above.status is Verdict.REFUTED
    assert "continuous-time systems only" in cert.message  # why the SOS proposer stood aside


def test_certified_set_is_mapped_into_itself():
    """The invariance the certificate claims, sampled: V(F(x)) <= V(x) <= c on {V <= c}."""
    s = cubic_map()
    c = 0.99 * optimum()
    assert roa.certify(s, level=c).certified
    P = np.eye(2) / (1 - LAM**2)
    rng = np.random.default_rng(1)
    X = rng.uniform(-1, 1, (200_000, 2))
    X = X[np.einsum("ij,jk,ik->i", X, P, X) <= c]
    Y = F_numpy(X)
    VX, VY = np.einsum("ij,jk,ik->i", X, P, X), np.einsum("ij,jk,ik->i", Y, P, Y)
    assert len(X) > 50_000 and np.all(VY <= VX) and np.all(VY <= c)


def test_a_cover_of_the_component_alone_is_refused_for_a_map():
    """A V with no Gram matrix has only a component cover (a box with V > c on its faces):
    a map may jump out of the component, so neither the route's preconditions nor the branch
    and bound called directly certify it (precondition 'invariant')."""
    from roa.proof._validate import validate_level

    s = cubic_map()
    V = roa.FunctionLyapunov(lambda x, xp: (x[0] ** 2 + x[1] ** 2) * (4.0 / 3.0), [0.0, 0.0])
    v = roa.IntervalValidator().check(s, V, 0.5)
    assert v.status is Verdict.INCONCLUSIVE and v.meta["precondition"] == "invariant"
    direct = validate_level(s, V, 0.5, cover_estimate=ray_box)
    assert direct.status is Verdict.INCONCLUSIVE
    assert direct.meta["precondition"] == "invariant", direct.message
    # the same level with the quadratic V (whole set, convex) is certified
    assert roa.IntervalValidator().check(s, roa.default_lyapunov(s), 0.5).status is (
        Verdict.CERTIFIED
    )


def test_a_tampered_map_certificate_is_refused():
    from roa.certification import Certificate

    s = cubic_map()
    cert = roa.certify(s, level=0.99 * optimum())
    data = json.loads(roa.io.to_json(cert.to_dict()))
    assert Certificate.from_dict(data, s).reverify().certified
    raised = Certificate.from_dict({**data, "level": 1.01 * optimum()}, s).reverify()
    assert raised.status is Verdict.REFUTED
    with pytest.raises(RoaInputError, match="another system"):
        Certificate.from_dict(data, s.with_params(mu=1.2))  # another map
    # the fingerprint removed: the other map refutes the stored level on re-verification
    bare = {k: v for k, v in data.items() if k != "system_fingerprint"}
    assert Certificate.from_dict(bare, s.with_params(mu=1.2)).reverify().status is (Verdict.REFUTED)


# -- Monte Carlo -------------------------------------------------------------------------------------
def _numpy_codes(X: np.ndarray, steps: int, tol: float, bound: float) -> np.ndarray:
    """Statuses by iterating F_numpy row by row: 0 converged, 2 diverged, 3 undecided."""
    out = np.full(len(X), 3)
    for i, x in enumerate(X):
        for _ in range(steps + 1):
            if not np.all(np.isfinite(x)) or np.linalg.norm(x) >= bound:
                out[i] = 2
                break
            if np.linalg.norm(x) <= tol:
                out[i] = 0
                break
            x = F_numpy(x)[0]
    return out


def test_basin_of_the_map_agrees_with_direct_iteration():
    s = cubic_map()
    rules = roa.StopRules(t_final=60.0, converge_tol=1e-3, diverge_bound=1e3)
    sampler = roa.box_sample(s, [(-2.5, 2.5), (-2.5, 2.5)], 3000, seed=3)
    res = roa.basin(s, sampler, rules=rules, run=roa.RunOptions(n_jobs=1, chunk_size=700))
    X = sampler.points(0, 3000)
    expected = _numpy_codes(X, 60, 1e-3, 1e3)
    np.testing.assert_array_equal(res.code, expected)
    assert 0 < res.counts["converged"] < 3000 and res.counts["diverged"] > 0
    # every point of the certified set converges
    P = np.eye(2) / (1 - LAM**2)
    inside = np.einsum("ij,jk,ik->i", X, P, X) <= 0.99 * optimum()
    assert inside.sum() > 50 and np.all(res.code[inside] == 0)
    # one orbit: simulate iterates the same map
    traj = roa.simulate(s, X[0], rules=rules)
    assert traj.status.value == {0: "converged", 2: "diverged", 3: "undecided"}[expected[0]]
    np.testing.assert_allclose(traj.x[1], F_numpy(X[0])[0], rtol=1e-15)


# -- discretised flows --------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "h, method, named",
    [(0.0, "rk4", "h"), (-0.1, "euler", "h"), (float("inf"), "rk4", "h"), (True, "rk4", "h"),
     ("0.1", "rk4", "h"), (0.1, "midpoint", "method")],
)  # fmt: skip
def test_discretise_refuses_a_bad_step_naming_it(h, method, named):
    from roa.model._discrete import discretise
    from roa.systems.vanderpol import vanderpol

    with pytest.raises(RoaInputError, match=named):
        discretise(vanderpol(), h, method)
    with pytest.raises(RoaInputError, match="already discrete-time"):
        discretise(cubic_map(), 0.1)


def test_discretise_writes_the_euler_and_rk4_steps_in_every_namespace():
    from roa.model._discrete import discretise
    from roa.proof._exact import exact_equilibrium
    from roa.proof._interval import INTERVAL, Interval
    from roa.systems.vanderpol import vanderpol

    flow = vanderpol()
    h = 0.05
    X = np.random.default_rng(0).uniform(-1, 1, (20, 2))

    def f(x):
        return flow.f(x)

    euler = discretise(flow, h, "euler")
    np.testing.assert_allclose(euler.step(X), X + h * f(X), rtol=1e-14)
    rk4 = discretise(flow, h, "rk4")
    k1 = f(X)
    k2 = f(X + h / 2 * k1)
    k3 = f(X + h / 2 * k2)
    k4 = f(X + h * k3)
    np.testing.assert_allclose(rk4.step(X), X + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4), rtol=1e-13)
    assert rk4.sample_time == h and rk4.with_params(mu=0.5).step(X[:1]).shape == (1, 2)
    # intervals enclose the float step
    box = rk4.map(0.0, [Interval(X[:, 0]), Interval(X[:, 1])], INTERVAL)
    Y = rk4.step(X)
    for i in range(2):
        assert np.all(box[i].lo <= Y[:, i]) and np.all(Y[:, i] <= box[i].hi)
    assert exact_equilibrium(rk4, np.zeros(2))
    off = roa.System(name="off", field=lambda t, x, xp: (-x[0] + 1e-20, -x[1]),
                     equilibrium=(0.0, 0.0), state_names=("a", "b"))  # fmt: skip
    assert not exact_equilibrium(discretise(off, h, "rk4"), np.zeros(2))


def _pendulum():
    sys.path.insert(0, str(EXAMPLES))
    try:
        import pendulum_nn_discrete
    finally:
        sys.path.remove(str(EXAMPLES))
    return pendulum_nn_discrete


@pytest.mark.slow
def test_sampled_nn_pendulum_certified_at_099_refuted_at_101():
    """The tanh-network pendulum, Euler step of h = 0.05 s: the branch and bound certifies
    0.99 x the SLSQP optimum of the default V (A'PA - P = -I) with the Hessian proof at the
    fixed point, and refutes 1.01 x with a 50-digit witness."""
    ex = _pendulum()
    s = ex.SYSTEM
    P = roa.default_lyapunov(s).P
    flow = s.meta["discretised"]
    assert flow["method"] == "euler" and flow["h"] == ex.H
    sys.path.insert(0, str(EXAMPLES))
    try:
        import pendulum_nn
    finally:
        sys.path.remove(str(EXAMPLES))
    cont = pendulum_nn.SYSTEM

    def F(X):
        return X + ex.H * cont.f(X)  # the Euler step, by hand

    c = slsqp_optimum(F, P, 4.0)
    assert 100.0 < c < 1000.0
    cert = roa.certify(s, level=0.99 * c)
    assert cert.certified, cert.message
    meta = cert.to_dict()
    assert meta["local_proof"] == "hessian" and meta["cover"].startswith("global")
    above = roa.certify(s, level=1.01 * c)
    assert above.status is Verdict.REFUTED, above.message
    w = np.array(above.witness)
    y = F(w[None])[0]
    assert w @ P @ w <= 1.01 * c * (1 + 1e-9) and y @ P @ y - w @ P @ w >= 0


def test_cli_certifies_the_registered_map(capsys):
    from roa.cli import main

    level = 0.99 * optimum()
    assert main(["certify", "--system", "cubic-map", "--level", f"{level:.12g}", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "certified" and out["local_proof"] == "hessian"
    code = main(["certify", "--system", "cubic-map", "--level", f"{1.01 * optimum():.12g}"])
    assert code == 1


@pytest.mark.slow
def test_discrete_pendulum_example_writes_its_certificate_and_basin(tmp_path):
    """The gallery script (quick): certified, refuted above, every grid point of the certified
    set converged when the map is iterated."""
    sys.path.insert(0, str(ROOT / "examples"))
    try:
        import discrete_pendulum_nn
    finally:
        sys.path.remove(str(ROOT / "examples"))
    doc = discrete_pendulum_nn.main(["--quick", "--out", str(tmp_path)])
    cert, basin = doc["certificate"], doc["basin_slice"]
    assert cert["status"] == "certified" and cert["above"] == "refuted"
    assert 0 < cert["level"] <= doc["level_search"]["level"]
    (certified,) = [r for r in basin["regions"] if r["status"] == "certified"]
    assert certified["slice"]["points_in_region"] > 0 and certified["slice"]["all_converged"]
    assert (tmp_path / "discrete_pendulum_nn.png").read_bytes()[:4] == b"\x89PNG"


def test_polynomial_map_certified_by_an_exact_sos_certificate():
    """For a polynomial map Delta V = V(F(x)) - V(x) is a polynomial: the SOS route proves
    0.99 x the closed-form optimum with a certificate checked in exact rationals; the stored
    certificate re-verifies, and refuses to certify with its level raised above the optimum or
    with a Gram matrix altered."""
    from fractions import Fraction

    from roa.certification import Certificate

    s = cubic_map()
    cert = roa.certify(s, level=0.99 * optimum(), validator="sos")
    assert cert.certified and cert.method == "sos-exact", cert.message
    data = json.loads(roa.io.to_json(cert.to_dict()))
    assert Certificate.from_dict(data, s).reverify().certified
    raised = Certificate.from_dict({**data, "level": 1.01 * optimum()}, s).reverify()
    assert not raised.certified
    tampered = json.loads(json.dumps(data))
    gram = tampered["certificate"]["parts"][0]["grams"][-1]
    gram["Q"] = [[str(Fraction(q) * Fraction(3, 2)) for q in row] for row in gram["Q"]]
    assert not Certificate.from_dict(tampered, s).reverify().certified
    above = roa.certify(s, level=1.01 * optimum(), validator="sos")
    assert not above.certified  # the SOS route never certifies above the optimum


@pytest.mark.slow
def test_a_map_with_uncertain_parameters_is_proved_for_the_whole_box():
    """mu in [0.9, 1.1]: the worst optimum is 1 / (1.1 (1 + lam)); 0.99 x it is certified for
    every mu of the box, 1.01 x it refuted by a 50-digit witness at mu = 1.1."""
    s = cubic_map().with_ranges(mu=(0.9, 1.1))
    worst = optimum(LAM, 1.1)
    assert roa.certify(s, level=0.99 * worst).certified
    above = roa.certify(s, level=1.01 * worst)
    assert above.status is Verdict.REFUTED and above.validation.witness_parameters == {"mu": 1.1}


def test_cli_basin_of_the_registered_map_with_its_certificate_as_terminal_set(tmp_path, capsys):
    """``roa basin`` iterates the map; runs entering the certified set stop as converged; the
    counts agree with the library call on the same grid; method='sos' is refused by name."""
    from roa.cli import main

    level = 0.99 * optimum()
    assert main(["certify", "--system", "cubic-map", "--level", f"{level:.12g}", "--json"]) == 0
    path = tmp_path / "cert.json"
    path.write_text(capsys.readouterr().out)
    args = [
        "basin",
        "--system",
        "cubic-map",
        "--slice",
        "x1,x2",
        "--grid",
        "30x30",
        "--box",
        "x1=-2.5:2.5,x2=-2.5:2.5",
        "--terminal-set",
        str(path),
        "--jobs",
        "1",
        "--json",
    ]
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    s = cubic_map()
    grid = roa.grid_slice(s, ("x1", "x2"), [(-2.5, 2.5), (-2.5, 2.5)], (30, 30))
    X = grid.points(0, 900)
    expected = _numpy_codes(X, 60, 1e-3, 1e6)
    assert out["counts"]["converged"] == int(np.sum(expected == 0)) > 0
    assert out["entered_certified_set"] == out["counts"]["converged"]
    assert out["counts"]["diverged"] == int(np.sum(expected == 2)) > 0
    assert main(["certify", "--system", "cubic-map", "--method", "sos"]) == 2
    assert "discrete-time" in capsys.readouterr().err
