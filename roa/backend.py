"""Array namespaces: one vector-field definition, evaluated by numpy, CasADi or sympy.

A system's field is written as ``field(t, x, xp)`` where ``x`` is indexable by component and ``xp``
is one of the namespaces below. Only the functions listed in :data:`FUNCTIONS` may be used.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np

from roa.errors import RoaInputError

FUNCTIONS = ("sin", "cos", "tan", "sqrt", "arctan", "arcsinh", "arctanh", "exp", "log", "abs")


def _numpy() -> SimpleNamespace:
    ns = {name: getattr(np, name) for name in FUNCTIONS}
    ns["name"] = "numpy"
    return SimpleNamespace(**ns)


def _casadi() -> SimpleNamespace:
    import casadi as ca

    ns = {
        "sin": ca.sin,
        "cos": ca.cos,
        "tan": ca.tan,
        "sqrt": ca.sqrt,
        "arctan": ca.atan,
        "arcsinh": ca.asinh,
        "arctanh": ca.atanh,
        "exp": ca.exp,
        "log": ca.log,
        "abs": ca.fabs,
        "name": "casadi",
    }
    return SimpleNamespace(**ns)


def _sympy() -> SimpleNamespace:
    import sympy as sp

    ns = {
        "sin": sp.sin,
        "cos": sp.cos,
        "tan": sp.tan,
        "sqrt": sp.sqrt,
        "arctan": sp.atan,
        "arcsinh": sp.asinh,
        "arctanh": sp.atanh,
        "exp": sp.exp,
        "log": sp.log,
        "abs": sp.Abs,
        "name": "sympy",
    }
    return SimpleNamespace(**ns)


_CACHE: dict[str, SimpleNamespace] = {}
_FACTORIES = {"numpy": _numpy, "casadi": _casadi, "sympy": _sympy}


def namespace(name: str) -> Any:
    """Return the array namespace ``name`` (one of ``numpy``, ``casadi``, ``sympy``)."""
    if name not in _FACTORIES:
        raise RoaInputError(f"backend: unknown namespace {name!r}; allowed: {sorted(_FACTORIES)}")
    if name not in _CACHE:
        _CACHE[name] = _FACTORIES[name]()
    return _CACHE[name]


NP = namespace("numpy")
