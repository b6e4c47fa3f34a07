"""Built-in systems and loading a user's own system from a Python file.

A user file defines a :class:`roa.system.System` (or a function with no required arguments that
returns one) and, optionally, ``LYAPUNOV_P`` (an n x n positive-definite matrix) for the Lyapunov
analysis. ``--system path/to/file.py:NAME`` loads ``NAME`` from it.
"""

from __future__ import annotations

import functools
import importlib.util
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

from roa.lyapunov import QuadraticLyapunov
from roa.system import System

BUILTIN: dict[str, str] = {
    "ipc": "roa.systems.ipc:closed_loop",
    "ipc-flat": "roa.systems.ipc:transformed",
    "vanderpol": "roa.systems.vanderpol:vanderpol",
}


def _resolve(target: str) -> Callable[..., System]:
    module, attr = target.split(":")
    return getattr(importlib.import_module(module), attr)


def load_system(spec: str) -> System:
    """Load a built-in system by name or ``path/to/file.py:NAME`` from a user's file."""
    if spec in BUILTIN:
        return _resolve(BUILTIN[spec])()
    if ":" not in spec:
        raise ValueError(
            f"--system {spec!r}: not a built-in system ({', '.join(BUILTIN)}) and not of the form "
            "path/to/file.py:NAME"
        )
    path_str, name = spec.rsplit(":", 1)
    path = Path(path_str)
    module = _user_module(path)
    if not hasattr(module, name):
        raise ValueError(f"--system: {path} defines no {name!r}")
    obj = getattr(module, name)
    system = obj() if callable(obj) and not isinstance(obj, System) else obj
    if not isinstance(system, System):
        raise ValueError(
            f"--system: {path}:{name} is not a roa.System (got {type(system).__name__})"
        )
    return system


def default_lyapunov(spec: str, system: System | None = None) -> QuadraticLyapunov:
    """The quadratic Lyapunov candidate of a ``--system`` spec.

    ``LYAPUNOV_P`` from a user's file; the published matrix for ``vanderpol``; the paper's (3.11)
    for ``ipc-flat``; otherwise P from A'P + PA = -I at the equilibrium.
    """
    system = load_system(spec) if system is None else system
    if spec == "ipc-flat":
        from roa.systems.ipc.lyapunov import paper_lyapunov

        return paper_lyapunov()
    if spec == "vanderpol":
        from roa.systems.vanderpol import P_BENCHMARK

        return QuadraticLyapunov.for_system(system, P_BENCHMARK, name="benchmark P")
    P = load_module_attr(spec, "LYAPUNOV_P")
    name = "LYAPUNOV_P"
    if P is None:
        from roa.levelset import lyapunov_matrix

        P, name = lyapunov_matrix(system), "P from A'P + PA = -I"
    return QuadraticLyapunov.for_system(system, P, name=name)


def load_module_attr(spec: str, attr: str) -> object:
    """Return ``attr`` of the user file behind ``spec`` (``None`` for built-ins or if missing)."""
    if spec in BUILTIN or ":" not in spec:
        return None
    return getattr(_user_module(Path(spec.rsplit(":", 1)[0])), attr, None)


def _user_module(path: Path) -> ModuleType:
    """Import a user's system file once per content (keyed by path and modification time)."""
    if not path.is_file():
        raise ValueError(f"--system: file {path} does not exist")
    return _import_file(str(path.resolve()), path.stat().st_mtime_ns)


@functools.lru_cache(maxsize=32)
def _import_file(path_str: str, mtime_ns: int) -> ModuleType:
    path = Path(path_str)
    mod_spec = importlib.util.spec_from_file_location(f"roa_user_{path.stem}", path)
    if mod_spec is None or mod_spec.loader is None:
        raise ValueError(f"--system: cannot import {path}")
    module = importlib.util.module_from_spec(mod_spec)
    mod_spec.loader.exec_module(module)
    return module
