"""``roa certify`` with no option picks the route that certifies (AutoValidator)."""

from __future__ import annotations

import json

import pytest

import roa
from roa.cli import main
from roa.status import Verdict

#: The 10-state LyZNet example's optimum for V = |x|^2 / 2 (closed form in
#: tests/test_levelset_scale.py: 2025 / 8).
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
