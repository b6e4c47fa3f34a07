"""paper_repro.md is generated from results/ and never drifts; experiment configs all run."""

import dataclasses
import importlib
from pathlib import Path

import pytest

from ipc_paper import STUDY
from ipc_paper.report import collect, render_report
from roa.errors import RoaInputError
from roa.options import Options
from roa.studies._experiment import (
    VERDICTS,
    check_params,
    experiments_dir,
    list_experiments,
    load_config,
    run_experiment,
)

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = list_experiments(ROOT / "experiments")


def test_committed_report_matches_generated():
    generated = render_report(ROOT / "results", ROOT / "paper_repro.md")
    committed = (ROOT / "paper_repro.md").read_text()
    assert committed == generated, "paper_repro.md is stale: run `roa report` and commit it"


def test_every_claim_is_well_formed_and_its_evidence_exists():
    claims, _ = collect(ROOT / "results")
    assert claims, "no claims found under results/"
    ids = [c["id"] for c in claims]
    assert len(ids) == len(set(ids)), "duplicate claim ids"
    for c in claims:
        assert c["verdict"] in VERDICTS
        assert (ROOT / c["evidence"]).is_file(), c["evidence"]


def test_packaged_experiments_are_the_repository_ones():
    packaged = STUDY.experiments
    assert packaged == ROOT / "ipc_paper" / "experiments"
    assert sorted(p.name for p in packaged.glob("*.toml")) == sorted(p.name for p in CONFIGS)
    for p in CONFIGS:
        assert (packaged / p.name).read_text() == p.read_text(), p.name
    assert experiments_dir(STUDY).is_dir()


def test_bad_config_is_rejected(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('runner = "no such runner"\n')
    with pytest.raises(ValueError, match="runner must be 'module:function'"):
        load_config(bad)
    bad.write_text('runner = "ipc_paper.figures:run_figure1"\nparms = {}\n')
    with pytest.raises(ValueError, match="unknown keys"):
        load_config(bad)


def test_config_cannot_name_code_outside_a_study(tmp_path):
    """A config is data: its runner must be a function of a registered study's package."""
    bad = tmp_path / "evil.toml"
    bad.write_text('runner = "os:system"\n[params]\n')
    with pytest.raises(ValueError, match="not in a registered study's package"):
        load_config(bad)


def test_missing_dependency_is_a_clear_error(tmp_path):
    dependent = [p for p in CONFIGS if load_config(p).get("depends")]
    assert dependent, "no config declares depends"
    with pytest.raises(ValueError, match="depends on"):
        run_experiment(dependent[0], results=tmp_path, quick=True)


def test_unknown_params_are_rejected_before_work(tmp_path):
    cfg = tmp_path / "typo.toml"
    cfg.write_text(
        'runner = "ipc_paper.figures:run_figure1"\n[params]\nt_finall = 3.0\n[params.initial_conditions]\np1 = [0, 0, 0.1, 0]\n'
    )
    with pytest.raises(
        RoaInputError,
        match=r"^typo: \[params\]: unknown option\(s\) \['t_finall'\] for Figure1Params; "
        r"allowed: initial_conditions, t_final, .*extra_theta0$",
    ):
        run_experiment(cfg, results=tmp_path / "r")
    assert not (tmp_path / "r" / "typo").exists()


def test_params_are_checked_by_the_runner_dataclass(tmp_path):
    """Missing required keys and bad values are rejected, naming the experiment, before any work."""
    cfg = tmp_path / "noics.toml"
    cfg.write_text('runner = "ipc_paper.figures:run_figure1"\n[params]\nt_final = 3.0\n')
    with pytest.raises(
        RoaInputError, match=r"^noics: \[params\]: missing .*\['initial_conditions'\]"
    ):
        run_experiment(cfg, results=tmp_path / "r")
    cfg = tmp_path / "badtol.toml"
    cfg.write_text('runner = "ipc_paper.basins:run_global"\n[params]\nsamples = 10\n'
                   'half_widths = [1.0]\nrtol = -1.0\n')  # fmt: skip
    with pytest.raises(RoaInputError, match=r"^badtol: \[params\]: rtol must be in"):
        run_experiment(cfg, results=tmp_path / "r")
    assert not (tmp_path / "r").exists()


def _runner(cfg):
    module, func = cfg["runner"].split(":")
    return getattr(importlib.import_module(module), func)


@pytest.mark.parametrize("config", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_runner_params_class_accepts_the_config_keys(config):
    """Each runner declares a frozen Options dataclass with every key its configs use; the
    config's [params], with and without [quick], build into it and fill in every default."""
    cfg = load_config(config)
    runner = _runner(cfg)
    declared = runner.params
    cfg_params, cfg_quick = cfg.get("params", {}), cfg.get("quick", {})
    assert isinstance(declared, type) and issubclass(declared, Options)
    assert dataclasses.is_dataclass(declared) and declared.__dataclass_params__.frozen
    fields = {f.name for f in dataclasses.fields(declared)}
    assert set(cfg_params) <= fields, f"keys not accepted: {set(cfg_params) - fields}"
    assert set(cfg_quick) <= fields, f"keys not accepted: {set(cfg_quick) - fields}"
    for quick in (False, True):
        params = {**cfg_params, **(cfg_quick if quick else {})}
        built = check_params(cfg["name"], runner, params)
        assert set(built) == fields
        for key, value in params.items():
            expected = tuple(value) if isinstance(value, list) else value
            assert built[key] == expected, key


def test_every_runner_declares_a_params_class():
    """All runners of the committed configs use @accepts(Class)."""
    for config in CONFIGS:
        cfg = load_config(config)
        declared = _runner(cfg).params
        assert isinstance(declared, type) and issubclass(declared, Options), cfg["runner"]


def test_quick_reproduce_leaves_the_committed_results_alone(tmp_path, monkeypatch):
    from roa.cli import main

    configs = tmp_path / "configs"
    configs.mkdir()
    (configs / "figure1.toml").write_text((ROOT / "experiments" / "figure1.toml").read_text())
    monkeypatch.chdir(tmp_path)
    assert main(["reproduce", "--quick", "--experiments", str(configs)]) == 0
    assert (tmp_path / "results-quick" / "figure1" / "summary.json").is_file()
    assert (tmp_path / "results-quick" / "paper_repro.md").is_file()
    assert not (tmp_path / "results").exists() and not (tmp_path / "paper_repro.md").exists()


def test_figure2_verdicts_follow_what_was_run(tmp_path):
    """Issue 12 item 5: a copy of figure2 with another setup must not report 'reproduced'."""
    cfg = tmp_path / "configs" / "figure2.toml"
    cfg.parent.mkdir()
    cfg.write_text(
        'runner = "ipc_paper.figures:run_figure2"\n[params]\nt_final = 2.0\n'
        "initial_condition = [0.0, 0.0, 0.05, 0.0]\nn_points = 201\n"
    )
    summary = run_experiment(cfg, results=tmp_path / "r", quick=True)
    verdicts = {c["id"]: c["verdict"] for c in summary["claims"]}
    assert verdicts == {"F3": "not reproduced", "F4": "not reproduced"}
    assert all("not the paper's setup" in c["ours"] for c in summary["claims"])


def test_tampered_outputs_are_never_served(tmp_path, monkeypatch, capsys):
    """Issue 12 item 4: a flipped verdict in a summary is detected: the cache reruns the experiment
    and `roa report` refuses to render it."""
    import json

    from roa.cli import main
    from roa.studies._experiment import verify_outputs

    results = tmp_path / "r"
    cfg = ROOT / "experiments" / "bound.toml"
    run_experiment(cfg, results=results, quick=True)
    assert verify_outputs(results / "bound") == []
    path = results / "bound" / "summary.json"
    data = json.loads(path.read_text())
    original = data["claims"][0]["verdict"]
    data["claims"][0]["verdict"] = "reproduced" if original != "reproduced" else "erratum"
    path.write_text(json.dumps(data))
    assert verify_outputs(results / "bound") == [
        f"{results / 'bound'}/summary.json was modified after its run"
    ]
    assert main(["report", "--results", str(results), "--out", str(tmp_path / "rep.md")]) == 1
    assert "modified after its run" in capsys.readouterr().err
    again = run_experiment(cfg, results=results, quick=True)  # not served from the cache
    assert again["cached"] is False and again["claims"][0]["verdict"] == original


def test_a_foreign_config_cannot_overwrite_results(tmp_path):
    """Issue 12 item 2: a different config with the same name refuses to replace the results."""
    results = tmp_path / "r"
    run_experiment(ROOT / "experiments" / "bound.toml", results=results, quick=True)
    other = tmp_path / "elsewhere" / "bound.toml"
    other.parent.mkdir()
    other.write_text(
        (ROOT / "experiments" / "bound.toml").read_text().replace("seed = 0", "seed = 1")
    )
    with pytest.raises(ValueError, match="holds the results of another config"):
        run_experiment(other, results=results, quick=True)


def test_certify_params_name_the_bad_field():
    from ipc_paper.certify_runs import CertifyParams

    with pytest.raises(RoaInputError, match=r"CertifyParams\.cases .*ipc_optimised"):
        CertifyParams(cases=("ipc_ball",))
    with pytest.raises(RoaInputError, match=r"CertifyParams\.n_jobs .*>= 0"):
        CertifyParams(n_jobs=-1)


def test_resumable_chunks_are_scratch_not_results(tmp_path):
    """Chunk files in any chunks/ folder (git-ignored, e.g. results/basin_box/reference/chunks)
    are not outputs: a fresh clone without them verifies, a changed summary still does not."""
    from roa.studies._experiment import output_hashes, verify_outputs

    out = tmp_path / "exp"
    (out / "reference" / "chunks").mkdir(parents=True)
    (out / "summary.json").write_text("{}")
    (out / "reference" / "chunks" / "chunk_0.npz").write_bytes(b"x")
    (out / "reference" / "data.json").write_text("[]")
    hashes = output_hashes(out)
    assert sorted(hashes) == ["reference/data.json", "summary.json"]
    old = {**hashes, "reference/chunks/chunk_4096.npz": "0" * 64}  # recorded by older manifests
    assert verify_outputs(out, {"outputs": old}) == []
    (out / "summary.json").write_text('{"x": 1}')
    assert verify_outputs(out, {"outputs": old}) == [
        f"{out}/summary.json was modified after its run"
    ]


def test_a_report_with_an_experiment_missing_fails_naming_it(tmp_path, capsys):
    """Reliability issue item 5: deleting an experiment's folder must not drop its claims from the
    report silently (33 of 37 claims, exit 0, before)."""
    import shutil

    from roa.cli import main

    results = tmp_path / "r"
    shutil.copytree(ROOT / "results", results)
    shutil.rmtree(results / "figure2")
    assert main(["report", "--results", str(results), "--out", str(tmp_path / "rep.md")]) == 1
    err = capsys.readouterr().err
    assert "figure2" in err and "no results" in err
    assert not (tmp_path / "rep.md").exists()
