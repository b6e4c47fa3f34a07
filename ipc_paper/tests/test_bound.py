"""The analytic bound (3.13)-(3.14), printed vs corrected, and the bound/khalil CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ipc_paper.bound import (
    KAPPA,
    check_against_phi,
    corrected_bound,
    kappa_numeric,
    paper_bound,
    rhs_314,
)
from roa.cli import main


def test_kappa_closed_form():
    # phi0(w) = w (1+w^2)^(-3/2): phi0' = 0 at w^2 = 1/2, phi0 = (1/sqrt 2)(2/3)^(3/2) = 2/3^(3/2)
    k = kappa_numeric()
    assert k["kappa"] == pytest.approx(2 / 3**1.5, rel=1e-12)
    assert k["w_at_max"] == pytest.approx(np.sqrt(0.5), abs=1e-6)


def test_bound_numbers_in_closed_form():
    p, c = paper_bound(), corrected_bound()
    # paper: alpha = 2/(3 kappa) = sqrt 3, c~ = alpha/(2 kappa) = 9/4
    assert p["alpha_max"] == pytest.approx(np.sqrt(3), rel=1e-14)
    assert p["c_tilde"] == pytest.approx(9 / 4, rel=1e-14)
    # corrected: alpha = 1/(3 kappa) = sqrt(3)/2, c~ = 9/8; V-level 3c~/4, ball 2/3 of it
    assert c["alpha_max"] == pytest.approx(np.sqrt(3) / 2, rel=1e-14)
    assert c["c_tilde"] == pytest.approx(9 / 8, rel=1e-14)
    assert c["V_level_in_slab"] == pytest.approx(27 / 32, rel=1e-14)
    assert c["ball_in_V_level"] == pytest.approx(9 / 16, rel=1e-14)
    assert p["V_level_in_slab"] == pytest.approx(27 / 16, rel=1e-14)


def test_corrected_314_holds_printed_fails():
    chk = check_against_phi(50000, 1)
    assert chk["corrected"]["holds"]
    assert not chk["paper"]["holds"] and chk["paper"]["max_Phi_minus_rhs"] > 0.1
    assert chk["max_Phi_over_qq_on_slab"] < 0


def test_corrected_314_is_tight_in_alpha():
    # with alpha slightly above sqrt(3)/2 the q1 coefficient turns positive: the bound stops being
    # negative along q = (q1, 0, 0, 0) even though Phi = -q1^2 there (the inequality still holds)
    q = np.array([[1.0, 0, 0, 0]])
    assert rhs_314(q, 1 / (3 * KAPPA), printed=False)[0] == pytest.approx(0.0, abs=1e-15)
    assert rhs_314(q, 1.01 / (3 * KAPPA), printed=False)[0] > 0


def test_cli_bound_json(capsys):
    assert main(["study", "ipc", "bound", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["paper"]["c_tilde"] == pytest.approx(2.25)
    assert out["corrected"]["c_tilde"] == pytest.approx(1.125)


def test_cli_khalil_json_vanderpol(capsys):
    code = main(
        ["khalil", "--system", "vanderpol", "--shape", "level", "--json", "--directions", "2000"]
    )
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    assert set(out) >= {"value", "witness", "method", "shape", "per_method"}
    assert out["value"] == pytest.approx(2.3045, abs=1e-3)


def test_cli_khalil_user_file(tmp_path, capsys):
    f = tmp_path / "mysys.py"
    f.write_text(
        "from roa.model._system import System\n"
        "def field(t, x, xp):\n    return (-x[0] + x[0]**3, -x[1])\n"
        "SYS = System('cubic', field, (0.0, 0.0), ('a', 'b'))\n"
    )
    # no LYAPUNOV_P: A = -I, A'P + PA = -I gives P = I/2; ball shape: c* = 1 (closed form)
    code = main(["khalil", "--system", f"{f}:SYS", "--method", "casadi", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    assert np.allclose(out["P"], 0.5 * np.eye(2))
    assert out["value"] == pytest.approx(1.0, rel=1e-9)


def test_cli_errors(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["khalil", "--shape", "cube"])
    assert exc.value.code == 2
    with pytest.raises(SystemExit) as exc:
        main(["study", "ipc", "bound", "--nonsense"])
    assert exc.value.code == 2
    assert main(["khalil", "--system", "nosuch"]) == 2
    assert "not a built-in system" in capsys.readouterr().err
    assert main(["khalil", "--system", "vanderpol", "--directions", "3"]) == 2
    assert "--directions" in capsys.readouterr().err
