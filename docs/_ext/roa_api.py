"""The docstrings autodoc misses on ``roa``'s lazily loaded packages.

A package ``roa.PKG`` defines nothing itself: ``lazy_loader.attach_stub`` imports each public name
on first use from the private module that ``roa/PKG/__init__.pyi`` names. autodoc reads the
comment of a constant (``#: ...`` above it, or a string below it) from the module it imported the
name from, ``roa/PKG/__init__.py``, finds none there and falls back to the docstring of the value's
type (``int``, ``tuple``). This hook reads the comment from the defining module instead, and leaves
a constant without one undocumented (``api.rst`` then describes it). A numba ``cfunc`` (such as
``roa.integration.no_margin``) gets the docstring of its Python function.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path
from typing import Any

from sphinx.application import Sphinx
from sphinx.errors import PycodeError
from sphinx.pycode import ModuleAnalyzer
from sphinx.util.docstrings import prepare_docstring

ROA = Path(__file__).resolve().parents[2] / "roa"


@functools.cache
def origins() -> dict[str, str]:
    """``"roa.PKG.NAME"`` -> the private module defining it, from every ``roa/PKG/__init__.pyi``."""
    found = {}
    for stub in sorted(ROA.glob("*/__init__.pyi")):
        package = f"roa.{stub.parent.name}"
        for node in ast.parse(stub.read_text()).body:
            if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module:
                for alias in node.names:
                    name = alias.asname or alias.name
                    found[f"{package}.{name}"] = f"{package}.{node.module}"
    return found


def _comment(module: str, name: str) -> list[str]:
    try:
        analyzer = ModuleAnalyzer.for_module(module)
        analyzer.analyze()
    except PycodeError:
        return []
    return list(analyzer.attr_docs.get(("", name), []))


def _process(app: Sphinx, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    module = origins().get(name)
    if module is None:
        return
    pyfunc = getattr(obj, "_pyfunc", None)  # a numba cfunc: its Python function's docstring
    if pyfunc is not None and obj.__doc__ == type(obj).__doc__:
        lines[:] = prepare_docstring(pyfunc.__doc__ or "")
    elif what == "data":
        lines[:] = _comment(module, name.rpartition(".")[2])


def setup(app: Sphinx) -> dict[str, Any]:
    app.connect("autodoc-process-docstring", _process)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
