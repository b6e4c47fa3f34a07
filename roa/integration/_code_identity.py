"""A key for "the same field code as before", so a warm start finds its kernel without sympy.

:func:`code_key` hashes what a field (or margin) computes from: its bytecode and constants, the
values in its closure and the module globals it names, followed into the functions it calls (to
:data:`MAX_DEPTH` levels), with numbers, strings, tuples, lists, dicts and numpy arrays taken by
value, modules by name, dataclass-like objects by their fields. An object it cannot take by
value (an arbitrary instance without a picklable state) makes the key None: no shortcut, the
field is traced. The key is a shortcut only: the generated kernel found with it is still compared
with the numpy field on sample states before use (:mod:`roa.integration._kernel_cache`).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import pickle
import types
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

#: How deep calls into other functions are followed.
MAX_DEPTH = 6


class _Opaque(Exception):
    """A value that cannot be taken by value."""


def _value(v: Any, depth: int, seen: set[int]) -> Any:
    if v is None or isinstance(v, bool | int | float | complex | str | bytes):
        return (type(v).__name__, repr(v))
    if isinstance(v, np.ndarray):
        return (
            "ndarray",
            str(v.dtype),
            v.shape,
            hashlib.sha256(np.ascontiguousarray(v).tobytes()).hexdigest(),
        )
    if isinstance(v, np.generic):
        return ("np", repr(v))
    if isinstance(v, tuple | list | frozenset | set):
        items = [_value(x, depth, seen) for x in v]
        return (type(v).__name__, sorted(map(repr, items)) if isinstance(v, set | frozenset)
                else items)  # fmt: skip
    if isinstance(v, dict):
        return ("dict", [(repr(k), _value(x, depth, seen)) for k, x in v.items()])
    if isinstance(v, types.ModuleType):
        return ("module", v.__name__)
    if isinstance(v, type):
        return ("type", v.__module__, v.__qualname__)
    if isinstance(v, types.BuiltinFunctionType | np.ufunc):
        return ("builtin", getattr(v, "__module__", None), v.__name__)
    if callable(v) and hasattr(v, "__code__"):
        return _function(v, depth + 1, seen)
    if isinstance(v, types.MethodType):
        return ("method", _value(v.__self__, depth, seen), _function(v.__func__, depth + 1, seen))
    if id(v) in seen:
        return ("seen",)
    seen.add(id(v))
    if dataclasses.is_dataclass(v):
        return ("dataclass", type(v).__qualname__,
                [(f.name, _value(getattr(v, f.name), depth, seen))
                 for f in dataclasses.fields(v)])  # fmt: skip
    if hasattr(v, "items") and hasattr(v, "keys"):  # mappings (roa.model._system.Params, ...)
        return ("mapping", type(v).__qualname__,
                [(repr(k), _value(v[k], depth, seen)) for k in v.keys()])  # fmt: skip
    try:
        return ("pickle", type(v).__qualname__, hashlib.sha256(pickle.dumps(v)).hexdigest())
    except Exception:  # noqa: BLE001 - anything unpicklable: not taken by value
        raise _Opaque(type(v).__qualname__) from None


def _code(code: types.CodeType) -> Any:
    consts = [_code(c) if isinstance(c, types.CodeType) else repr(c) for c in code.co_consts]
    return (code.co_code.hex(), consts, code.co_names, code.co_argcount)


def _function(fn: Any, depth: int, seen: set[int]) -> Any:
    if depth > MAX_DEPTH:
        raise _Opaque("too deep")
    if id(fn) in seen:
        return ("seen", fn.__qualname__)
    seen.add(id(fn))
    code = fn.__code__
    cells = [_value(c.cell_contents, depth, seen) for c in (fn.__closure__ or ())]
    glob = fn.__globals__
    names = [(n, _value(glob[n], depth, seen)) for n in code.co_names if n in glob]
    nested = [n for c in code.co_consts if isinstance(c, types.CodeType) for n in c.co_names]
    names += [(n, _value(glob[n], depth, seen)) for n in nested if n in glob]
    defaults = _value(fn.__defaults__, depth, seen)
    return ("function", fn.__module__, fn.__qualname__, _code(code), cells, names, defaults)


def code_key(*objs: Any) -> str | None:
    """SHA-256 of the code and values ``objs`` compute from (see the module doc), or None."""
    try:
        blob = repr([_value(o, 0, set()) for o in objs])
    except (_Opaque, RecursionError):
        return None
    return hashlib.sha256(blob.encode()).hexdigest()


@functools.cache
def source_digest(filename: str) -> str:
    """SHA-256 of the bytes of the file ``filename`` (read once per process)."""
    return hashlib.sha256(Path(filename).read_bytes()).hexdigest()


def sources_digest(folder: Path, names: Iterable[str]) -> str:
    """SHA-256 of the :func:`source_digest` of the files ``names`` of ``folder``, in order."""
    return hashlib.sha256(
        "".join(source_digest(str(folder / f)) for f in names).encode()
    ).hexdigest()
