"""Lyapunov candidates beyond quadratic: level search, certification and interval validation.

Independent references: the one-state system x' = -x + x^3 with V = x^2 + x^4 has the closed
form V' = (2x + 4x^3)(-x + x^3) < 0 iff 0 < |x| < 1, so the largest level is V(1) = 2; the other
references are scipy multistart minimisations of V subject to V' = 0 (not the code under test).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize

import roa
from roa import System
from roa.cli import main
from roa.errors import RoaInputError
from roa.lyapunov import FunctionLyapunov, Lyapunov, PolynomialLyapunov
from roa.proof._validate import validate_level
from roa.search._rays import ray_box
from roa.status import Verdict
from roa.systems import load_system
from roa.systems.vanderpol import vanderpol

ROOT = Path(__file__).resolve().parents[2]
ONE_STATE = f"{ROOT}/examples/systems/one_state.py:SYSTEM"


def _reference(V, Vdot, n, *, starts=60, box=3.0, seed=0):
    """min V(x) s.t. V'(x) = 0, |x| >= 0.05 by SLSQP from random starts (scipy only)."""
    rng = np.random.default_rng(seed)
    best = np.inf
    for x0 in rng.uniform(-box, box, (starts, n)):
        r = minimize(
            V, x0, method="SLSQP",
            constraints=[{"type": "eq", "fun": Vdot}, {"type": "ineq", "fun": lambda x: x @ x - 0.05}],
            options={"ftol": 1e-14, "maxiter": 500},
        )  # fmt: skip
        if r.success and abs(Vdot(r.x)) < 1e-9 and r.x @ r.x > 0.04:
            best = min(best, float(r.fun))
    return best


def test_quadratic_is_a_lyapunov_and_unchanged():
    V = roa.default_lyapunov(vanderpol())
    assert isinstance(V, Lyapunov)
    x = np.array([[0.3, -1.2], [2.0, 0.5]])
    d = x - V.center
    assert np.array_equal(V.value(x), np.einsum("...i,ij,...j->...", d, V.P, d))
    from roa.model._backend import NP

    assert np.allclose(V.expr([x[:, 0], x[:, 1]], NP), V.value(x))
    assert np.allclose(V.gradient(x), 2 * d @ V.P)


def test_inputs_are_checked():
    with pytest.raises(RoaInputError, match="coefficients"):
        PolynomialLyapunov([[2, 0], [0, 2]], [1.0], [0.0, 0.0])
    with pytest.raises(RoaInputError, match="degree >= 2"):
        PolynomialLyapunov([[1, 0], [0, 2]], [1.0, 1.0], [0.0, 0.0])
    with pytest.raises(RoaInputError, match="even"):
        PolynomialLyapunov([[2, 0], [3, 0]], [1.0, 1.0], [0.0, 0.0])
    with pytest.raises(RoaInputError, match="center"):
        PolynomialLyapunov([[2, 0]], [1.0], [0.0])
    with pytest.raises(RoaInputError, match="func"):
        FunctionLyapunov(3.0, [0.0])
    with pytest.raises(RoaInputError, match="vanish"):
        FunctionLyapunov(lambda x, xp: 1 + x[0] ** 2, [0.0])
    with pytest.raises(RoaInputError, match="sos"):
        roa.certify(load_system(ONE_STATE), PolynomialLyapunov([[2], [4]], [1, 1], [0.0]),
                    method="sos")  # fmt: skip


def test_one_state_quartic_closed_form():
    system = load_system(ONE_STATE)
    V = PolynomialLyapunov([[2], [4]], [1.0, 1.0], [0.0])
    res = roa.level_search(system, V, method="both")
    assert res.status.value == "agree"
    assert res.level == pytest.approx(2.0, rel=1e-8)
    assert abs(abs(res.witness[0]) - 1.0) < 1e-8
    assert validate_level(system, V, 0.999 * 2, cover_estimate=ray_box).status is Verdict.CERTIFIED
    ref = validate_level(system, V, 1.001 * 2, cover_estimate=ray_box)
    assert ref.status is Verdict.REFUTED and ref.witness_check["confirmed"]
    # the same V from a Gram matrix: a global cover proved from Q
    G = PolynomialLyapunov.from_gram([[1], [2]], np.eye(2), [0.0])
    v = validate_level(system, G, 1.998, cover_estimate=ray_box)
    assert v.status is Verdict.CERTIFIED and v.meta["cover"].startswith("global")
    assert validate_level(system, G, 2.002, cover_estimate=ray_box).status is Verdict.REFUTED


SQUARE = System(
    name="square-basin",
    field=lambda t, x, xp: (-x[0] + x[0] ** 3, -x[1] + x[1] ** 3),
    equilibrium=(0.0, 0.0),
    state_names=("x1", "x2"),
)


def _square_vdot(w):
    def vdot(x):
        g = [2 * x[i] + 4 * w * x[i] ** 3 for i in range(2)]
        return sum(g[i] * (-x[i] + x[i] ** 3) for i in range(2))

    return vdot


@pytest.mark.slow
def test_quartic_certifies_more_than_best_quadratic():
    V = PolynomialLyapunov([[2, 0], [0, 2], [4, 0], [0, 4]], [1.0, 1.0, 1.0, 1.0], [0.0, 0.0])
    # closed form 2 (at (+-1, 0), (0, +-1)); SLSQP from 15 starts confirms it
    ref = _reference(lambda x: x @ x + x[0] ** 4 + x[1] ** 4, _square_vdot(1.0), 2, starts=15)
    assert ref == pytest.approx(2.0, rel=1e-6)
    res = roa.level_search(SQUARE, V, method="both")
    assert res.ok and res.level == pytest.approx(ref, rel=1e-6)
    cert = roa.certify(SQUARE, V, check_above=1.001)
    assert cert.certified and cert.level_source == "sampled" and cert.method == "interval"
    assert "SOS applies to quadratic V only" in cert.message
    assert cert.level == pytest.approx(0.999 * ref, rel=1e-5)
    assert cert.above.status is Verdict.REFUTED
    # certified area of the quartic (grid) beats every quadratic one: the basin is the open square
    # (-1, 1)^2 (x_i' = -x_i + x_i^3 decouple), so a certified ellipse lies in it, and the largest
    # ellipse in a square is its inscribed circle (John's ellipse; by symmetry), of area pi
    g = np.linspace(-1.0, 1.0, 801)
    X = np.stack(np.meshgrid(g, g), axis=-1)
    area = float(np.mean(V.value(X) <= cert.level)) * 4.0
    assert area > 1.08 * np.pi
    # the unit circle x'x <= 1 itself is certifiable (V = x'x: V' = -2|x|^2 + 2 sum x_i^4 < 0)
    circle = roa.QuadraticLyapunov(np.eye(2), np.zeros(2), "circle")
    assert validate_level(SQUARE, circle, 0.999, cover_estimate=ray_box).status is Verdict.CERTIFIED


def test_function_lyapunov_log_on_vanderpol():
    # V = log(1 + x'Px) (P of A'P + PA = -I: with P = I, V' = -2 (1 - x1^2) x2^2 / (1 + x'x)
    # vanishes on the x1 axis and no level is certifiable)
    vp = vanderpol()
    P = np.array([[1.5, -0.5], [-0.5, 1.0]])
    F = FunctionLyapunov(
        lambda x, xp: xp.log(1.0 + 1.5 * x[0] ** 2 - x[0] * x[1] + x[1] ** 2), [0.0, 0.0], "log V"
    )

    def vdot(x):
        f = np.array([-x[1], x[0] - (1 - x[0] ** 2) * x[1]])  # reversed-time Van der Pol
        return 2 * (P @ x) @ f / (1 + x @ P @ x)

    assert np.allclose(vp.f(np.array([[0.7, -0.4]]))[0], [0.4, 0.7 - (1 - 0.49) * -0.4])
    ref = _reference(lambda x: np.log(1 + x @ P @ x), vdot, 2)
    assert ref == pytest.approx(np.log(1 + 2.3045), rel=1e-4)  # log(1 + the quadratic level)
    res = roa.level_search(vp, F, method="both")
    assert res.ok and res.level == pytest.approx(ref, rel=1e-5)
    assert validate_level(vp, F, 0.999 * ref, cover_estimate=ray_box).status is Verdict.CERTIFIED
    bad = validate_level(vp, F, 1.001 * ref, cover_estimate=ray_box)
    assert bad.status is Verdict.REFUTED and bad.witness_check["confirmed"]


def _cli(capsys, argv):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_cli_accepts_polynomial_json_and_python_object(tmp_path, capsys):
    spec = tmp_path / "v.json"
    spec.write_text(json.dumps({"monomials": [[2], [4]], "coefficients": [1, 1]}))
    code, out, _ = _cli(
        capsys, ["certify", "--system", ONE_STATE, "--lyapunov", str(spec), "--json"]
    )
    assert code == 0
    data = json.loads(out)
    assert data["status"] == "certified" and data["level_source"] == "sampled"
    assert data["level"] == pytest.approx(0.999 * 2, rel=1e-6)
    py = tmp_path / "v.py"
    py.write_text(
        "from roa.lyapunov import FunctionLyapunov\n"
        "V = FunctionLyapunov(lambda x, xp: x[0] ** 2 + x[0] ** 4, [0.0], 'quartic')\n"
    )
    code, out, _ = _cli(capsys, ["certify", "--system", ONE_STATE, "--lyapunov", f"{py}:V",
                                 "--level", "1.99", "--json"])  # fmt: skip
    assert code == 0 and json.loads(out)["status"] == "certified"
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"monomials": [[2], [4]]}))
    code, out, err = _cli(capsys, ["certify", "--system", ONE_STATE, "--lyapunov", str(bad)])
    assert code != 0 and "coefficients" in out + err


def test_a_polynomial_V_keeps_its_gram_matrix_in_json():
    """A quartic V built from its Gram matrix is proved bounded (``V >= mu |d|^2``) again after a
    JSON round trip; a stored Gram matrix that is not positive definite proves nothing."""
    import json

    from roa.lyapunov import PolynomialLyapunov, from_json
    from roa.proof import gram_cover

    basis = [(1, 0), (0, 1), (2, 0), (0, 2), (1, 1)]
    V = PolynomialLyapunov.from_gram(basis, np.diag([1.0, 1.0, 0.5, 0.5, 0.25]), np.zeros(2))
    W = from_json(json.loads(json.dumps(V.describe())), np.zeros(2))
    assert W.gram is not None and gram_cover(W, 2.0) is not None
    assert (
        from_json({k: v for k, v in V.describe().items() if k != "gram"}, np.zeros(2)).gram is None
    )
    bad = V.describe()  # the same polynomial (x0^2 x1^2: -2 + 2 x 1.125 = 0.25), Q indefinite
    bad["gram"]["Q"][4][4] = -2.0
    bad["gram"]["Q"][2][3] = bad["gram"]["Q"][3][2] = 1.125
    assert gram_cover(from_json(bad, np.zeros(2)), 2.0) is None
    bad["gram"]["Q"] = [[1.0]]
    with pytest.raises(RoaInputError, match="gram Q"):
        from_json(bad, np.zeros(2))


def test_cli_refuses_a_malformed_gram_matrix_naming_it(tmp_path, capsys):
    """``--lyapunov FILE.json`` reads V's Gram matrix too: one of the wrong shape exits 2 naming
    ``gram Q``, without a traceback."""
    bad = tmp_path / "badgram.json"
    bad.write_text(json.dumps({"monomials": [[2, 0], [0, 2]], "coefficients": [1, 1],
                               "gram": {"basis": [[1, 0]], "Q": [[1, 0], [0, 1]]}}))  # fmt: skip
    code, out, err = _cli(capsys, ["certify", "--system", "vanderpol", "--lyapunov", str(bad)])
    assert code == 2 and "gram Q" in out + err and "Traceback" not in out + err
