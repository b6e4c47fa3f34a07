"""``roa certify`` with no option picks the route that certifies (AutoValidator)."""

from __future__ import annotations

import json

import pytest

import roa
from roa.cli import main
from roa.status import Verdict

#: The 10-state LyZNet example's optimum for V = |x|^2 / 2 (closed form in
#: tests/search/test_levelset_scale.py: 2025 / 8).
LYZNET_OPTIMUM = 2025 / 8


def test_ten_states_certified_by_the_cli_without_options(capsys):
    """The branch and bound cannot decide 10 states; the default route proves the level by the
    exact SOS certificate (decoupled blocks), below the closed-form optimum."""
    rc = main(["certify", "--system", "examples/systems/lyznet_10d.py:SYSTEM", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and out["status"] == "certified" and out["method"] == "sos-exact"
    assert 0.99 * LYZNET_OPTIMUM <= out["level"] <= LYZNET_OPTIMUM


def test_small_systems_keep_the_branch_and_bound(capsys):
    """Two states: the branch and bound decides (and refutes above); the method names it."""
    rc = main(["certify", "--system", "vanderpol", "--check-above", "1.001", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and out["method"] == "interval" and out["above"]["status"] == "refuted"
    assert out["level"] <= 2.3045


def test_validator_names_are_checked():
    from roa.systems.vanderpol import vanderpol

    with pytest.raises(roa.RoaInputError, match="validator must be one of"):
        roa.certify(vanderpol(), level=2.0, validator="magic")
    cert = roa.certify(vanderpol(), level=2.0, validator="auto")
    assert cert.status is Verdict.CERTIFIED and cert.method == "interval"
    assert roa.certify(vanderpol(), level=2.0, validator="sos").method == "sos-exact"


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--validator", "magic"], "invalid choice: 'magic'"),
        (["--time-limit", "0"], "--time-limit must be a number of seconds in (0, 1e9]"),
        (["--time-limit", "abc"], "--time-limit: 'abc' is not a number"),
    ],
)
def test_bad_route_options_exit_2_naming_them(args, words, capsys):
    try:
        rc = main(["certify", "--system", "vanderpol", "--level", "2.0", *args])
    except SystemExit as exc:  # argparse's own errors
        rc = exc.code
    assert rc == 2 and words in capsys.readouterr().err


def test_robust_experiment_parameters_are_checked():
    from ipc_paper.robust import RobustParams

    for kw, words in [({"delta_low": 1.5}, "delta_low < 1 < delta_high"),
                      ({"safety": 1.5}, "safety must be in"),
                      ({"sector_k": (0.5,)}, "sector_k must be in"),
                      ({"cases": ("nope",)}, "unknown cases")]:  # fmt: skip
        with pytest.raises(roa.RoaInputError, match=words):
            RobustParams(**kw)
