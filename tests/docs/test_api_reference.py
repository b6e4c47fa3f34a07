"""``docs/api.rst`` is the reference of the public API, and of nothing else.

The public names are those of the stubs (``roa/__init__.pyi`` and each ``roa/PKG/__init__.pyi``,
read with ``ast``): every one has an entry in the page (an autosummary line or an ``auto*``
directive), once, as ``roa.PKG.NAME`` or, for a name ``roa`` re-exports, as ``roa.NAME``; and
every ``roa.`` name the page mentions is public: a stub's name (or an attribute of one), a
package or a public module (``roa.systems.vanderpol``), never a ``._`` path. No sphinx run: the
strict build of CI checks that each entry renders.
"""

from __future__ import annotations

import ast
import re
from collections import Counter
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
STUBS = sorted((ROOT / "roa").rglob("__init__.pyi"))
API = (ROOT / "docs" / "api.rst").read_text()
# the names the page documents: autosummary entries (an indented name alone on its line) and the
# targets of autodata, autofunction, autoclass, ...
ENTRIES = Counter(
    re.findall(r"^ {3}(roa(?:\.\w+)+)\s*$", API, re.M)
    + re.findall(r"^\.\. auto\w+:: (roa(?:\.\w+)+)\s*$", API, re.M)
)
# every dotted name of roa the page mentions, in entries, prose and roles
MENTIONED = set(re.findall(r"(?<![\w.])roa(?:\.\w+)+", API))


def package(stub: Path) -> str:
    return ".".join(stub.parent.relative_to(ROOT).parts)


def imports(stub: Path) -> dict[str, str]:
    """A stub's public names -> where each comes from (``roa.certify`` -> ``roa.certification``)."""
    pkg = package(stub)
    found = {}
    for node in ast.parse(stub.read_text()).body:
        if isinstance(node, ast.ImportFrom):
            assert node.level == 1 and node.module, ast.unparse(node)
            for alias in node.names:
                found[alias.asname or alias.name] = f"{pkg}.{node.module}"
    return found


PUBLIC = {package(s): imports(s) for s in STUBS}
TOP = PUBLIC["roa"]


def test_every_package_has_its_stub():
    assert {"roa", "roa.model", "roa.proof", "roa.search", "roa.commands"} <= set(PUBLIC)
    assert all(PUBLIC.values())


@pytest.mark.parametrize("stub", STUBS, ids=package)
def test_every_public_name_has_one_entry(stub: Path):
    pkg = package(stub)
    missing, twice = [], []
    for name in imports(stub):
        spellings = [f"{pkg}.{name}"]
        if pkg != "roa" and TOP.get(name) == pkg:  # re-exported: roa.NAME documents it
            spellings.append(f"roa.{name}")
        count = sum(ENTRIES[s] for s in spellings)
        (missing if count == 0 else twice if count > 1 else []).append(name)
    assert missing == [], f"{pkg}: no entry in docs/api.rst"
    assert twice == [], f"{pkg}: more than one entry in docs/api.rst"


def public(dotted: str) -> bool:
    """A package, a public module, a stub's name, or a public attribute of a stub's name."""
    parts = dotted.split(".")
    if any(p.startswith("_") for p in parts):
        return False
    path = ROOT.joinpath(*parts)
    if path.with_suffix(".py").is_file() or (path / "__init__.py").is_file():
        return True
    return any(parts[k] in PUBLIC.get(".".join(parts[:k]), {}) for k in range(1, len(parts)))


def test_api_reference_names_nothing_private():
    assert re.search(r"roa(?:\.\w+)*\._", API) is None
    assert sorted(n for n in MENTIONED if not public(n)) == []


def test_entries_are_public_names():
    # an entry is a stub's name itself (no attribute of one, no module): what the stubs list
    names = {f"{pkg}.{n}" for pkg, found in PUBLIC.items() for n in found}
    assert sorted(set(ENTRIES) - names) == []
