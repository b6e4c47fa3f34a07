"""Forward-mode Taylor jets over intervals: value, gradient and Hessian enclosures.

:class:`Jet` carries value, gradient and (optionally) Hessian of an expression (forward-mode
automatic differentiation over :class:`roa.proof.interval.Interval`), used for the centred form and
for the second-order proof near the equilibrium. Every jet coefficient is either an
:class:`Interval` (outward rounded) or a Python float that is *exactly* the coefficient (``0.0``, the
seeds ``1.0``, an exactly representable constant, or an exactly representable product or sum of
such floats, checked in rational arithmetic); constants entering a jet are enclosed, never rounded.
:data:`JET` is the namespace of jets in the style of :mod:`roa.backend`.
"""

from __future__ import annotations

import math
from fractions import Fraction
from types import SimpleNamespace
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.proof.interval import (  # noqa: F401
    Interval,
    _down,
    _enclose_constant,
    _up,
    iarcsinh,
    iarctan,
    iarctanh,
    icos,
    iexp,
    ilog,
    isin,
    isqrt,
    itan,
)


# -- forward-mode jets over intervals ---------------------------------------------------------------
# A coefficient is an Interval, or a Python float that is exactly the coefficient. 0.0 is an exact,
# symbolic zero (a sparse-gradient shortcut); 1.0 and -1.0 multiply exactly.
def _coef(c: Any) -> Any:
    """A constant as a jet coefficient: an exact Python float when it is a double, else enclosed."""
    if type(c) is float:
        return c
    if isinstance(c, Interval):
        return c
    if isinstance(c, np.float64 | np.float32 | np.float16):
        return float(c)
    iv = _enclose_constant(c)
    if iv.lo.ndim == 0 and iv.lo == iv.hi:
        return float(iv.lo)
    return iv


def _fmul(a: float, b: float) -> Any:
    """``a * b`` of two exact float coefficients: the float if exact, else an enclosure."""
    p = a * b
    if math.isfinite(p) and Fraction(p) == Fraction(a) * Fraction(b):
        return p
    return Interval(a) * b


def _fadd(a: float, b: float) -> Any:
    """``a + b`` of two exact float coefficients: the float if exact (TwoSum), else an enclosure."""
    s = a + b
    if math.isfinite(s):
        bb = s - a
        if (a - (s - bb)) + (b - bb) == 0.0:
            return s
    return Interval(a) + b


def _m(a: Any, b: Any) -> Any:
    """Product of coefficients; exact zeros stay symbolic, +-1 multiply exactly, floats never round."""
    if type(a) is float:
        if a == 0.0:
            return 0.0
        if a == 1.0:
            return b
        if a == -1.0:
            return _n(b)
        if type(b) is float:
            return 0.0 if b == 0.0 else _fmul(a, b)
        return b * a
    if type(b) is float:
        if b == 0.0:
            return 0.0
        if b == 1.0:
            return a
        if b == -1.0:
            return -a
    return a * b


def _a(a: Any, b: Any) -> Any:
    """Sum of coefficients; exact zeros skipped, float + float only when exact."""
    if type(a) is float:
        if a == 0.0:
            return b
        if type(b) is float:
            return a if b == 0.0 else _fadd(a, b)
        return b + a
    if type(b) is float and b == 0.0:
        return a
    return a + b


def _n(a: Any) -> Any:
    return 0.0 if type(a) is float and a == 0.0 else -a


def _hessian(j: Jet) -> list:
    """The Hessian of a second-order jet (jets of mixed order are a programming error)."""
    if j.h is None:
        raise RoaInputError("jet arithmetic mixes first- and second-order jets")
    return j.h


def _real_power(v: Interval, e: Fraction) -> Interval:
    """Enclosure of ``v^e`` for an exact rational exponent ``e`` (``v >= 0``).

    If ``e`` is a double, ``v ** float(e)``; else the hull over the two neighbouring doubles
    (``v^e`` is monotone in ``e`` for each fixed ``v > 0``).
    """
    f = float(e)
    if Fraction(f) == e:
        return v**f
    a, b = v ** float(_down(f)), v ** float(_up(f))
    return Interval(np.minimum(a.lo, b.lo), np.maximum(a.hi, b.hi))


class Jet:
    """Value, gradient and optionally Hessian of an expression.

    ``Jet.variables(box_lo, box_hi)`` seeds the coordinates; arithmetic and the namespace
    :data:`JET` propagate derivatives by the chain rule. ``h`` is ``None`` for first order. The
    value is an :class:`Interval`; a gradient or Hessian entry is an :class:`Interval` or a Python
    float that is exactly the entry (``0.0`` for an exact zero, skipped in arithmetic). Only the
    upper triangle ``h[i][j], j >= i`` of the Hessian is computed (the lower one holds ``0.0``).
    """

    __slots__ = ("v", "g", "h")
    __array_priority__ = 1000

    def __init__(self, v: Any, g: list, h: list | None) -> None:
        self.v, self.g, self.h = Interval.of(v), g, h

    @classmethod
    def variables(cls, lo: Any, hi: Any, *, order: int = 1) -> list[Jet]:
        """Coordinate jets on the boxes ``[lo, hi]`` (shape ``(m, n)``), up to ``order`` (1 or 2)."""
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        n = lo.shape[-1]
        out = []
        for i in range(n):
            g = [1.0 if j == i else 0.0 for j in range(n)]
            h = [[0.0] * n for _ in range(n)] if order >= 2 else None
            out.append(cls(Interval(lo[..., i], hi[..., i]), g, h))
        return out

    def _const(self, c: Any) -> Jet:
        if isinstance(c, Jet):
            return c
        n = len(self.g)
        h = [[0.0] * n for _ in range(n)] if self.h is not None else None
        return Jet(Interval.of(_coef(c)), [0.0] * n, h)

    def __neg__(self) -> Jet:
        h = None if self.h is None else [[_n(e) for e in row] for row in self.h]
        return Jet(-self.v, [_n(e) for e in self.g], h)

    def __add__(self, other: Any) -> Jet:
        if not isinstance(other, Jet):
            return Jet(self.v + _coef(other), self.g, self.h)
        o = other
        h = (
            None
            if self.h is None
            else [
                [_a(a, b) for a, b in zip(r1, r2, strict=True)]
                for r1, r2 in zip(self.h, _hessian(o), strict=True)
            ]
        )
        return Jet(self.v + o.v, [_a(a, b) for a, b in zip(self.g, o.g, strict=True)], h)

    __radd__ = __add__

    def __sub__(self, other: Any) -> Jet:
        if not isinstance(other, Jet):
            return Jet(self.v - _coef(other), self.g, self.h)
        return self + (-other)

    def __rsub__(self, other: Any) -> Jet:
        return (-self) + other

    def __mul__(self, other: Any) -> Jet:
        if not isinstance(other, Jet):
            c = _coef(other)
            h = None if self.h is None else [[_m(e, c) for e in row] for row in self.h]
            return Jet(self.v * c, [_m(e, c) for e in self.g], h)
        o = other
        v = self.v * o.v
        if o is self:
            g = [_m(_m(a, self.v), 2.0) for a in self.g]
        else:
            g = [_a(_m(a, o.v), _m(self.v, b)) for a, b in zip(self.g, o.g, strict=True)]
        h = None
        if self.h is not None:
            n = len(self.g)
            h = [
                [
                    _a(
                        _a(_m(self.h[i][j], o.v), _m(self.v, _hessian(o)[i][j])),
                        _a(_m(self.g[i], o.g[j]), _m(self.g[j], o.g[i])),
                    )
                    if j >= i
                    else 0.0
                    for j in range(n)
                ]
                for i in range(n)
            ]
        return Jet(v, g, h)

    __rmul__ = __mul__

    def apply(self, f0: Any, f1: Any, f2: Any = None) -> Jet:
        """Chain rule for a scalar function with value ``f0``, derivatives ``f1``, ``f2`` (intervals)."""
        d1 = f1(self.v)
        g = [_m(d1, e) for e in self.g]
        h = None
        if self.h is not None:
            d2 = f2(self.v)
            n = len(self.g)
            h = [
                [
                    _a(_m(_m(d2, self.g[i]), self.g[j]), _m(d1, self.h[i][j])) if j >= i else 0.0
                    for j in range(n)
                ]
                for i in range(n)
            ]
        return Jet(f0(self.v), g, h)

    def reciprocal(self) -> Jet:
        """``1 / x`` by the chain rule (derivatives ``-1/x^2``, ``2/x^3``)."""
        return self.apply(
            lambda v: v.reciprocal(), lambda v: -(v.square().reciprocal()), lambda v: 2.0 / (v**3)
        )

    def __truediv__(self, other: Any) -> Jet:
        if not isinstance(other, Jet):
            return self * Interval.of(_coef(other)).reciprocal()
        return self * other.reciprocal()

    def __rtruediv__(self, other: Any) -> Jet:
        return self.reciprocal() * other

    def __pow__(self, p: Any) -> Jet:
        q = p if isinstance(p, Fraction) else Fraction(p)  # exact (p is a double or an integer)
        if q.denominator == 1:
            k = int(q)
            if k == 0:
                return self._const(1.0)
            if k == 1:
                return self
            if k == 2:
                return self * self
            return self.apply(
                lambda v: v**k,
                lambda v: v ** (k - 1) * _coef(k),
                lambda v: v ** (k - 2) * _coef(k * (k - 1)),
            )
        return self.apply(
            lambda v: _real_power(v, q),
            lambda v: _real_power(v, q - 1) * _coef(q),
            lambda v: _real_power(v, q - 2) * _coef(q * (q - 1)),
        )


def _jet_fn(f0: Any, f1: Any, f2: Any) -> Any:
    def fn(x: Any) -> Any:
        if isinstance(x, Jet):
            return x.apply(f0, f1, f2)
        return f0(x)

    return fn


JET = SimpleNamespace(
    name="interval-jet",
    sqrt=_jet_fn(isqrt, lambda v: 0.5 / isqrt(v), lambda v: -0.25 / (v * isqrt(v))),
    sin=_jet_fn(isin, icos, lambda v: -isin(v)),
    cos=_jet_fn(icos, lambda v: -isin(v), lambda v: -icos(v)),
    exp=_jet_fn(iexp, iexp, iexp),
    log=_jet_fn(ilog, lambda v: v.reciprocal(), lambda v: -(v.square().reciprocal())),
    arctan=_jet_fn(
        iarctan,
        lambda v: (1.0 + v.square()).reciprocal(),
        lambda v: -2.0 * v / (1.0 + v.square()).square(),
    ),
    arcsinh=_jet_fn(
        iarcsinh,
        lambda v: isqrt(1.0 + v.square()).reciprocal(),
        lambda v: -v / (1.0 + v.square()) ** 1.5,
    ),
    arctanh=_jet_fn(
        iarctanh,
        lambda v: (1.0 - v.square()).reciprocal(),
        lambda v: 2.0 * v / (1.0 - v.square()).square(),
    ),
    tan=_jet_fn(
        itan, lambda v: 1.0 + itan(v).square(), lambda v: 2.0 * itan(v) * (1.0 + itan(v).square())
    ),
)
"""Jet namespace (first/second-order interval AD) for the functions of :mod:`roa.backend` it supports."""
