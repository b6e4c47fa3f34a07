"""sympy expressions evaluated in any array namespace, with exact rational constants.

:func:`sympy_eval` evaluates an expression in any namespace of :mod:`roa.model._backend`, in the
interval namespace and jets of :mod:`roa.proof._interval` (rational constants enclosed), or in
mpmath; :func:`exact_rationals` replaces every float by the exact rational of the double.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from roa.errors import RoaInputError

_EXACT = ("interval", "interval-jet")


def exact_constant(p: int, q: int, xp: Any) -> Any:
    """The rational p/q as a constant of namespace ``xp`` (enclosed, or at working precision)."""
    name = getattr(xp, "name", "")
    if q == 1:
        return float(p) if abs(p) <= 2**53 and name != "mpmath" else _big(p, xp)
    if name in _EXACT:
        return Fraction(p, q)
    if name == "mpmath":
        import mpmath as mp

        return mp.mpf(p) / q
    return p / q


def _big(p: int, xp: Any) -> Any:
    if getattr(xp, "name", "") in _EXACT:
        return Fraction(p)
    if getattr(xp, "name", "") == "mpmath":
        import mpmath as mp

        return mp.mpf(p)
    return float(p)


#: sympy function class name -> the namespace function of :mod:`roa.model._backend`.
FUNCTIONS = {
    "sin": "sin",
    "cos": "cos",
    "tan": "tan",
    "exp": "exp",
    "log": "log",
    "atan": "arctan",
    "asinh": "arcsinh",
    "atanh": "arctanh",
    "tanh": "tanh",
    "Abs": "abs",
}


def sympy_eval(e: Any, env: dict[Any, Any], xp: Any) -> Any:
    """Evaluate a sympy expression (exact rationals, the functions of :mod:`roa.model._backend`) in ``xp``."""
    import sympy as sp

    if e.is_Symbol:
        return env[e]
    if e.is_Rational:
        return exact_constant(int(e.p), int(e.q), xp)
    if e.is_Add:
        out: Any = 0.0
        for a in e.args:
            out = sympy_eval(a, env, xp) + out
        return out
    if e.is_Mul:
        num = [a for a in e.args if a.is_Rational]
        out = None
        for a in e.args:
            if not a.is_Rational:
                v = sympy_eval(a, env, xp)
                out = v if out is None else out * v
        for a in num:
            c = sympy_eval(a, env, xp)
            out = c if out is None else out * c
        return out
    if e.is_Pow:
        b, k = e.args
        base = sympy_eval(b, env, xp)
        if k.is_Integer:
            return base ** int(k) if int(k) > 0 else 1.0 / base ** (-int(k))
        if k.is_Rational and int(k.q) == 2:
            r = xp.sqrt(base)
            p = int(k.p)
            return r**p if p > 0 else 1.0 / r ** (-p)
        raise RoaInputError(f"V: unsupported power {e} (integer and half-integer powers only)")
    if isinstance(e, sp.Function) and type(e).__name__ in FUNCTIONS:
        return getattr(xp, FUNCTIONS[type(e).__name__])(sympy_eval(e.args[0], env, xp))
    if e.is_Number:  # an irrational sympy number (pi, E, ...)
        raise RoaInputError(f"V: unsupported constant {e} (write it as a float)")
    raise RoaInputError(f"V: unsupported expression {type(e).__name__} {e}")


def exact_rationals(expr: Any) -> Any:
    """``expr`` with every float replaced by the exact rational of the double."""
    import sympy as sp

    return expr.xreplace({f: sp.Rational(f) for f in expr.atoms(sp.Float)})
