"""Array namespaces: one vector-field definition, evaluated by numpy, CasADi or sympy.

A system's field is written as ``field(t, x, xp)`` where ``x`` is indexable by component and ``xp``
is one of the namespaces below. Only the functions listed in :data:`FUNCTIONS` may be used.

``minimum(a, b)``, ``maximum(a, b)``, ``clip(x, lo, hi)`` (``= minimum(maximum(x, lo), hi)``, e.g.
an actuator saturation) and ``abs`` are Lipschitz but not smooth: the interval validation encloses
them and their generalised derivatives (:mod:`roa.proof._interval`, :mod:`roa.proof._jet`); the SOS
path, which needs a polynomial field, refuses them.

The activations of neural networks (:data:`ACTIVATIONS`) are in every namespace too:
``tanh``, ``sigmoid(x) = 1 / (1 + exp(-x))``, ``softplus(x) = log(1 + exp(x))`` (smooth) and
``relu(x) = max(x, 0)``, ``leaky_relu(x, alpha) = max(x, 0) + alpha min(x, 0)`` (kinked at 0,
``alpha = 0.01`` by default). numpy evaluates ``sigmoid`` and ``softplus`` in overflow-free forms
(``softplus(x) = max(x, 0) + log1p(exp(-|x|))``); CasADi, sympy and mpmath write the formulas
above (sympy: ``Max``/``Min``, ``exp``, ``log``, so traced fields compile to Monte Carlo kernels).
:class:`roa.nn.MLP` evaluates networks with them.
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
#: Activation functions of neural networks (:class:`roa.nn.MLP`); ``leaky_relu(x, alpha=0.01)``.
ACTIVATIONS = ("tanh", "sigmoid", "relu", "leaky_relu", "softplus")
#: The default negative slope of ``leaky_relu`` (PyTorch's).
LEAKY_SLOPE = 0.01


def _np_sigmoid(x: Any) -> Any:
    """``1 / (1 + exp(-x))`` without overflow warnings (``exp(-x) = inf`` gives 0, exactly right)."""
    with np.errstate(over="ignore"):
        return 1.0 / (1.0 + np.exp(-np.asarray(x, dtype=float)))


def _np_softplus(x: Any) -> Any:
    """``log(1 + exp(x)) = max(x, 0) + log1p(exp(-|x|))`` (no overflow for large ``x``)."""
    x = np.asarray(x, dtype=float)
    return np.maximum(x, 0.0) + np.log1p(np.exp(-np.abs(x)))


def _np_leaky_relu(x: Any, alpha: float = LEAKY_SLOPE) -> Any:
    return np.maximum(x, 0.0) + alpha * np.minimum(x, 0.0)


def _numpy() -> SimpleNamespace:
    ns: dict[str, Any] = {name: getattr(np, name) for name in FUNCTIONS + PIECEWISE}
    ns.update(
        tanh=np.tanh,
        sigmoid=_np_sigmoid,
        relu=lambda x: np.maximum(x, 0.0),
        leaky_relu=_np_leaky_relu,
        softplus=_np_softplus,
    )
    ns["name"] = "numpy"
    return SimpleNamespace(**ns)


#: The attribute of each of :data:`FUNCTIONS` but ``abs`` in CasADi, sympy and mpmath (their
#: inverse functions are spelt ``atan``, numpy's ``arctan``).
_SPELLING = {"sin": "sin", "cos": "cos", "tan": "tan", "sqrt": "sqrt", "arctan": "atan",
             "arcsinh": "asinh", "arctanh": "atanh", "exp": "exp", "log": "log"}  # fmt: skip


def _symbolic(
    name: str, mod: Any, *, abs_: Any, minimum: Any, maximum: Any, softplus: Any, zero: Any
) -> SimpleNamespace:
    """The namespace of a scalar or symbolic module ``mod``: :data:`FUNCTIONS` from ``mod``, the
    piecewise functions and the activations written from its ``minimum``, ``maximum``, ``exp``."""
    ns: dict[str, Any] = {key: getattr(mod, attr) for key, attr in _SPELLING.items()}
    ns.update(
        abs=abs_,
        minimum=minimum,
        maximum=maximum,
        clip=lambda x, lo, hi: minimum(maximum(x, lo), hi),
        tanh=mod.tanh,
        sigmoid=lambda x: 1 / (1 + mod.exp(-x)),
        relu=lambda x: maximum(x, zero),
        leaky_relu=lambda x, alpha=LEAKY_SLOPE: maximum(x, zero) + alpha * minimum(x, zero),
        softplus=softplus,
        name=name,
    )
    return SimpleNamespace(**ns)


def _casadi() -> SimpleNamespace:
    import casadi as ca

    return _symbolic("casadi", ca, abs_=ca.fabs, minimum=ca.fmin, maximum=ca.fmax, zero=0.0,
                     softplus=lambda x: ca.fmax(x, 0.0) + ca.log1p(ca.exp(-ca.fabs(x))))  # fmt: skip


def _sympy() -> SimpleNamespace:
    import sympy as sp

    return _symbolic("sympy", sp, abs_=sp.Abs, minimum=sp.Min, maximum=sp.Max, zero=0,
                     softplus=lambda x: sp.log(1 + sp.exp(x)))  # fmt: skip


def _mpmath() -> SimpleNamespace:
    """Scalar mpmath numbers (the 50-digit re-checks of witnesses); precision from ``mp.workdps``."""
    import mpmath as mp

    return _symbolic("mpmath", mp, abs_=mp.fabs, minimum=min, maximum=max, zero=0,
                     softplus=lambda x: mp.log1p(mp.exp(x)))  # fmt: skip


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
