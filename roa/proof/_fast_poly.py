"""A polynomial field's components over the rationals, by exact ring arithmetic on the expression tree.

:func:`roa.proof._sos_check.exact_data` expands the field written in sympy (every float taken as
the exact rational of its double, ``x = x_eq + d``) into polynomials over QQ. sympy's generic
route (``Poly(expr)``: ``expand`` on expression trees) costs minutes for a dense cubic field of
20 states. :func:`field_polys` evaluates the same tree bottom up in the sparse polynomial ring
``QQ[d]`` (:func:`sympy.polys.rings.ring`): symbols ``x_i -> d_i + c_i``, floats -> the exact
rationals of the doubles (``sympy.Rational(Float)``, as
:func:`roa.lyapunov._symbolic.exact_rationals`), sums, products and non-negative integer powers
exactly. Anything else (a function, a negative or fractional power) returns None, and the caller
uses the generic route, which decides what is polynomial. Same polynomials, exactly (tested
against the generic route).
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any


class _NotPolynomial(Exception):
    pass


def field_polys(exprs: list[Any], xs: list[Any], center: tuple[Fraction, ...],
                d: list[Any]) -> list[Any] | None:  # fmt: skip
    """``[Poly(f_i(x_eq + d), d, QQ)]`` of the expressions ``exprs`` in the symbols ``xs``, or
    None when an expression is not a polynomial built from sums, products and powers."""
    import sympy as sp
    from sympy.polys.rings import ring

    R, *gens = ring(d, sp.QQ)
    QQ = sp.QQ
    shift = {x: g + QQ(c.numerator, c.denominator)
             for x, g, c in zip(xs, gens, center, strict=True)}  # fmt: skip
    memo: dict[Any, Any] = {}

    def ev(e: Any) -> Any:
        if isinstance(e, bool):
            raise _NotPolynomial
        if isinstance(e, int):
            return R(QQ(e))
        if isinstance(e, float):
            q = Fraction(e)
            return R(QQ(q.numerator, q.denominator))
        hit = memo.get(e)
        if hit is not None:
            return hit
        if e.is_Symbol:
            if e not in shift:
                raise _NotPolynomial
            out = shift[e]
        elif e.is_Float:
            r = sp.Rational(e)
            out = R(QQ(int(r.p), int(r.q)))
        elif e.is_Rational:
            out = R(QQ(int(e.p), int(e.q)))
        elif e.is_Add:
            out = R(0)
            for a in e.args:
                out = out + ev(a)
        elif e.is_Mul:
            out = R(1)
            for a in e.args:
                out = out * ev(a)
        elif e.is_Pow and e.exp.is_Integer and int(e.exp) >= 0:
            out = ev(e.base) ** int(e.exp)
        else:
            raise _NotPolynomial
        memo[e] = out
        return out

    try:
        polys = [ev(e) for e in exprs]
    except _NotPolynomial:
        return None
    return [sp.Poly.from_dict({m: sp.Rational(int(c.numerator), int(c.denominator))
                               for m, c in dict(p).items()} or {(0,) * len(d): 0}, *d,
                              domain="QQ") for p in polys]  # fmt: skip
