"""A fingerprint of a system: what a certificate is bound to, instead of the system's name.

:func:`system_fingerprint` hashes what decides a certificate's meaning: the number, names and
order of the states, the equilibrium, whether the system is time-varying, and a *trace* of the
field (and of the domain margin) at fixed points around the equilibrium. Two systems whose fields
differ anywhere on those points (another parameter, another controller gain, another coordinate
system) get different fingerprints; two builds of the same system get the same one.

The trace is rounded to 10 significant digits before hashing, so that a last-bit difference of a
libm function between platforms does not change it. A fingerprint detects a certificate used for
the wrong system; it proves nothing about the certificate itself (re-verification does that,
:mod:`roa.proof.reverify`).
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

import numpy as np

from roa.system import System

#: Number of trace points and their seed (part of the fingerprint's definition: do not change).
N_POINTS = 8
SEED = 20261202


def _rounded(values: np.ndarray) -> list[str]:
    return [f"{float(v):.10g}" if np.isfinite(v) else str(float(v)) for v in values.ravel()]


def trace_points(system: System) -> np.ndarray:
    """The fixed points of the trace: the equilibrium and ``N_POINTS`` points around it."""
    c = system.x_eq if system.equilibrium is not None else np.zeros(system.n)
    rng = np.random.default_rng(SEED)
    U = rng.uniform(-1.0, 1.0, (N_POINTS, system.n))
    r = 0.1 * (1.0 + float(np.abs(c).max(initial=0.0)))
    return np.concatenate([c[None, :], c + r * U])


def system_fingerprint(system: System) -> str:
    """SHA-256 (hex) of the system's states, equilibrium and field trace (see module doc)."""
    X = trace_points(system)
    with np.errstate(all="ignore"):
        try:
            F = np.asarray(system.f(X), dtype=float)
        except Exception:  # noqa: BLE001 - a field that fails on the trace still has an identity
            F = np.full(X.shape, np.nan)
        margin: Any = None
        if system.margin is not None:
            try:
                comps = [X[:, i] for i in range(system.n)]
                from roa.backend import NP

                margin = _rounded(np.broadcast_to(system.margin(comps, NP), X.shape[:1]))
            except Exception:  # noqa: BLE001
                margin = "error"
    data = {
        "n": system.n,
        "states": list(system.state_names),
        "equilibrium": None if system.equilibrium is None else _rounded(system.x_eq),
        "time_varying": bool(system.time_varying),
        "field": _rounded(F),
        "margin": margin,
    }
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()


class _Unidentified(Exception):
    """Something in the system's definition cannot be identified exactly."""


def _source_digest(module_name: str, filename: str | None = None) -> str:
    """SHA-256 of the code a function may call: its top-level package's sources when it is an
    installed package, else its own file (a user's system file)."""
    import importlib.util

    from roa.io import code_hash

    top = module_name.split(".")[0]
    try:
        spec = importlib.util.find_spec(top)
    except (ImportError, ValueError):
        spec = None
    if spec is not None and spec.submodule_search_locations:
        return code_hash(top)
    if filename is None:
        raise _Unidentified(module_name)
    from pathlib import Path

    return hashlib.sha256(Path(filename).read_bytes()).hexdigest()


def _identity(obj: Any, depth: int = 0) -> Any:
    """An exact, JSON-able identity of a value a field depends on (raises _Unidentified)."""
    import dataclasses
    import types

    import numpy as np

    if depth > 8:
        raise _Unidentified("nested too deep")
    if obj is None or isinstance(obj, bool | str):
        return obj
    if isinstance(obj, int):
        return str(obj)
    if isinstance(obj, float | np.floating):
        return float(obj).hex()
    if isinstance(obj, np.ndarray):
        return [str(obj.dtype), list(obj.shape), hashlib.sha256(obj.tobytes()).hexdigest()]
    if isinstance(obj, tuple | list):
        return [_identity(v, depth + 1) for v in obj]
    if isinstance(obj, dict) or hasattr(obj, "items") and hasattr(obj, "keys"):
        return {str(k): _identity(v, depth + 1) for k, v in obj.items()}
    if isinstance(obj, types.FunctionType):
        code = obj.__code__
        cells = [c.cell_contents for c in (obj.__closure__ or ())]
        return {
            "function": f"{obj.__module__}.{obj.__qualname__}",
            "code": hashlib.sha256(code.co_code + repr(code.co_consts).encode()).hexdigest(),
            "source": _source_digest(obj.__module__, code.co_filename),
            "closure": _identity(cells, depth + 1),
            "defaults": _identity(obj.__defaults__, depth + 1),
        }
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        fields = {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}
        return {"type": type(obj).__qualname__, "fields": _identity(fields, depth + 1)}
    cls = type(obj)
    slots = [n for c in cls.__mro__ for n in getattr(c, "__slots__", ()) if hasattr(obj, n)]
    if cls.__module__ != "builtins" and (hasattr(obj, "__dict__") or slots):
        import inspect

        try:
            filename = inspect.getsourcefile(cls)
        except TypeError:
            filename = None
        state = dict(vars(obj)) if hasattr(obj, "__dict__") else {}
        state.update({n: getattr(obj, n) for n in slots})
        return {"type": f"{cls.__module__}.{cls.__qualname__}",
                "source": _source_digest(cls.__module__, filename),
                "state": _identity(state, depth + 1)}  # fmt: skip
    raise _Unidentified(cls.__name__)


def system_identity(system: System) -> str | None:
    """SHA-256 of an exact identity of the system (states, equilibrium, parameters, and the code
    and captured values of its field and margin, with the sources they may call), or None when
    some part of it cannot be identified exactly. Unlike :func:`system_fingerprint` two systems
    that differ anywhere get different identities; what has none is never cached."""
    try:
        data = {
            "fingerprint": system_fingerprint(system),
            "name": system.name,
            "equilibrium": None if system.equilibrium is None else _identity(list(system.x_eq)),
            "params": None if system.params is None else _identity(dict(system.params)),
            "field": _identity(system.field),
            "margin": _identity(system.margin),
        }
    except (_Unidentified, OSError, TypeError, ValueError):
        return None
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()
