"""The README tutorial, run on the example user system (examples/vanderpol_system.py).

Reference: time-reversed Van der Pol with P = [[1.5, -0.5], [-0.5, 1]] has largest level
rho = 2.3045 (Drake / Underactuated Robotics course notes; LyZNet's dReal bisection 2.3042).
"""

import json
from pathlib import Path

import pytest

from roa.cli import main

SPEC = str(Path(__file__).resolve().parents[2] / "examples" / "vanderpol_system.py") + ":SYSTEM"


def _json(capsys, argv, code=0):
    assert main(argv) == code
    return json.loads(capsys.readouterr().out)


def test_tutorial_level(capsys):
    out = _json(capsys, ["khalil", "--system", SPEC, "--shape", "level", "--json"])
    assert out["value"] == pytest.approx(2.3045, abs=1e-3)


def test_tutorial_certificate(capsys):
    out = _json(
        capsys, ["certify", "--system", SPEC, "--level", "2.30", "--method", "interval", "--json"]
    )
    assert out["status"] == "certified"
    argv = ["certify", "--system", SPEC, "--level", "2.31", "--method", "interval", "--json"]
    out = _json(capsys, argv, code=1)  # a refuted level exits 1
    assert out["status"] == "refuted" and out["witness"] is not None


def test_tutorial_basin_map(capsys, tmp_path):
    png = tmp_path / "vdp.png"
    argv = ["basin", "--system", SPEC, "--slice", "x1,x2", "--grid", "40x40", "--box", "x1=-3:3,x2=-3:3",
            "--lyapunov-level", "2.30", "--plot", str(png), "--json"]  # fmt: skip
    out = _json(capsys, argv)
    assert png.is_file()
    assert out["counts"]["converged"] + out["counts"]["diverged"] == out["n"] == 1600
    (reg,) = out["regions"]
    assert {k: reg[k] for k in ("name", "level", "status")} == {
        "name": "V <= 2.3 (my-vanderpol V)",
        "level": 2.3,
        "status": "certified",
    }
    assert reg["V"] == {"P": [[1.5, -0.5], [-0.5, 1.0]]} and reg["slice"]["all_converged"]


def test_tutorial_runs_on_a_system_without_lyapunov_p(capsys):
    """The tutorial's commands on the damped pendulum (no LYAPUNOV_P: A'P + PA = -I is used).

    Reference: P solves A'P + PA = -I for A = [[0, 1], [-1, -1]]; the largest level of V = x'Px
    found independently by scipy (tests/commands/test_user_systems.py) is certified just below and
    refuted just above by the same commands."""
    spec = (
        str(Path(__file__).resolve().parents[2] / "examples" / "systems" / "pendulum.py")
        + ":SYSTEM"
    )
    out = _json(capsys, ["khalil", "--system", spec, "--shape", "level", "--json"])
    assert out["status"] == "agree" and out["level"] > 0
    level = out["level"]
    out = _json(capsys, ["certify", "--system", spec, "--level", str(0.999 * level), "--json"])
    assert out["status"] == "certified" and out["lyapunov"] == "P from A'P + PA = -I"
    out = _json(
        capsys, ["certify", "--system", spec, "--level", str(1.001 * level), "--json"], code=1
    )
    assert out["status"] == "refuted"
