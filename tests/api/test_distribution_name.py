"""The distribution name (issue 37, item 1): "roa" on PyPI is another project, so this package is
distributed as ``roa-verify`` (import name ``roa``) and every install line names a local path."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import roa
from roa import io

ROOT = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def _install_lines() -> list[tuple[str, str]]:
    files = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.rst"))]
    for sub in ("roa", "examples", "benchmarks"):
        files += sorted((ROOT / sub).rglob("*.py"))
    out = []
    for f in files:
        text = f.read_text()
        # a README line may break inside a backtick span: join the wrapped lines first
        for m in re.finditer(r"pip\s+install\s+([^`\n)]*(?:\n[^`\n)]*)?)", text):
            out.append((f.name, " ".join(m.group(1).split())))
    return out


def test_distribution_name_is_not_the_pypi_roa():
    name = PYPROJECT["project"]["name"]
    assert name == io.DISTRIBUTION == "roa-verify"
    assert PYPROJECT["project"]["version"] == roa.__version__
    # the command keeps its name
    assert PYPROJECT["project"]["scripts"]["roa"] == "roa.cli:main"


def test_every_install_line_installs_from_a_path_or_a_third_party_package():
    lines = _install_lines()
    assert len(lines) >= 8  # README, docs/index.rst, docs/models.rst, examples, benchmarks, roa
    extras = set(PYPROJECT["project"]["optional-dependencies"])
    third_party = {"control", "dask[distributed]", "'dask[distributed]'", "onnx", "torch"}
    for where, args in lines:
        first = args.split("&&")[0].split("#")[0].strip()
        tokens = [t.strip("'\"") for t in first.split() if t not in ("-e", "--quiet")]
        target = tokens[0] if tokens else ""
        target = target.rstrip(".,;:'\"") or target
        assert not re.match(r"roa(\[|$)", target), (where, args)
        if target.startswith("."):
            m = re.fullmatch(r"\.(?:\[(\w+)\])?", target)
            assert m, (where, args)
            assert m.group(1) is None or m.group(1) in extras, (where, args)
        else:
            assert target in third_party or target.startswith("-"), (where, args)


def test_package_versions_looks_up_this_distribution_only(monkeypatch):
    asked: list[str] = []

    def version(name: str) -> str:
        asked.append(name)
        if name == "roa":  # what the PyPI package would answer
            return "1.8"
        if name == io.DISTRIBUTION:
            return "0.1.0"
        raise io.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(io.metadata, "version", version)
    versions = io.package_versions()
    assert io.DISTRIBUTION in asked and "roa" not in asked
    assert versions["roa"] == "0.1.0"
    assert "roa-verify" not in versions
