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
    modules = ["roa.integration._simulation", "roa.search._levelset", "roa.certification._pipeline", "roa.montecarlo._basin",
               "roa.search._candidate", "roa.lyapunov._polynomial", "roa.lyapunov._function",
               "roa.options", "roa.status", "roa.model._linearisation", "roa.systems"]  # fmt: skip
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


def _stub_names(package: Path) -> list[tuple[str, str]]:
    """(module, name) for each ``from .module import name as name`` of a package's stub."""
    import ast

    tree = ast.parse((package / "__init__.pyi").read_text())
    pairs = []
    for node in tree.body:
        if isinstance(node, ast.ImportFrom):
            assert node.level == 1 and node.module, f"{package}: only `from .module import`"
            for a in node.names:
                assert a.asname == a.name, f"{package}: `{a.name} as {a.name}` re-exports it"
                pairs.append((node.module, a.name))
    return pairs


PACKAGES = sorted(p for p in (ROOT / "roa").iterdir() if (p / "__init__.pyi").exists())


@pytest.mark.parametrize("package", [ROOT / "roa", *PACKAGES], ids=lambda p: p.name)
def test_the_public_names_are_written_once(package):
    """A package's stub lists its public names once: ``__all__`` and the lazy imports are built
    from it, each name resolves to the object its module defines, and no private name is public."""
    import importlib

    dotted = "roa" if package.name == "roa" else f"roa.{package.name}"
    mod = importlib.import_module(dotted)
    pairs = _stub_names(package)
    names = [name for _, name in pairs]
    assert len(names) == len(set(names))
    assert sorted(mod.__all__) == sorted(names)
    for module, name in pairs:
        assert not name.startswith("_"), name
        assert getattr(mod, name) is getattr(importlib.import_module(f"{dotted}.{module}"), name)


def test_every_module_inside_a_package_is_private():
    """The public/private line: inside ``roa``'s packages every module is private (``_name.py``)
    and its public names are those of the package's stub; the built-in systems are the exception
    (system definitions users import, ``roa.systems.vanderpol``). Each package with modules has a
    stub."""
    for package in (p for p in (ROOT / "roa").iterdir() if (p / "__init__.py").exists()):
        if package.name == "systems":
            continue
        public = [f.name for f in package.glob("*.py") if not f.name.startswith("_")]
        assert public == [], f"roa.{package.name}: public modules {public}"
        assert (package / "__init__.pyi").exists(), f"roa.{package.name} has no stub"


def test_the_study_and_the_examples_use_only_the_public_api():
    """The IPC study's code (its tests may reach internals, as every test suite does) and the
    examples import no private module and no private name of ``roa``."""
    import ast

    files = [p for p in (ROOT / "ipc_paper").rglob("*.py") if "tests" not in p.parts]
    files += list((ROOT / "examples").rglob("*.py"))
    bad = []
    for path in files:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "roa":
                names = [a.name for a in node.names]
                if any(p.startswith("_") for p in node.module.split(".")) or any(
                    n.startswith("_") for n in names
                ):
                    bad.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.module} {names}")
            elif isinstance(node, ast.Import):
                bad += [
                    f"{path.relative_to(ROOT)}:{node.lineno} {a.name}"
                    for a in node.names
                    if a.name.startswith("roa.") and "._" in a.name
                ]
    assert bad == []
