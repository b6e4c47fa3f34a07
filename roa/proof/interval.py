"""Vectorised interval arithmetic with outward rounding, an interval namespace, and Taylor jets.

:class:`Interval` holds arrays ``lo <= hi`` (one interval per box, evaluated for many boxes at
once). Every arithmetic result is rounded outward by one ulp with :func:`numpy.nextafter` (IEEE
``+ - * / sqrt`` are correctly rounded, so one ulp outward is an enclosure); library functions that
are not correctly rounded (exp, log, arctan, ...) are widened by :data:`LIBM_ULPS` ulps.
``x * x`` on the *same* object is evaluated as a square (tight, never negative).

:data:`INTERVAL` is a namespace in the style of :mod:`roa.backend`, so ``system.field(t, x, INTERVAL)``
encloses the field over boxes. :class:`Jet` carries value, gradient and (optionally) Hessian of an
expression as intervals (forward-mode automatic differentiation), used for the centred form and
for the second-order proof near the equilibrium.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np

LIBM_ULPS = 4
_INF = np.inf


def _down(x: np.ndarray, k: int = 1) -> np.ndarray:
    for _ in range(k):
        x = np.nextafter(x, -_INF)
    return x


def _up(x: np.ndarray, k: int = 1) -> np.ndarray:
    for _ in range(k):
        x = np.nextafter(x, _INF)
    return x


class Interval:
    """Arrays of closed intervals ``[lo, hi]`` with outward-rounded arithmetic."""

    __slots__ = ("lo", "hi")
    __array_priority__ = 1000  # numpy scalars defer to our reflected operators

    def __init__(self, lo: Any, hi: Any = None) -> None:
        lo = np.asarray(lo, dtype=float)
        hi = lo if hi is None else np.asarray(hi, dtype=float)
        bad = np.isnan(lo) | np.isnan(hi)
        self.lo = np.where(bad, -_INF, lo)
        self.hi = np.where(bad, _INF, hi)
        inverted = self.lo > self.hi
        if np.any(inverted):
            k = np.flatnonzero(inverted)[0]
            raise ValueError(
                f"Interval: lower bound > upper bound at {np.count_nonzero(inverted)} entries "
                f"(first: [{self.lo.flat[k]!r}, {self.hi.flat[k]!r}])"
            )

    # -- helpers ---------------------------------------------------------------------------------
    @staticmethod
    def of(x: Any) -> Interval:
        """``x`` itself if it is an :class:`Interval`, else the point interval(s) ``[x, x]``."""
        return x if isinstance(x, Interval) else Interval(x)

    @property
    def mid(self) -> np.ndarray:
        return 0.5 * (self.lo + self.hi)

    @property
    def width(self) -> np.ndarray:
        return self.hi - self.lo

    def contains(self, x: Any) -> np.ndarray:
        """Boolean mask: ``lo <= x <= hi`` elementwise."""
        return (self.lo <= x) & (x <= self.hi)

    def __repr__(self) -> str:
        return f"Interval({self.lo!r}, {self.hi!r})"

    # -- arithmetic ------------------------------------------------------------------------------
    def __neg__(self) -> Interval:
        return Interval(-self.hi, -self.lo)

    def __pos__(self) -> Interval:
        return self

    def __add__(self, other: Any) -> Interval:
        o = Interval.of(other)
        return Interval(_down(self.lo + o.lo), _up(self.hi + o.hi))

    __radd__ = __add__

    def __sub__(self, other: Any) -> Interval:
        o = Interval.of(other)
        return Interval(_down(self.lo - o.hi), _up(self.hi - o.lo))

    def __rsub__(self, other: Any) -> Interval:
        return Interval.of(other) - self

    def square(self) -> Interval:
        """``x^2`` as one operation: never negative, 0 included when the interval straddles 0."""
        a, b = self.lo * self.lo, self.hi * self.hi
        hi = _up(np.maximum(a, b))
        lo = np.where((self.lo <= 0) & (self.hi >= 0), 0.0, _down(np.minimum(a, b)))
        return Interval(np.maximum(lo, 0.0), hi)

    def __mul__(self, other: Any) -> Interval:
        if other is self:
            return self.square()
        o = Interval.of(other)
        with np.errstate(invalid="ignore"):
            p = np.stack([self.lo * o.lo, self.lo * o.hi, self.hi * o.lo, self.hi * o.hi])
        p = np.where(np.isnan(p), 0.0, p)  # 0 * inf: the product's factor is exactly 0
        return Interval(_down(p.min(axis=0)), _up(p.max(axis=0)))

    __rmul__ = __mul__

    def reciprocal(self) -> Interval:
        """``1 / x``; the whole line where the interval contains 0."""
        zero = (self.lo <= 0) & (self.hi >= 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            lo = np.where(zero, -_INF, _down(1.0 / self.hi))
            hi = np.where(zero, _INF, _up(1.0 / self.lo))
        return Interval(lo, hi)

    def __truediv__(self, other: Any) -> Interval:
        return self * Interval.of(other).reciprocal()

    def __rtruediv__(self, other: Any) -> Interval:
        return Interval.of(other) * self.reciprocal()

    def __pow__(self, p: Any) -> Interval:
        if isinstance(p, int | np.integer) or float(p).is_integer():
            k = int(p)
            if k == 0:
                return Interval(np.ones_like(self.lo))
            if k < 0:
                return (self ** (-k)).reciprocal()
            if k % 2 == 0:
                return self.square() ** (k // 2) if k > 2 else self.square()
            out = self
            for _ in range(k - 1):
                out = out * self  # odd power: monotone, product bound is exact enough
            lo, hi = self.lo**k, self.hi**k
            return Interval(np.maximum(out.lo, _down(lo, k)), np.minimum(out.hi, _up(hi, k)))
        p = float(p)
        base = Interval(np.maximum(self.lo, 0.0), np.maximum(self.hi, 0.0))  # domain x >= 0
        with np.errstate(divide="ignore", invalid="ignore"):
            a, b = base.lo**p, base.hi**p
        lo, hi = (a, b) if p > 0 else (b, a)
        out = Interval(_down(lo, LIBM_ULPS), _up(hi, LIBM_ULPS))
        out.lo[self.lo < 0] = -_INF  # partly outside the domain: no information
        out.hi[self.hi < 0] = _INF  # wholly outside: the whole line, as for NaN
        return out


def _monotone(fn: Any, x: Any, *, increasing: bool = True) -> Interval:
    x = Interval.of(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = fn(x.lo), fn(x.hi)
    lo, hi = (a, b) if increasing else (b, a)
    return Interval(_down(lo, LIBM_ULPS), _up(hi, LIBM_ULPS))


def isqrt(x: Any) -> Interval:
    """Enclosure of ``sqrt(x)``; the lower bound is ``-inf`` where ``x`` reaches below 0."""
    x = Interval.of(x)
    out = Interval(_down(np.sqrt(np.maximum(x.lo, 0.0))), _up(np.sqrt(np.maximum(x.hi, 0.0))))
    out.lo[x.lo < 0] = -_INF
    return out


def iabs(x: Any) -> Interval:
    """Enclosure of ``|x|`` (exact: no rounding is needed)."""
    x = Interval.of(x)
    a, b = np.abs(x.lo), np.abs(x.hi)
    lo = np.where((x.lo <= 0) & (x.hi >= 0), 0.0, np.minimum(a, b))
    return Interval(lo, np.maximum(a, b))


def _periodic(fn: Any, x: Any, peak: float) -> Interval:
    """sin/cos: enclose by endpoint values, 1 if ``peak + 2 k pi`` inside, -1 if ``peak + pi + 2 k pi``."""
    x = Interval.of(x)
    a, b = fn(x.lo), fn(x.hi)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    two_pi = 2 * np.pi
    # (x - peak) / two_pi is off by a few ulps of its value: the tolerance grows with |x|
    tol = 1e-12 + 1e-14 * np.maximum(np.abs(x.lo), np.abs(x.hi))
    has_max = np.floor((x.hi - peak) / two_pi + tol) >= np.ceil((x.lo - peak) / two_pi - tol)
    trough = peak + np.pi
    has_min = np.floor((x.hi - trough) / two_pi + tol) >= np.ceil((x.lo - trough) / two_pi - tol)
    hi = np.where(has_max, 1.0, np.minimum(_up(hi, LIBM_ULPS), 1.0))
    lo = np.where(has_min, -1.0, np.maximum(_down(lo, LIBM_ULPS), -1.0))
    return Interval(lo, hi)


def isin(x: Any) -> Interval:
    """Enclosure of ``sin(x)``: endpoint values, and +-1 where a peak or trough is inside."""
    return _periodic(np.sin, x, np.pi / 2)


def icos(x: Any) -> Interval:
    """Enclosure of ``cos(x)``: endpoint values, and +-1 where a peak or trough is inside."""
    return _periodic(np.cos, x, 0.0)


def itan(x: Any) -> Interval:
    """Enclosure of ``tan(x)``; the whole line where the box may contain a pole.

    A pole ``pi/2 + k pi`` may lie in ``x`` exactly when the rigorous enclosure :func:`icos` of
    ``cos(x)`` contains 0; otherwise ``cos`` has one sign on ``x``, ``x`` lies in one branch and
    ``tan`` is increasing there, so the (widened) endpoint values enclose it.
    """
    x = Interval.of(x)
    c = icos(x)
    pole = (c.lo <= 0) & (c.hi >= 0)
    with np.errstate(invalid="ignore"):
        a, b = np.tan(x.lo), np.tan(x.hi)
    lo = np.where(pole, -_INF, _down(a, LIBM_ULPS))
    hi = np.where(pole, _INF, _up(b, LIBM_ULPS))
    return Interval(lo, hi)


def ilog(x: Any) -> Interval:
    """Enclosure of ``log(x)``; ``-inf`` below where ``x`` reaches 0, the whole line if ``x <= 0``."""
    x = Interval.of(x)
    out = _monotone(np.log, Interval(np.maximum(x.lo, 0.0), np.maximum(x.hi, 0.0)))
    out.lo[x.lo <= 0] = -_INF
    out.hi[x.hi <= 0] = _INF
    return out


INTERVAL = SimpleNamespace(
    name="interval",
    sqrt=isqrt,
    abs=iabs,
    sin=isin,
    cos=icos,
    tan=itan,
    exp=lambda x: _monotone(np.exp, x),
    log=ilog,
    arctan=lambda x: _monotone(np.arctan, x),
    arcsinh=lambda x: _monotone(np.arcsinh, x),
    arctanh=lambda x: _monotone(np.arctanh, x),
)
"""Interval namespace: ``system.field(t, x, INTERVAL)`` encloses the field over boxes."""


# -- forward-mode jets over intervals ---------------------------------------------------------------
def _m(a: Any, b: Any) -> Any:
    """Product that keeps exact zeros (float 0.0) symbolic: a sparse-gradient shortcut."""
    if (isinstance(a, float) and a == 0.0) or (isinstance(b, float) and b == 0.0):
        return 0.0
    if isinstance(a, float) and a == 1.0:
        return b
    if isinstance(b, float) and b == 1.0:
        return a
    return a * b


def _a(a: Any, b: Any) -> Any:
    if isinstance(a, float) and a == 0.0:
        return b
    if isinstance(b, float) and b == 0.0:
        return a
    return a + b


def _n(a: Any) -> Any:
    return 0.0 if isinstance(a, float) and a == 0.0 else -a


def _hessian(j: Jet) -> list:
    """The Hessian of a second-order jet (jets of mixed order are a programming error)."""
    if j.h is None:
        raise ValueError("jet arithmetic mixes first- and second-order jets")
    return j.h


class Jet:
    """Value, gradient and optionally Hessian of an expression, each entry an :class:`Interval`.

    ``Jet.variables(box_lo, box_hi)`` seeds the coordinates; arithmetic and the namespace
    :data:`JET` propagate derivatives by the chain rule. ``h`` is ``None`` for first order.
    Entries that are exactly zero are stored as the float ``0.0`` and skipped. Only the upper
    triangle ``h[i][j], j >= i`` of the Hessian is computed (the lower one holds ``0.0``).
    """

    __slots__ = ("v", "g", "h")
    __array_priority__ = 1000

    def __init__(self, v: Any, g: list, h: list | None) -> None:
        self.v, self.g, self.h = v, g, h

    @classmethod
    def variables(cls, lo: np.ndarray, hi: np.ndarray, *, order: int = 1) -> list[Jet]:
        """Coordinate jets on the boxes ``[lo, hi]`` (shape ``(m, n)``), up to ``order`` (1 or 2)."""
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
        return Jet(c, [0.0] * n, h)

    def __neg__(self) -> Jet:
        h = None if self.h is None else [[_n(e) for e in row] for row in self.h]
        return Jet(-self.v, [_n(e) for e in self.g], h)

    def __add__(self, other: Any) -> Jet:
        if not isinstance(other, Jet):
            return Jet(self.v + other, self.g, self.h)
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
        return self + (-self._const(other))

    def __rsub__(self, other: Any) -> Jet:
        return self._const(other) + (-self)

    def __mul__(self, other: Any) -> Jet:
        if not isinstance(other, Jet):
            c = other
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

    def __truediv__(self, other: Any) -> Jet:
        if not isinstance(other, Jet):
            return self * (1.0 / Interval.of(other))
        return self * other.apply(
            lambda v: v.reciprocal(), lambda v: -(v.square().reciprocal()), lambda v: 2.0 / (v**3)
        )

    def __rtruediv__(self, other: Any) -> Jet:
        return self._const(other) / self

    def __pow__(self, p: Any) -> Jet:
        p = float(p)
        if p == 2.0:
            return self * self
        return self.apply(
            lambda v: v**p, lambda v: p * v ** (p - 1), lambda v: p * (p - 1) * v ** (p - 2)
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
    exp=_jet_fn(INTERVAL.exp, INTERVAL.exp, INTERVAL.exp),
    log=_jet_fn(ilog, lambda v: v.reciprocal(), lambda v: -(v.square().reciprocal())),
    arctan=_jet_fn(
        INTERVAL.arctan,
        lambda v: (1.0 + v.square()).reciprocal(),
        lambda v: -2.0 * v / (1.0 + v.square()).square(),
    ),
    arcsinh=_jet_fn(
        INTERVAL.arcsinh,
        lambda v: isqrt(1.0 + v.square()).reciprocal(),
        lambda v: -v / (1.0 + v.square()) ** 1.5,
    ),
    tan=_jet_fn(
        itan, lambda v: 1.0 + itan(v).square(), lambda v: 2.0 * itan(v) * (1.0 + itan(v).square())
    ),
)
"""Jet namespace (first/second-order interval AD) for the functions of :mod:`roa.backend` it supports."""
