"""The house as a map: no import circle in ``roa``, at most 10 modules at its top level, and the
layers contract of ``pyproject.toml`` kept (``lint-imports``, also run by ``.ci/run``).

The import graph is grimp's (the library import-linter builds on): every ``import`` statement,
at module level or inside a function, except those under ``if TYPE_CHECKING:``.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import grimp

ROOT = Path(__file__).resolve().parents[2]


def _strong_components(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components with more than one module (the circles)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))
    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_the_circle_finder_finds_a_circle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _strong_components(graph) == [["a", "b", "c"]]
    assert _strong_components({"a": {"b"}, "b": set()}) == []


def test_roa_has_no_import_circle():
    g = grimp.build_graph(
        "roa", include_external_packages=False, exclude_type_checking_imports=True
    )
    graph = {m: set(g.find_modules_directly_imported_by(m)) for m in g.modules}
    assert _strong_components(graph) == []


def test_at_most_ten_modules_at_roas_top_level():
    top = sorted(p.name for p in (ROOT / "roa").glob("*.py"))
    assert len(top) <= 10, top


def test_the_layers_contract_is_kept():
    exe = shutil.which("lint-imports", path=str(Path(sys.executable).parent))
    assert exe is not None, "lint-imports (import-linter) is a test dependency"
    run = subprocess.run([exe], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-3000:]
    assert "roa's layers" in run.stdout and "KEPT" in run.stdout
