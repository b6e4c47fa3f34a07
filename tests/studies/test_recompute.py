"""``roa check --recompute`` (reliability issue, finding 6 and Deliver 4): a summary rewritten with
its hash recomputed passes the hash check (the threat model says so), and is caught by running the
experiment again and comparing every stored value. ``results/`` itself is never touched: the
tests work on a copy.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest

from roa.cli import main
from roa.studies._experiment import verify_outputs
from roa.studies._recompute import differences

ROOT = Path(__file__).resolve().parents[2]


def _forge(folder: Path, edit) -> None:
    """Rewrite ``folder/summary.json`` with ``edit`` and record its new hash in the manifest."""
    summary = json.loads((folder / "summary.json").read_text())
    edit(summary)
    data = json.dumps(summary, indent=2).encode()
    (folder / "summary.json").write_bytes(data)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["outputs"]["summary.json"] = hashlib.sha256(data).hexdigest()
    (folder / "manifest.json").write_text(json.dumps(manifest, indent=2))


@pytest.fixture
def results_copy(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)  # the study's experiments/ of the checkout
    results = tmp_path / "results"
    results.mkdir()
    shutil.copytree(ROOT / "results" / "bound", results / "bound")
    shutil.copy(ROOT / "results" / "reference.json", results / "reference.json")
    return results


def test_an_edit_with_its_hash_recomputed_is_caught_by_recomputing(results_copy, capsys):
    ref = str(results_copy / "reference.json")
    assert main(["check", "--reference", ref, "--recompute", "bound", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["failed"] == []

    def edit(summary):  # a claim's verdict and the number behind it
        summary["claims"][0]["verdict"] = "reproduced"
        summary["claims"][0]["ours"] = summary["claims"][0]["ours"] + " 9.99"

    _forge(results_copy / "bound", edit)
    assert verify_outputs(results_copy / "bound") == []  # the hash cannot see a deliberate edit
    assert main(["check", "--reference", ref, "--recompute", "bound"]) == 1
    captured = capsys.readouterr()
    assert "differs  recomputed bound" in captured.out and ".claims[0]" in captured.out
    assert "Traceback" not in captured.err
    assert (ROOT / "results" / "bound" / "summary.json").read_bytes() != (
        results_copy / "bound" / "summary.json"
    ).read_bytes()  # the checkout's results were left alone


def test_recompute_names_unknown_or_missing_experiments(results_copy, capsys):
    ref = str(results_copy / "reference.json")
    assert main(["check", "--reference", ref, "--recompute", "nonexistent"]) == 2
    assert "no experiment 'nonexistent'" in capsys.readouterr().err
    assert main(["check", "--reference", ref, "--recompute", "figure1"]) == 1  # no results here
    assert "error  recomputed figure1" in capsys.readouterr().out
    assert main(["check", "--reference", ref, "--recompute", "bound", "--update"]) == 2


def test_differences_compare_values_not_run_bookkeeping():
    a = {"counts": {"converged": 7565}, "seconds": 1.0, "chunks_resumed": 3, "solver_s": 2.0,
         "ours": "c = 1.125000 (in 3 boxes)", "ok": True, "xs": [1.0, None]}  # fmt: skip
    b = {"counts": {"converged": 7565}, "seconds": 9.0, "chunks_resumed": 0, "solver_s": 5.0,
         "ours": "c = 1.1250000001 (in 3 boxes)", "ok": True, "xs": [1.0 + 1e-9, None]}  # fmt: skip
    assert differences(a, b) == []
    b["counts"]["converged"] = 10091
    b["ours"] = "c = 1.2 (in 3 boxes)"
    b["xs"] = [1.0]
    b["ok"] = False
    b["extra"] = 1
    found = "\n".join(differences(a, b))
    for where in (".counts.converged", ".ours", ".xs", ".ok", ".extra"):
        assert where in found
