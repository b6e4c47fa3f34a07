"""Regression values in results/reference.json: `roa check` must pass."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ipc_paper.reference import REGISTRY
from roa.cli import main
from roa.studies import _reference as reference

REF = Path(__file__).resolve().parents[2] / "results" / "reference.json"


def test_every_registered_value_is_stored_and_reproduces():
    rows = reference.check(REGISTRY, path=REF)
    bad = [r for r in rows if r["status"] != "ok"]
    assert not bad, bad


def test_check_flags_drift_and_missing(tmp_path, capsys):
    stored = json.loads(REF.read_text())
    key = "ipc.bound.corrected.c_tilde"
    stored[key]["value"] = 2.25  # the paper's number: must be reported as drift
    p = tmp_path / "ref.json"
    p.write_text(json.dumps({key: stored[key]}))
    assert main(["check", "--only", key, "--reference", str(p)]) == 1
    assert key in capsys.readouterr().err
    assert main(["check", "--only", "vanderpol.level.casadi", "--reference", str(p)]) == 1
    assert "missing" in capsys.readouterr().out


def test_unknown_key():
    with pytest.raises(ValueError, match="unknown reference key"):
        reference.check(REGISTRY, ["nope"], path=REF)


def test_check_outside_a_checkout_says_where_it_looked(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["check", "--only", "ipc.bound.corrected.c_tilde"]) == 1
    err = capsys.readouterr().err
    assert "reference file" in err and str(tmp_path) in err and "does not exist" in err
