"""``roa certify`` command line: option checks, level-search statuses, the SOS safety factor.

Reference: time-reversed Van der Pol with P_BENCHMARK has largest level rho = 2.3045 (Drake /
Underactuated Robotics course notes). The toy systems below have closed-form answers: for
x' = -x and V = |x|^2, V' = -2 |x|^2 < 0 everywhere (no finite largest level); for the saddle
x' = (x1, -x2), the linearisation is unstable (no region of attraction: an input error).
"""

from __future__ import annotations

import json

import pytest

from roa.cli import main
from roa.systems.vanderpol import RHO_BENCHMARK

TOY = """
from roa import System

DECAY = System(name="decay", field=lambda t, x, xp: (-x[0], -x[1]), equilibrium=(0.0, 0.0),
               state_names=("x1", "x2"))
SADDLE = System(name="saddle", field=lambda t, x, xp: (x[0], -x[1]), equilibrium=(0.0, 0.0),
                state_names=("x1", "x2"))
LYAPUNOV_P = [[1.0, 0.0], [0.0, 1.0]]
"""


@pytest.fixture
def toy(tmp_path):
    path = tmp_path / "toy.py"
    path.write_text(TOY)
    return str(path)


def _run(capsys, argv):
    code = main(argv)
    cap = capsys.readouterr()
    return code, cap


def test_sos_with_level_is_rejected(capsys):
    code, cap = _run(
        capsys, ["certify", "--system", "vanderpol", "--method", "sos", "--level", "2"]
    )
    assert code == 2
    assert "--method sos with --level" in cap.err and "--method interval" in cap.err


def test_ipc_flat_carries_the_papers_v(capsys):
    """--system ipc-flat (the IPC study's system) carries V (3.11); its largest level is 2.28284
    (roa check), so 2.3 lies above it and must be refuted with a witness."""
    code, cap = _run(capsys, ["certify", "--system", "ipc-flat", "--level", "2.3", "--json"])
    out = json.loads(cap.out)
    assert code == 1 and out["system"] == "ipc_flat" and out["status"] == "refuted"
    assert out["witness_check"]["confirmed"] is True


def test_unbounded_level_search_is_a_clear_status(capsys, toy):
    argv = ["certify", "--system", f"{toy}:DECAY", "--method", "interval", "--json"]
    code, cap = _run(capsys, argv)
    out = json.loads(cap.out)
    assert code == 1
    assert out["status"] == "inconclusive" and out["level"] is None
    assert out["level_search"]["status"] == "unbounded"
    assert "V' < 0 may hold on every sublevel set" in out["message"]


def test_unstable_linearisation_is_a_clear_error(capsys, toy):
    """The saddle x' = (x1, -x2) has an eigenvalue +1: no region of attraction (exit 2, one line)."""
    argv = ["certify", "--system", f"{toy}:SADDLE", "--method", "interval", "--json"]
    code, cap = _run(capsys, argv)
    assert code == 2 and cap.out == ""
    assert "is unstable (eigenvalue 1 with positive real part)" in cap.err


def test_sos_level_validated_with_safety_factor(capsys):
    code, cap = _run(capsys, ["certify", "--system", "vanderpol", "--json"])
    out = json.loads(cap.out)
    assert code == 0 and out["status"] == "certified" and out["method"] == "interval"
    assert out["level_source"] == "sos" and out["safety_factor"] == pytest.approx(1 - 1e-4)
    assert out["level"] == pytest.approx(out["safety_factor"] * out["sos"]["level"], rel=1e-12)
    assert out["sos"]["level"] == pytest.approx(RHO_BENCHMARK, abs=1e-3)


def test_help_describes_every_option_with_its_default(capsys):
    with pytest.raises(SystemExit):
        main(["certify", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "Exit code 0 iff certified" in text
    for opt, default in (
        ("--system", "the system (required): a built-in by name (vanderpol, cubic-map; study ipc:"),
        ("--lyapunov", "default: the system's own"),
        ("--level", "default: maximise"),
        ("--maximise", "(default: what happens without --level)"),
        ("--method", "Default: both"),
        ("--max-boxes", "default 3000000"),
    ):
        assert opt in text and default in text, (opt, default)
