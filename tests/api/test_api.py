"""The public API: one call per analysis, typed results, and a CLI that is a thin shell over it.

Each CLI command's ``--json`` output must equal ``result.to_dict()`` of the same API call (timings
excepted). References: Van der Pol with the benchmark P has largest level 2.3045 (Drake course
notes); 2.30 is certified and 2.31 refuted (interval validation, 50-digit witness).
"""

from __future__ import annotations

import ast
import doctest
import importlib
import json
import re
from pathlib import Path

import numpy as np
import pytest

import roa
from roa.cli import main
from roa.io import to_json
from roa.systems.vanderpol import vanderpol

ROOT = Path(__file__).resolve().parents[2]


def _strip(obj):
    """Drop timing keys (they differ between two runs of the same computation)."""
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if k not in ("seconds",)}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    return obj


def _cli(capsys, argv):
    code = main(argv)
    return code, json.loads(capsys.readouterr().out)


def test_simulate_cli_is_the_api(capsys):
    code, out = _cli(capsys, ["simulate", "--system", "vanderpol", "--x0", "0.5,0.5", "--json"])
    res = roa.simulate(vanderpol(), [0.5, 0.5])
    assert code == 0 and _strip(out) == _strip(json.loads(to_json(res.to_dict())))
    assert res.status is roa.RunStatus.CONVERGED


def test_khalil_cli_is_the_api(capsys):
    argv = ["khalil", "--system", "vanderpol", "--shape", "level", "--directions", "2000", "--json"]
    code, out = _cli(capsys, argv)
    res = roa.level_search(
        vanderpol(), shape="level", sampled=roa.SampledOptions(n_directions=2000)
    )
    assert code == 0 and _strip(out) == _strip(json.loads(to_json(res.to_dict())))
    assert res.status is roa.LevelStatus.AGREE and res.level == pytest.approx(2.3045, abs=1e-3)


def test_certify_cli_is_the_api(capsys):
    code, out = _cli(capsys, ["certify", "--system", "vanderpol", "--level", "2.31", "--json"])
    res = roa.certify(vanderpol(), level=2.31, validator="auto")  # the CLI's default route
    assert code == 1 and _strip(out) == _strip(json.loads(to_json(res.to_dict())))
    assert res.status is roa.Verdict.REFUTED and res.witness is not None


def test_basin_cli_is_the_api(capsys):
    argv = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "7x6", "--box",
            "x1=-3:3,x2=-3:3", "--jobs", "1", "--json"]  # fmt: skip
    code, out = _cli(capsys, argv)
    system = vanderpol()
    grid = roa.grid_slice(system, ("x1", "x2"), [(-3, 3), (-3, 3)], (7, 6))
    res = roa.basin(system, grid, run=roa.RunOptions(n_jobs=1))
    api = _strip(res.to_dict())
    assert code == 0 and {k: v for k, v in _strip(out).items() if k in api} == api
    assert sum(res.counts.values()) == res.n == 42


def test_results_are_frozen_and_statuses_explain_themselves():
    res = roa.certify(vanderpol(), level=2.30)
    with pytest.raises(AttributeError):
        res.level = 3.0  # type: ignore[misc]
    for enum in (roa.RunStatus, roa.LevelStatus, roa.Verdict, roa.SosStatus, roa.BasinStatus):
        for member in enum:
            assert isinstance(member.meaning, str) and len(member.meaning) > 10, member


def test_certify_keeps_a_refute_just_above_check():
    """Certify 0.999 x the Van der Pol optimum and refute 1.001 x it (both by interval B&B)."""
    search = roa.level_search(vanderpol(), method="casadi")
    cert = roa.certify(vanderpol(), candidate=search, check_above=1.001)
    assert cert.status is roa.Verdict.CERTIFIED
    assert cert.level == pytest.approx(0.999 * search.level, rel=1e-15)
    assert cert.above is not None and cert.above.status is roa.Verdict.REFUTED


def test_certify_sos_alone_is_never_certified():
    cert = roa.certify(vanderpol(), method="sos")
    assert cert.status is roa.Verdict.INCONCLUSIVE and cert.method == "sos"
    assert cert.level == pytest.approx(2.3045, abs=1e-3)


def test_input_errors_name_the_argument():
    with pytest.raises(roa.RoaInputError, match="level must be a finite number > 0"):
        roa.certify(vanderpol(), level=-1.0)
    with pytest.raises(roa.RoaInputError, match="method must be one of"):
        roa.level_search(vanderpol(), method="grid")
    with pytest.raises(roa.RoaInputError, match=r"unknown option\(s\) \['n_dirs'\]"):
        roa.SampledOptions.from_mapping({"n_dirs": 3})
    with pytest.raises(roa.RoaInputError, match="IntervalOptions.max_boxes must be in"):
        roa.IntervalOptions(max_boxes=0)
    with pytest.raises(roa.RoaInputError, match="RunOptions.n_jobs must be in"):
        roa.RunOptions(n_jobs=10**6)


def test_default_lyapunov_solves_the_lyapunov_equation():
    system = roa.System("lin", lambda t, x, xp: (-x[0] + x[1], -2 * x[1]), (0.0, 0.0), ("a", "b"))
    P = roa.default_lyapunov(system).P
    A = np.array([[-1.0, 1.0], [0.0, -2.0]])
    assert np.allclose(A.T @ P + P @ A, -np.eye(2), atol=1e-12)


def test_every_public_name_is_documented_with_an_example():
    """Each public call has a numpydoc docstring whose Examples section runs (doctest)."""
    for name in ("simulate", "level_search", "certify", "basin", "default_lyapunov"):
        doc = getattr(roa, name).__doc__
        assert "Parameters" in doc or name == "default_lyapunov", name
        assert "Examples" in doc and ">>>" in doc, name
    modules = ["roa.integration.simulation", "roa.search.levelset", "roa.certification.pipeline", "roa.montecarlo.basin",
               "roa.search.candidate", "roa.lyapunov.polynomial", "roa.lyapunov.function",
               "roa.options", "roa.status", "roa.model.linearisation", "roa.systems"]  # fmt: skip
    for mod in modules:
        failed, tried = doctest.testmod(importlib.import_module(mod), optionflags=doctest.ELLIPSIS)
        assert failed == 0, mod
        assert tried > 0, mod


def test_readme_python_section_runs():
    """The README's "From Python" section, run as written."""
    text = (ROOT / "README.md").read_text()
    section = text.split("## From Python", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert blocks, "no python block in the README's From Python section"
    namespace: dict = {}
    exec(compile("\n".join(blocks), "README.md", "exec"), namespace)  # noqa: S102
    assert namespace["cert"].status is roa.Verdict.CERTIFIED


def _docstrings(tree: ast.AST) -> set[int]:
    """``id`` of the docstring nodes of a module and its classes and functions."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                out.add(id(body[0].value))
    return out


def test_library_does_not_import_the_study():
    """No module of roa/ imports ipc_paper (statically, or by a "module:attr" string such as a
    built-in system's factory): the library reaches a study only through roa.studies."""
    for path in sorted((ROOT / "roa").rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        docs = _docstrings(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            elif isinstance(node, ast.Constant) and isinstance(node.value, str):
                names = [] if id(node) in docs else [node.value]
            else:
                continue
            for name in names:
                assert not name.startswith("ipc_paper"), f"{path}:{node.lineno}: {name}"
    assert not list((ROOT / "roa" / "systems").glob("ipc*/*.py"))  # no IPC module in the library


def test_library_does_not_special_case_the_ipc():
    """No "ipc" special case in the commands, top-level modules or the library's built-ins; the
    IPC's names come from its study (roa.studies), after the library's own."""
    for path in [*(ROOT / "roa" / "commands").glob("*.py"), *(ROOT / "roa").glob("*.py")]:
        assert '"ipc' not in path.read_text(), path
    from roa.systems import BUILTIN, builtin_names

    assert set(BUILTIN) == {"vanderpol", "cubic-map"}
    assert builtin_names() == {
        "vanderpol": None,
        "cubic-map": None,
        "ipc": "ipc",
        "ipc-flat": "ipc",
        "ipc-flat-uncertain": "ipc",
    }


def test_cli_reports_each_long_step_on_stderr_and_the_library_stays_silent(capsys):
    """Issue 11: a line per step with its time from the CLI (no bars outside a terminal)."""
    assert main(["certify", "--system", "vanderpol", "--level", "2.3", "--json"]) == 0
    err = capsys.readouterr().err
    assert "interval validation of level 2.3:" in err and " s\n" in err
    from roa import progress

    progress.enable(False)
    roa.certify(vanderpol(), level=2.3)
    assert capsys.readouterr().err == ""


def test_the_public_names_are_written_once():
    """``PUBLIC`` gives ``__all__`` and the lazy table; the type-checking imports list the same
    (module, name) pairs, and each name is defined by the module it is listed under."""
    import ast
    import importlib

    tree = ast.parse((ROOT / "roa" / "__init__.py").read_text())
    block = next(
        n
        for n in tree.body
        if isinstance(n, ast.If) and getattr(n.test, "id", "") == "TYPE_CHECKING"
    )
    pairs = {(imp.module, a.name) for imp in block.body for a in imp.names}
    listed = {(module, name) for module, names in roa.PUBLIC.items() for name in names}
    assert pairs == listed
    assert sorted(roa.__all__) == sorted(name for _, name in listed)
    for module, name in listed:
        assert getattr(importlib.import_module(module), name) is getattr(roa, name), name
