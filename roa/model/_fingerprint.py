"""A fingerprint of a system: what a certificate is bound to, instead of the system's name.

:func:`system_fingerprint` hashes what decides a certificate's meaning: the number, names and
order of the states, the equilibrium, whether the system is time-varying, and a *trace* of the
field (and of the domain margin) at fixed points around the equilibrium. Two systems whose fields
differ anywhere on those points (another parameter, another controller gain, another coordinate
system) get different fingerprints; two builds of the same system get the same one.

The trace is rounded to 10 significant digits before hashing, so that a last-bit difference of a
libm function between platforms does not change it. A fingerprint detects a certificate used for
the wrong system; it proves nothing about the certificate itself (re-verification does that,
:mod:`roa.proof._reverify`).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

import numpy as np

from roa.model._system import System

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
            F = np.asarray(system.evaluate(X), dtype=float)  # f, or the map F
        except Exception:  # noqa: BLE001 - a field that fails on the trace still has an identity
            F = np.full(X.shape, np.nan)
        margin: Any = None
        if system.margin is not None:
            try:
                comps = [X[:, i] for i in range(system.n)]
                from roa.model._backend import NP

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
    if system.time == "discrete":  # a map's trace is of F (absent: a field's)
        data["time"] = {"discrete": True, "sample_time": system.sample_time}
    if system.parameters:  # the box a robust certificate holds for (absent: one parameter value)
        data["parameters"] = {k: [float(v) for v in r] for k, r in system.parameters.items()}
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()


class _Unidentified(Exception):
    """Something in the system's definition cannot be identified exactly."""


def _package_digest(module_name: str) -> str:
    """SHA-256 of the sources of the installed package that holds ``module_name`` (the code a
    function of it may call); a module outside an installed package (a user's file, a test
    module) has no exact identity here: its globals and the files it imports are not pinned."""
    import importlib.util

    from roa.io import code_hash

    top = module_name.split(".")[0]
    try:
        spec = importlib.util.find_spec(top)
    except (ImportError, ValueError):
        spec = None
    if spec is None or not spec.submodule_search_locations or spec.origin is None:
        raise _Unidentified(f"{module_name} is not in an installed package")
    return code_hash(top)


def _code_identity(code: Any) -> list[Any]:
    consts = [_code_identity(c) if hasattr(c, "co_code") else repr(c) for c in code.co_consts]
    return [hashlib.sha256(code.co_code).hexdigest(), consts, list(code.co_names)]


def _identity(obj: Any, depth: int = 0) -> Any:
    """An exact, JSON-able, type-tagged identity of a value a field depends on; raises
    _Unidentified for anything not positively understood (then nothing is cached)."""
    import dataclasses
    import types

    import numpy as np

    if depth > 8:
        raise _Unidentified("nested too deep")
    if obj is None or isinstance(obj, bool):
        return ["const", repr(obj)]
    if type(obj) is str:
        return ["str", obj]
    if type(obj) is int:
        return ["int", str(obj)]
    if type(obj) is float or isinstance(obj, np.floating):
        return ["float", float(obj).hex()]
    if type(obj) is np.ndarray:
        digest = hashlib.sha256(np.ascontiguousarray(obj).tobytes()).hexdigest()
        return ["ndarray", str(obj.dtype), list(obj.shape), digest]
    if type(obj) in (tuple, list):
        return [type(obj).__name__, [_identity(v, depth + 1) for v in obj]]
    if (
        type(obj) is dict
        or isinstance(obj, Mapping)
        and type(obj).__module__ == "roa.model._system"
    ):
        items = sorted(((repr(k), _identity(v, depth + 1)) for k, v in obj.items()), key=str)
        return ["mapping", items]
    if type(obj) is types.FunctionType:
        cells = [c.cell_contents for c in (obj.__closure__ or ())]
        return ["function", f"{obj.__module__}.{obj.__qualname__}",
                _code_identity(obj.__code__), _package_digest(obj.__module__),
                _identity(cells, depth + 1), _identity(obj.__defaults__, depth + 1),
                _identity(obj.__kwdefaults__, depth + 1), _identity(dict(obj.__dict__), depth + 1)]  # fmt: skip
    cls = type(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        fields = {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}
        return ["dataclass", f"{cls.__module__}.{cls.__qualname__}", _package_digest(cls.__module__),
                _identity(fields, depth + 1)]  # fmt: skip
    slots = [n for c in cls.__mro__ for n in getattr(c, "__slots__", ()) if hasattr(obj, n)]
    if hasattr(obj, "__dict__") or slots:  # an instance of a class of an installed package
        digest = _package_digest(cls.__module__)  # raises for builtins, functools, user files
        state = dict(vars(obj)) if hasattr(obj, "__dict__") else {}
        state.update({n: getattr(obj, n) for n in slots})
        return ["object", f"{cls.__module__}.{cls.__qualname__}", digest,
                _identity(state, depth + 1)]  # fmt: skip
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
        if system.parameters:
            data["parameters"] = {k: [float(v) for v in r] for k, r in system.parameters.items()}
    except (_Unidentified, OSError, TypeError, ValueError):
        return None
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()
