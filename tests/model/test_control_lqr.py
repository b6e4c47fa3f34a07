"""python-control loops (#37 item 4): the Riccati solution S of ``control.lqr`` as the loop's V, the
model's state and input names with the user's units, and the inputs u(t) of a simulation.

The cart-pole of ``examples/cartpole_lqr.py`` (M = 1 kg, m = 0.1 kg, l = 0.5 m, Q = I, R = 1): the
largest level of V = x'Sx with V' < 0 on {V <= c} is computed independently here, by scipy's SLSQP
minimising V on {V' >= 0, |x| >= 0.01} from random starts with the plant's own numpy updfcn and
K (no roa code): c*_S = 3.40333, c*_I = 0.0875004 for P of A'P + PA = -I. roa certifies 0.999 c*
and refutes 1.001 c* (the witness re-checked at 50 digits).
"""

from __future__ import annotations

import json
import pickle
import sys
from pathlib import Path

import numpy as np
import pytest
from references import complex_step_gradient
from scipy.optimize import minimize

import roa
from roa import closed_loop
from roa.model._control_system import RICCATI_NAME, lqr_parts
from roa.model._linearisation import jacobian, lyapunov_matrix

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "examples"))
import cartpole_lqr as cp  # noqa: E402

sys.path.remove(str(ROOT / "examples"))


def _c_star(P: np.ndarray, K: np.ndarray, starts: int = 30) -> float:
    """min x'Px on {2 x'P f(x) >= 0, |x|^2 >= 1e-4} by SLSQP from random starts (scipy only;
    the constraint's gradient by complex steps, exact to rounding: f is analytic)."""

    def f(x):  # x: (4,) or (4, m), one column per point
        return np.asarray(cp.updfcn(0.0, x, -K @ x, None))

    def vdot(x):
        return np.einsum("i...,ij,j...->...", x, 2.0 * P, f(x))

    cons = [{"type": "ineq", "fun": vdot, "jac": lambda x: complex_step_gradient(vdot, x)},
            {"type": "ineq", "fun": lambda x: x @ x - 1e-4, "jac": lambda x: 2.0 * x}]  # fmt: skip
    best = np.inf
    rng = np.random.default_rng(0)
    for _ in range(starts):
        r = minimize(lambda x: x @ P @ x, rng.standard_normal(4), jac=lambda x: 2.0 * P @ x,
                     constraints=cons, method="SLSQP",
                     options={"maxiter": 500, "ftol": 1e-12})  # fmt: skip
        if r.success and vdot(r.x) >= -1e-9 and r.x @ r.x > 1e-5:
            best = min(best, float(r.x @ P @ r.x))
    return best


@pytest.fixture(scope="module")
def loop():
    K, S, E = cp.lqr()
    return cp.cartpole(), K, S, E


def test_the_lqr_result_gives_the_riccati_solution_as_V(loop):
    system, K, S, E = loop
    np.testing.assert_array_equal(np.asarray(system.lyapunov), S)
    V = roa.default_lyapunov(system)
    assert V.name == RICCATI_NAME
    np.testing.assert_array_equal(V.P, S)
    # the closed loop is A - B K with the eigenvalues E that control.lqr reported
    eig = np.sort_complex(np.linalg.eigvals(jacobian(system)))
    np.testing.assert_allclose(eig, np.sort_complex(E), rtol=1e-6)
    # S solves the Riccati equation of the loop: (A - BK)'S + S(A - BK) = -(Q + K'RK)
    Acl = jacobian(system)
    np.testing.assert_allclose(Acl.T @ S + S @ Acl, -(cp.Q + K.T @ cp.R @ K), atol=1e-6)


def test_names_and_units_are_kept(loop):
    system = loop[0]
    assert system.state_names == ("p", "v", "theta", "omega")
    assert system.state_units == ("m", "m/s", "rad", "rad/s")
    assert system.input_names == ("F",) and system.input_units == ("N",)
    back = pickle.loads(pickle.dumps(system))
    x = np.array([[0.1, -0.2, 0.3, 0.4], [0.0, 0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(back.inputs(x), system.inputs(x))
    np.testing.assert_allclose(system.inputs(x), -(x @ loop[1].T), rtol=1e-15, atol=1e-15)


def test_lqr_weights_design_the_same_gain_and_S():
    K, S, _ = cp.lqr()
    designed = roa.System.from_control(cp.plant(), lqr=(cp.Q, cp.R))
    np.testing.assert_array_equal(np.asarray(designed.lyapunov), S)
    np.testing.assert_allclose(jacobian(designed), jacobian(cp.cartpole()), rtol=0, atol=1e-12)


def test_a_gain_alone_keeps_the_default_candidate():
    K, S, _ = cp.lqr()
    plain = roa.System.from_control(cp.plant(), K)
    assert plain.lyapunov is None and plain.input_names == ("F",)
    np.testing.assert_allclose(roa.default_lyapunov(plain).P, lyapunov_matrix(plain))
    # a K of three rows is a gain, not an lqr result
    rows = [[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]]
    assert lqr_parts(rows, 2) == (rows, None)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"K": np.zeros((1, 4)), "lqr": (np.eye(4), np.eye(1))}, r"K or lqr=\(Q, R\), not both"),
        ({"lqr": np.eye(4)}, r"lqr must be \(Q, R\)"),
        ({"lqr": (np.eye(3), np.eye(1))}, r"control.lqr failed"),
        ({"K": np.zeros((1, 4)), "input_units": ("N", "V")}, r"input_units must give one unit"),
        ({"K": np.zeros((1, 4)), "state_units": ("m",)}, r"state_units must give one unit"),
    ],
)
def test_bad_lqr_and_units_name_the_argument(kwargs, match):
    with pytest.raises(roa.RoaInputError, match=match):
        roa.System.from_control(cp.plant(), **kwargs)


def test_the_riccati_level_is_certified_and_refuted_just_above(loop):
    system, K, S, _ = loop
    c_star = _c_star(S, K)
    assert c_star == pytest.approx(3.4033, rel=1e-3)  # the newcomer's "S certifies 3.40"
    V = roa.default_lyapunov(system)
    cert = roa.certify(system, V, level=0.999 * c_star)
    assert cert.status is roa.Verdict.CERTIFIED
    above = roa.certify(system, V, level=1.001 * c_star)
    assert above.status is roa.Verdict.REFUTED
    w = np.asarray(above.witness)
    assert float(V.value(w)) <= 1.001 * c_star * (1 + 1e-9)


def test_simulation_reports_and_plots_the_inputs(loop, tmp_path):
    system, K, _, _ = loop
    traj = roa.simulate(system, [0.0, 0.0, 0.5, 0.0])
    assert traj.status is roa.RunStatus.CONVERGED
    np.testing.assert_allclose(traj.u[:, 0], -(traj.x @ K[0]), rtol=1e-13, atol=1e-13)
    d = traj.to_dict()
    assert d["input_names"] == ["F"] and d["input_units"] == ["N"]
    assert d["max_abs_input"][0] == pytest.approx(float(np.abs(0.5 * K[0, 2])), rel=1e-12)
    ax = traj.plot()
    axes = ax.figure.axes
    assert len(axes) == 2
    assert [t.get_text() for t in axes[1].get_legend().get_texts()] == ["F [N]"]
    assert axes[1].get_xlabel() == "time t [s]"
    # a system without feedback keeps one panel
    plain = roa.simulate(roa.load_system("vanderpol"), [0.5, 0.5])
    assert plain.u is None and "input_names" not in plain.to_dict()
    ax = plain.plot()
    assert len(ax.figure.axes) == 1
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["x1 [-]", "x2 [-]"]


def test_closed_loop_defaults_input_names():
    def pendulum(t, x, u, xp):
        return (x[1], -xp.sin(x[0]) - 0.1 * x[1] + u[0])

    cl = closed_loop(pendulum, [[1.0, 2.0]], ("theta", "omega"))
    assert cl.input_names == ("u0",)
    np.testing.assert_allclose(cl.inputs([0.5, -1.0]), [-(0.5 - 2.0)])
    with pytest.raises(roa.RoaInputError, match=r"input_names must name the 1 input"):
        closed_loop(pendulum, [[1.0, 2.0]], ("theta", "omega"), input_names=("a", "b"))


def test_cli_simulate_plots_u(tmp_path, capsys):
    from roa.cli import main

    png = tmp_path / "cartpole.png"
    argv = ["simulate", "--system", f"{ROOT / 'examples' / 'cartpole_lqr.py'}:cartpole",
            "--x0", "0,0,0.5,0", "--plot", str(png)]  # fmt: skip
    assert main([*argv, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["status"] == "converged" and doc["input_names"] == ["F"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(argv) == 0
    assert "final input (F):" in capsys.readouterr().out


@pytest.mark.slow
def test_the_example_certifies_S_far_beyond_the_identity_candidate(tmp_path, monkeypatch):
    """The example's two certified levels against scipy's c*: 0.999 c* certified, 1.001 c*
    refuted, for S (3.40) and for P of A'P + PA = -I (0.087); its JSON and figure."""
    monkeypatch.syspath_prepend(str(ROOT / "examples"))  # the example's _gallery
    doc = cp.main(["--quick", "--out", str(tmp_path)])
    K, S, _ = cp.lqr()
    system = cp.cartpole()
    for key, P in (("certificate", S), ("identity_candidate", lyapunov_matrix(system))):
        cert = doc[key] if key == "certificate" else doc[key]["certificate"]
        c_star = _c_star(P, K)
        assert cert["status"] == "certified" and cert["above"] == "refuted"
        assert 0.99 * c_star <= cert["level"] <= c_star
    assert doc["certificate"]["level"] == pytest.approx(3.40, abs=5e-3)
    assert doc["identity_candidate"]["certificate"]["level"] == pytest.approx(0.087, abs=1e-3)
    assert json.loads((tmp_path / "cartpole_lqr.json").read_text()) == doc
    assert (tmp_path / "cartpole_lqr.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    shares = doc["certified_share"]  # each region over the slice, then over the sampled 4-D box
    assert [e["over"] for e in shares] == ["slice", "slice", "box", "box"]
    assert all(e["converged_in_region"] <= e["converged"] for e in shares)
    # {x'Px <= c_P} lies inside {x'Sx <= c_S} (x'Sx <= lambda_max(P^-1 S) x'Px): fewer points
    P, c_P = lyapunov_matrix(system), doc["identity_candidate"]["certificate"]["level"]
    lam = float(np.linalg.eigvals(np.linalg.solve(P, S)).real.max())
    assert lam * c_P <= doc["certificate"]["level"]
    assert shares[1]["converged_in_region"] <= shares[0]["converged_in_region"]
    assert shares[3]["converged_in_region"] <= shares[2]["converged_in_region"]
