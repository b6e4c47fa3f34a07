"""Built-in systems and loading a user's own system from a Python file.

``load_system(spec)`` takes

* a built-in name, optionally with keyword parameters: the library's own (:data:`BUILTIN`,
  ``"vanderpol"``, ``"vanderpol:mu=0.5"``), then those the installed studies declare
  (:attr:`roa.studies.Study.systems`, e.g. the IPC study's ``"ipc"``, ``"ipc:saturation=2"``,
  ``"ipc-flat"``); :func:`builtin_names` lists them all;
* ``"path/to/file.py:NAME"``: ``NAME`` in a user's file is a :class:`roa.System` (or a function
  with no required arguments returning one). An optional ``LYAPUNOV_P`` in the file (an n x n
  positive-definite matrix) becomes the system's ``lyapunov`` unless it already has one.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import importlib.util
import traceback
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

from roa.errors import RoaError, RoaInputError, SystemDefinitionError

if TYPE_CHECKING:  # imported where needed: the CLI's --help lists the names without numpy
    from roa.model._system import System

#: The library's built-in systems: name -> "module:factory"; factories take keyword parameters
#: (floats). Studies add their own (:attr:`roa.studies.Study.systems`), looked up after these.
BUILTIN: dict[str, str] = {
    "vanderpol": "roa.systems.vanderpol:vanderpol",
    "cubic-map": "roa.systems.cubic_map:cubic_map",
}


def builtin_names() -> dict[str, str | None]:
    """Every system loadable by name: name -> the study declaring it (None: the library's own).

    Examples
    --------
    >>> from roa.systems import builtin_names
    >>> builtin_names()["vanderpol"] is None
    True
    """
    from roa.studies._registry import systems

    out: dict[str, str | None] = dict.fromkeys(BUILTIN)
    for name, entries in systems().items():
        out.setdefault(
            name, entries[0][1] if len(entries) == 1 else "/".join(s for _, s in entries)
        )
    return out


def describe_builtins() -> str:
    """The names of :func:`builtin_names` for messages: ``vanderpol; study ipc: ipc, ipc-flat``."""
    by_origin: dict[str | None, list[str]] = {}
    for name, origin in builtin_names().items():
        by_origin.setdefault(origin, []).append(name)
    parts = [", ".join(by_origin.pop(None, []))]
    parts += [f"study {origin}: {', '.join(names)}" for origin, names in by_origin.items()]
    return "; ".join(p for p in parts if p)


def _target(name: str) -> str | None:
    """``"module:factory"`` of the built-in ``name`` (the library's first, then the studies')."""
    if name in BUILTIN:
        return BUILTIN[name]
    from roa.studies._registry import systems

    entries = systems().get(name)
    if not entries:
        return None
    if len(entries) > 1:
        raise RoaInputError(
            f"system {name!r} is declared by several studies "
            f"({', '.join(study for _, study in entries)}): uninstall all but one"
        )
    return entries[0][0]


def _resolve(target: str) -> Callable[..., System]:
    module, attr = target.split(":")
    return getattr(importlib.import_module(module), attr)


def _builtin(spec: str) -> System | None:
    name, _, params = spec.partition(":")
    target = _target(name)
    if target is None:
        return None
    kwargs: dict[str, float] = {}
    for part in filter(None, (p.strip() for p in params.split(","))):
        key, sep, value = part.partition("=")
        try:
            if not sep:
                raise ValueError
            kwargs[key.strip()] = float(value)
        except ValueError:
            raise RoaInputError(
                f"system {spec!r}: parameters must be NAME=NUMBER separated by commas "
                f"(e.g. vanderpol:mu=0.5), got {part!r}"
            ) from None
    try:
        return _resolve(target)(**kwargs)
    except TypeError as exc:
        raise RoaInputError(f"system {spec!r}: {exc}") from None


def load_system(spec: str) -> System:
    """A built-in system by name (with parameters) or ``path/to/file.py:NAME`` from a user's file.

    Built-in names are the library's (:data:`BUILTIN`), then those of the installed studies
    (:func:`builtin_names`).

    Examples
    --------
    >>> from roa.systems import load_system
    >>> load_system("vanderpol").state_names
    ('x1', 'x2')
    """
    from roa.model._system import System

    builtin = _builtin(spec)
    if builtin is not None:
        return builtin
    if ":" not in spec:
        raise RoaInputError(
            f"system {spec!r}: not a built-in system ({describe_builtins()}) and not of the "
            "form path/to/file.py:NAME"
        )
    path_str, name = spec.rsplit(":", 1)
    path = Path(path_str)
    module = user_module(path)
    if not hasattr(module, name):
        raise SystemDefinitionError(f"system file {path} defines no {name!r}")
    obj = getattr(module, name)
    try:
        system = obj() if callable(obj) and not isinstance(obj, System) else obj
    except Exception as exc:  # the user's code: report where it failed, in one line
        raise SystemDefinitionError(_where(path, exc)) from exc
    if not isinstance(system, System):
        raise SystemDefinitionError(
            f"{path}:{name} is not a roa.System (got {type(system).__name__})"
        )
    P = getattr(module, "LYAPUNOV_P", None)
    if P is not None and system.lyapunov is None:
        try:
            system = dataclasses.replace(system, lyapunov=P)
        except RoaInputError as exc:
            raise SystemDefinitionError(f"{path}: LYAPUNOV_P: {exc}") from None
    system = _guarded(system, path)
    from roa.model._checks import check_system

    try:
        check_system(system)  # the field's size, f(x_eq) = 0, x_eq in the domain
    except RoaInputError as exc:
        raise type(exc)(f"{path}:{name}: {exc}") from None
    except Exception as exc:  # the user's field raised: report where, in one line
        raise SystemDefinitionError(_where(path, exc)) from None
    return system


@dataclasses.dataclass(frozen=True)
class UserField:
    """A user file's field: what it raises becomes a :class:`SystemDefinitionError` naming the
    file, the line and the namespace it was evaluated in (picklable for the workers)."""

    func: Callable[..., Any]
    path: str

    def __call__(self, t: Any, x: Any, xp: Any, *p: Any) -> Any:
        try:
            return self.func(t, x, xp, *p)
        except RoaError:
            raise
        except Exception as exc:  # the user's code: one line naming where, no traceback
            hint = (
                "; write the field with xp.sin, xp.cos, ... (not numpy's) so that it runs on "
                "every namespace"
                if isinstance(exc, TypeError | AttributeError)
                else ""
            )
            raise SystemDefinitionError(
                f"{_where(Path(self.path), exc)} (evaluating the field with the "
                f"{getattr(xp, 'name', type(xp).__name__)} namespace){hint}"
            ) from None


def _guarded(system: System, path: Path) -> System:
    """``system`` with its field wrapped in :class:`UserField` (the innermost function, so that
    declared parameters are still bound)."""
    from roa.model._system import BoundField

    inner = system.field.func if isinstance(system.field, BoundField) else system.field
    if isinstance(inner, UserField):
        return system
    return dataclasses.replace(system, field=UserField(inner, str(path)))


def _where(path: Path, exc: BaseException) -> str:
    """``file:line: Type: message`` of the innermost frame in ``path`` (one line)."""
    line = "?"
    if isinstance(exc, SyntaxError) and exc.lineno is not None:
        line = str(exc.lineno)
    else:
        for frame in traceback.extract_tb(exc.__traceback__):
            if Path(frame.filename).resolve() == path.resolve():
                line = str(frame.lineno)
    msg = exc.msg if isinstance(exc, SyntaxError) else str(exc)
    return f"system file {path}:{line}: {type(exc).__name__}: {msg}"


def user_module(path: Path) -> ModuleType:
    """Import a user's system file once per content (keyed by path and modification time)."""
    if not path.is_file():
        raise SystemDefinitionError(f"system file {path} does not exist")
    return _import_file(str(path.resolve()), path.stat().st_mtime_ns)


@functools.lru_cache(maxsize=32)
def _import_file(path_str: str, mtime_ns: int) -> ModuleType:
    path = Path(path_str)
    mod_spec = importlib.util.spec_from_file_location(f"roa_user_{path.stem}", path)
    if mod_spec is None or mod_spec.loader is None:
        raise SystemDefinitionError(f"cannot import system file {path}")
    module = importlib.util.module_from_spec(mod_spec)
    try:
        mod_spec.loader.exec_module(module)
    except Exception as exc:  # syntax errors, import errors, ... in the user's file
        raise SystemDefinitionError(_where(path, exc)) from exc
    return module
