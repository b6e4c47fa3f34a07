"""Array namespaces: one vector-field definition, evaluated by numpy, CasADi or sympy.

A system's field is written as ``field(t, x, xp)`` where ``x`` is indexable by component and ``xp``
is one of the namespaces below. Only the functions listed in :data:`FUNCTIONS` may be used.

``minimum(a, b)``, ``maximum(a, b)``, ``clip(x, lo, hi)`` (``= minimum(maximum(x, lo), hi)``, e.g.
an actuator saturation) and ``abs`` are Lipschitz but not smooth: the interval validation encloses
them and their generalised derivatives (:mod:`roa.proof.interval`, :mod:`roa.proof.jet`); the SOS
path, which needs a polynomial field, refuses them.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np

from roa.errors import RoaInputError

FUNCTIONS = ("sin", "cos", "tan", "sqrt", "arctan", "arcsinh", "arctanh", "exp", "log", "abs")
#: The nonsmooth (piecewise) functions, besides ``abs``: ``minimum(a, b)``, ``maximum(a, b)`` and
#: ``clip(x, lo, hi)``, each namespace's own (numpy ``np.minimum``, CasADi ``fmin``, sympy ``Min``).
PIECEWISE = ("minimum", "maximum", "clip")


def _numpy() -> SimpleNamespace:
    ns = {name: getattr(np, name) for name in FUNCTIONS + PIECEWISE}
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
        "minimum": ca.fmin,
        "maximum": ca.fmax,
        "clip": lambda x, lo, hi: ca.fmin(ca.fmax(x, lo), hi),
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
        "minimum": sp.Min,
        "maximum": sp.Max,
        "clip": lambda x, lo, hi: sp.Min(sp.Max(x, lo), hi),
        "name": "sympy",
    }
    return SimpleNamespace(**ns)


def _mpmath() -> SimpleNamespace:
    """Scalar mpmath numbers (the 50-digit re-checks of witnesses); precision from ``mp.workdps``."""
    import mpmath as mp

    ns = {
        "sin": mp.sin,
        "cos": mp.cos,
        "tan": mp.tan,
        "sqrt": mp.sqrt,
        "arctan": mp.atan,
        "arcsinh": mp.asinh,
        "arctanh": mp.atanh,
        "exp": mp.exp,
        "log": mp.log,
        "abs": mp.fabs,
        "minimum": min,
        "maximum": max,
        "clip": lambda x, lo, hi: min(max(x, lo), hi),
        "name": "mpmath",
    }
    return SimpleNamespace(**ns)


_CACHE: dict[str, SimpleNamespace] = {}
_FACTORIES = {"numpy": _numpy, "casadi": _casadi, "sympy": _sympy, "mpmath": _mpmath}


def namespace(name: str) -> Any:
    """Return the array namespace ``name`` (one of ``numpy``, ``casadi``, ``sympy``, ``mpmath``)."""
    if name not in _FACTORIES:
        raise RoaInputError(f"backend: unknown namespace {name!r}; allowed: {sorted(_FACTORIES)}")
    if name not in _CACHE:
        _CACHE[name] = _FACTORIES[name]()
    return _CACHE[name]


NP = namespace("numpy")
