"""Vectorised interval arithmetic with outward rounding, an interval namespace, and Taylor jets.

:class:`Interval` holds arrays ``lo <= hi`` (one interval per box, evaluated for many boxes at
once). Every arithmetic result is rounded outward (:func:`round_down`, :func:`round_up`: ``r -+ (|r| (u + 1)
2^-52 + (u + 1) 2^-1022)`` for a result ``r`` within ``u`` ulps of the exact value, one rounded
operation in round-to-nearest; ``u = 1`` covers the correctly rounded IEEE ``+ - * / sqrt``).
Library functions that are not correctly rounded (exp, log, sin, arctan, pow, ...) are assumed
within :data:`LIBM_ULPS` ulps of the exact value; ``tests/proof/test_libm.py`` measures numpy's error
against 50-digit mpmath values and fails if the assumption does not hold on this platform.
``x * x`` on the *same* object is evaluated as a square (tight, never negative).

:data:`INTERVAL` is a namespace in the style of :mod:`roa.model._backend`, so ``system.field(t, x, INTERVAL)``
encloses the field over boxes. Jets (derivative enclosures) build on it in :mod:`roa.proof._jet`.
"""

from __future__ import annotations

from fractions import Fraction
from types import SimpleNamespace
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.nn._ops import Affine

#: Assumed maximal error, in ulps of the exact result, of numpy's transcendental functions
#: (sin, cos, tan, exp, log, log1p, arctan, arcsinh, arctanh, tanh, power). Checked by
#: ``tests/proof/test_libm.py`` against 50-digit mpmath values. The network activations build on it:
#: ``tanh`` is numpy's (endpoints widened by it), ``sigmoid`` and ``softplus`` are interval
#: compositions of ``exp`` and ``log1p`` (each enclosure sound under this assumption alone).
LIBM_ULPS = 4
#: Beyond this ``|x|`` the enclosures of sin and cos are ``[-1, 1]`` and tan the whole line: numpy's
#: values are not used where the argument reduction is hardest (``tests/proof/test_libm.py`` measures
#: 14 ulps for tan at ``6381956970095103 * 2^797``, the double closest to a multiple of pi/2).
TRIG_ARGUMENT_LIMIT = 2.0**40
_INF = np.inf
_EPS = 2.0**-52  # ulp(1)
_TINY = 2.0**-1022  # smallest normal number


def _widening(x: np.ndarray, ulps: float) -> np.ndarray:
    """``|x| (ulps + 1) 2^-52 + (ulps + 1) 2^-1022``, a fresh float array for an array ``x`` (a
    float for a 0-d one; see :func:`round_down`)."""
    d = np.abs(x)  # a new array (or a scalar): updated in place below
    d *= (ulps + 1) * _EPS
    d += (ulps + 1) * _TINY
    return d


def round_down(x: Any, ulps: float = 1) -> np.ndarray:
    """A float ``<=`` every real number within ``ulps`` ulps of ``x`` (a rounded result).

    ``x - (|x| (u + 1) 2^-52 + (u + 1) 2^-1022)`` computed in round-to-nearest: the ``+1`` absorbs
    the rounding of the subtraction itself (at most half an ulp of the result), the absolute term
    the subnormal range. ``x = +inf`` (an overflowed result) gives NaN, which :class:`Interval`
    reads as "no lower bound": sound, if loose. Much faster than :func:`numpy.nextafter` and never
    tighter than ``ulps`` applications of it.
    """
    x = np.asarray(x, dtype=float)
    d = _widening(x, ulps)
    with np.errstate(invalid="ignore"):
        if d.ndim:
            return np.subtract(x, d, out=d)
        return np.asarray(x - d)


def round_up(x: Any, ulps: float = 1) -> np.ndarray:
    """A float ``>=`` every real number within ``ulps`` ulps of ``x`` (mirror of :func:`round_down`)."""
    x = np.asarray(x, dtype=float)
    d = _widening(x, ulps)
    with np.errstate(invalid="ignore"):
        if d.ndim:
            return np.add(x, d, out=d)
        return np.asarray(x + d)


def _round_out(lo: Any, hi: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(round_down(lo), round_up(hi))`` for one rounded operation (``ulps = 1``), the same
    numbers with one error-state switch; the caller holds ``np.errstate(invalid="ignore",
    over="ignore")`` (an overflowed bound is infinite: sound, and not warned about)."""
    dl, dh = _widening(lo, 1), _widening(hi, 1)
    if np.ndim(dl) and np.ndim(dh):
        return np.subtract(lo, dl, out=dl), np.add(hi, dh, out=dh)
    return np.asarray(lo - dl), np.asarray(hi + dh)


def enclose_constant(c: Any) -> Interval:
    """The point interval of a constant, widened when the constant is not exactly a double.

    Python and numpy floats are doubles (taken exactly); integers beyond 2^53, Fractions, long
    doubles and other numbers are enclosed by the neighbouring doubles.
    """
    if isinstance(c, Interval):
        return c
    if isinstance(c, float | np.float64 | np.float32 | np.float16):
        return Interval(float(c))
    if isinstance(c, bool | int | np.integer | Fraction):
        q = Fraction(int(c)) if not isinstance(c, Fraction) else c
        try:
            f = float(q)
        except OverflowError:
            return Interval(
                -_INF if q < 0 else np.finfo(float).max, _INF if q > 0 else -np.finfo(float).max
            )
        if Fraction(f) == q:
            return Interval(f)
        return Interval(round_down(f), round_up(f))  # round-to-nearest: half an ulp away at most
    a = np.asarray(c)
    if a.dtype == np.float64:
        return Interval(a)
    if a.dtype.kind == "c":  # a real quantity only: the imaginary part was dropped silently
        if np.any(a.imag != 0):
            raise RoaInputError(
                f"a complex constant ({c!r}) in a real expression (e.g. a negative number to a "
                "fractional power in the field): write the field with real operations"
            )
        a = a.real
    fa = a.astype(float)
    if (a.dtype.kind == "f" and a.dtype.itemsize <= 4) or (
        a.dtype.kind in "biu" and np.all(np.abs(fa) <= 2.0**53)
    ):
        return Interval(fa)  # exactly representable in a double
    return Interval(round_down(fa), round_up(fa))


class DefersToOther(TypeError):
    """An operand that takes an Interval as a constant of its own arithmetic (a jet)."""


class Interval:
    """Arrays of closed intervals ``[lo, hi]`` with outward-rounded arithmetic."""

    __slots__ = ("lo", "hi")
    __array_priority__ = 1000  # numpy scalars defer to our reflected operators

    def __init__(self, lo: Any, hi: Any = None) -> None:
        lo = np.asarray(lo, dtype=float)
        hi = lo if hi is None else np.asarray(hi, dtype=float)
        if lo.shape != hi.shape:
            lo, hi = (np.array(a) for a in np.broadcast_arrays(lo, hi))
        if not (lo <= hi).all():  # NaN (no information) or inverted
            bad = np.isnan(lo) | np.isnan(hi)
            lo = np.where(bad, -_INF, lo)
            hi = np.where(bad, _INF, hi)
            inverted = lo > hi
            if np.any(inverted):
                k = np.flatnonzero(inverted)[0]
                raise RoaInputError(
                    f"Interval: lower bound > upper bound at {np.count_nonzero(inverted)} entries "
                    f"(first: [{lo.flat[k]!r}, {hi.flat[k]!r}])"
                )
        self.lo, self.hi = lo, hi

    # -- helpers ---------------------------------------------------------------------------------
    @staticmethod
    def of(x: Any) -> Interval:
        """``x`` itself if it is an :class:`Interval`, else an enclosure of the constant(s) ``x``.

        Doubles (Python floats, float arrays) give point intervals ``[x, x]``; integers beyond
        2^53, Fractions and other non-double numbers are enclosed by neighbouring doubles.
        """
        if isinstance(x, Interval):
            return x
        if type(x) is float:
            return Interval(x)
        if getattr(x, "defers_to_interval", False):
            raise DefersToOther  # a jet: the operator returns NotImplemented, the jet's runs
        return enclose_constant(x)

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
        if type(other) is float and other == 0.0:
            return self  # exact
        try:
            o = Interval.of(other)
        except DefersToOther:
            return NotImplemented
        with np.errstate(invalid="ignore", over="ignore"):
            return Interval(*_round_out(self.lo + o.lo, self.hi + o.hi))

    __radd__ = __add__

    def __sub__(self, other: Any) -> Interval:
        if type(other) is float and other == 0.0:
            return self
        try:
            o = Interval.of(other)
        except DefersToOther:
            return NotImplemented
        with np.errstate(invalid="ignore", over="ignore"):
            return Interval(*_round_out(self.lo - o.hi, self.hi - o.lo))

    def __rsub__(self, other: Any) -> Interval:
        try:
            return Interval.of(other) - self
        except DefersToOther:
            return NotImplemented

    def square(self) -> Interval:
        """``x^2`` as one operation: never negative, 0 included when the interval straddles 0."""
        a, b = self.lo * self.lo, self.hi * self.hi
        hi = round_up(np.maximum(a, b))
        lo = np.where((self.lo <= 0) & (self.hi >= 0), 0.0, round_down(np.minimum(a, b)))
        return Interval(np.maximum(lo, 0.0), hi)

    def __mul__(self, other: Any) -> Interval:
        if other is self:
            return self.square()
        if type(other) is float:
            if other == 1.0:
                return self  # exact
            if other == 0.0:
                return Interval(np.zeros(np.shape(self.lo)))  # x * 0 = 0 for every real x
        try:
            o = Interval.of(other)
        except DefersToOther:
            return NotImplemented
        if o.lo.ndim == 0 and (o.lo >= 0 or o.hi <= 0):
            return self._scaled(o)
        if self.lo.ndim == 0 and (self.lo >= 0 or self.hi <= 0):
            return o._scaled(self)
        with np.errstate(invalid="ignore", over="ignore"):
            p1, p2, p3, p4 = self.lo * o.lo, self.lo * o.hi, self.hi * o.lo, self.hi * o.hi
            lo = np.minimum(np.minimum(p1, p2), np.minimum(p3, p4))  # NaN if any product is
            if np.isnan(lo).any():  # 0 * inf: the product's factor is exactly 0
                p = np.stack([p1, p2, p3, p4])
                p = np.where(np.isnan(p), 0.0, p)
                return Interval(*_round_out(p.min(axis=0), p.max(axis=0)))
            return Interval(*_round_out(lo, np.maximum(np.maximum(p1, p2), np.maximum(p3, p4))))

    __rmul__ = __mul__

    def _scaled(self, c: Interval) -> Interval:
        """Product with a scalar interval ``c`` of one sign (2 or 4 products instead of 4 + stack).

        ``c >= 0``: the product is smallest at ``self.lo`` and largest at ``self.hi``; mirrored for
        ``c <= 0``. ``0 * inf`` (NaN) leaves that bound open, as :class:`Interval` reads NaN.
        """
        a, b = float(c.lo), float(c.hi)
        with np.errstate(invalid="ignore", over="ignore"):
            if a >= 0:
                lo = self.lo * a if a == b else np.minimum(self.lo * a, self.lo * b)
                hi = self.hi * a if a == b else np.maximum(self.hi * a, self.hi * b)
            else:
                lo = self.hi * a if a == b else np.minimum(self.hi * a, self.hi * b)
                hi = self.lo * a if a == b else np.maximum(self.lo * a, self.lo * b)
            return Interval(*_round_out(lo, hi))

    def reciprocal(self) -> Interval:
        """``1 / x``; the whole line where the interval contains 0."""
        zero = (self.lo <= 0) & (self.hi >= 0)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            lo = np.where(zero, -_INF, round_down(1.0 / self.hi))
            hi = np.where(zero, _INF, round_up(1.0 / self.lo))
        return Interval(lo, hi)

    def __truediv__(self, other: Any) -> Interval:
        try:
            return self * Interval.of(other).reciprocal()
        except DefersToOther:
            return NotImplemented

    def __rtruediv__(self, other: Any) -> Interval:
        try:
            return Interval.of(other) * self.reciprocal()
        except DefersToOther:
            return NotImplemented

    def __pow__(self, p: Any) -> Interval:
        if isinstance(p, int | np.integer) or float(p).is_integer():
            k = int(p)
            if k == 0:
                return Interval(np.ones_like(self.lo))
            if k < 0:
                return (self ** (-k)).reciprocal()
            if k == 1:
                return self
            if k % 2 == 0:
                return self.square() ** (k // 2) if k > 2 else self.square()
            if k <= 64:
                out = self
                for _ in range(k - 1):
                    out = out * self  # odd power: monotone, product bound is exact enough
            else:  # x * (x^2)^((k-1)/2): an enclosure in O(log k) products
                out = self * (self.square() ** ((k - 1) // 2))
            with np.errstate(over="ignore"):
                lo, hi = self.lo**k, self.hi**k
            # intersected with the (libm pow) endpoint values; NaN bounds stay open
            lo = np.fmax(out.lo, round_down(lo, LIBM_ULPS))
            hi = np.fmin(out.hi, round_up(hi, LIBM_ULPS))
            return Interval(lo, hi)
        p = float(p)
        base_lo, base_hi = np.maximum(self.lo, 0.0), np.maximum(self.hi, 0.0)  # domain x >= 0
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            a, b = base_lo**p, base_hi**p
        lo, hi = (a, b) if p > 0 else (b, a)
        lo, hi = round_down(lo, LIBM_ULPS), round_up(hi, LIBM_ULPS)
        lo = np.where(self.lo < 0, -_INF, lo)  # partly outside the domain: no information
        hi = np.where(self.hi < 0, _INF, hi)  # wholly outside: the whole line, as for NaN
        return Interval(lo, hi)


def _monotone(fn: Any, x: Any, *, increasing: bool = True) -> Interval:
    x = Interval.of(x)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        a, b = fn(x.lo), fn(x.hi)
    lo, hi = (a, b) if increasing else (b, a)
    return Interval(round_down(lo, LIBM_ULPS), round_up(hi, LIBM_ULPS))


def isqrt(x: Any) -> Interval:
    """Enclosure of ``sqrt(x)``; the lower bound is ``-inf`` where ``x`` reaches below 0."""
    x = Interval.of(x)
    lo = round_down(np.sqrt(np.maximum(x.lo, 0.0)))
    hi = round_up(np.sqrt(np.maximum(x.hi, 0.0)))
    return Interval(np.where(x.lo < 0, -_INF, np.maximum(lo, 0.0)), hi)


def iabs(x: Any) -> Interval:
    """Enclosure of ``|x|`` (exact: no rounding is needed)."""
    x = Interval.of(x)
    a, b = np.abs(x.lo), np.abs(x.hi)
    lo = np.where((x.lo <= 0) & (x.hi >= 0), 0.0, np.minimum(a, b))
    return Interval(lo, np.maximum(a, b))


def iminimum(a: Any, b: Any) -> Interval:
    """Enclosure of ``min(a, b)`` (exact: min is increasing in each argument, nothing is rounded)."""
    a, b = Interval.of(a), Interval.of(b)
    return Interval(np.minimum(a.lo, b.lo), np.minimum(a.hi, b.hi))


def imaximum(a: Any, b: Any) -> Interval:
    """Enclosure of ``max(a, b)`` (exact, as :func:`iminimum`)."""
    a, b = Interval.of(a), Interval.of(b)
    return Interval(np.maximum(a.lo, b.lo), np.maximum(a.hi, b.hi))


def iclip(x: Any, lo: Any, hi: Any) -> Interval:
    """Enclosure of ``clip(x, lo, hi) = min(max(x, lo), hi)`` (a saturation; exact)."""
    return iminimum(imaximum(x, lo), hi)


def _periodic(fn: Any, x: Any, peak: float) -> Interval:
    """sin/cos: enclose by endpoint values, 1 if ``peak + 2 k pi`` inside, -1 if ``peak + pi + 2 k pi``."""
    x = Interval.of(x)
    with np.errstate(invalid="ignore"):
        a, b = fn(x.lo), fn(x.hi)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    two_pi = 2 * np.pi
    # (x - peak) / two_pi is off by a few ulps of its value: the tolerance grows with |x|
    size = np.maximum(np.abs(x.lo), np.abs(x.hi))
    tol = 1e-12 + 1e-14 * size
    far = ~(size <= TRIG_ARGUMENT_LIMIT)  # also inf: [-1, 1] without numpy's values
    with np.errstate(invalid="ignore"):
        has_max = np.floor((x.hi - peak) / two_pi + tol) >= np.ceil((x.lo - peak) / two_pi - tol)
        trough = peak + np.pi
        has_min = np.floor((x.hi - trough) / two_pi + tol) >= np.ceil(
            (x.lo - trough) / two_pi - tol
        )
    has_max, has_min = has_max | far, has_min | far
    hi = np.where(has_max, 1.0, np.fmin(round_up(hi, LIBM_ULPS), 1.0))
    lo = np.where(has_min, -1.0, np.fmax(round_down(lo, LIBM_ULPS), -1.0))
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
    ``cos(x)`` contains 0 (so also beyond :data:`TRIG_ARGUMENT_LIMIT`, where it is ``[-1, 1]``);
    otherwise ``cos`` has one sign on ``x``, ``x`` lies in one branch and ``tan`` is increasing
    there, so the (widened) endpoint values enclose it.
    """
    x = Interval.of(x)
    c = icos(x)
    pole = (c.lo <= 0) & (c.hi >= 0)
    with np.errstate(invalid="ignore"):
        a, b = np.tan(x.lo), np.tan(x.hi)
    lo = np.where(pole, -_INF, round_down(a, LIBM_ULPS))
    hi = np.where(pole, _INF, round_up(b, LIBM_ULPS))
    return Interval(lo, hi)


def ilog(x: Any) -> Interval:
    """Enclosure of ``log(x)``; ``-inf`` below where ``x`` reaches 0, the whole line if ``x <= 0``."""
    x = Interval.of(x)
    out = _monotone(np.log, Interval(np.maximum(x.lo, 0.0), np.maximum(x.hi, 0.0)))
    return Interval(np.where(x.lo <= 0, -_INF, out.lo), np.where(x.hi <= 0, _INF, out.hi))


def iexp(x: Any) -> Interval:
    """Enclosure of ``exp(x)`` (increasing; never negative)."""
    out = _monotone(np.exp, x)
    return Interval(np.fmax(out.lo, 0.0), out.hi)


def iarctan(x: Any) -> Interval:
    """Enclosure of ``arctan(x)`` (increasing)."""
    return _monotone(np.arctan, x)


def iarcsinh(x: Any) -> Interval:
    """Enclosure of ``arcsinh(x)`` (increasing)."""
    return _monotone(np.arcsinh, x)


def iarctanh(x: Any) -> Interval:
    """Enclosure of ``arctanh(x)`` (increasing on (-1, 1); NaN endpoints leave a bound open)."""
    return _monotone(np.arctanh, x)


# -- activations of neural networks ----------------------------------------------------------------
def itanh(x: Any) -> Interval:
    """Enclosure of ``tanh(x)``: increasing, numpy's endpoint values widened by :data:`LIBM_ULPS`
    ulps, intersected with ``[-1, 1]``."""
    out = _monotone(np.tanh, x)
    return Interval(np.fmax(out.lo, -1.0), np.fmin(out.hi, 1.0))


def ilog1p(x: Any) -> Interval:
    """Enclosure of ``log(1 + x)`` (increasing; numpy's ``log1p`` within :data:`LIBM_ULPS` ulps);
    ``-inf`` below where ``x`` reaches -1, the whole line if ``x <= -1``."""
    x = Interval.of(x)
    out = _monotone(np.log1p, Interval(np.maximum(x.lo, -1.0), np.maximum(x.hi, -1.0)))
    return Interval(np.where(x.lo <= -1, -_INF, out.lo), np.where(x.hi <= -1, _INF, out.hi))


def isigmoid(x: Any) -> Interval:
    """Enclosure of ``sigmoid(x) = 1 / (1 + exp(-x))``, intersected with ``[0, 1]``.

    The interval expression has one occurrence of ``x`` and is increasing in it, so it is the
    range up to the outward rounding of ``exp`` (:data:`LIBM_ULPS`), ``+`` and ``1 /``: a few ulps,
    also relative to tiny values (``sigmoid(-40) ~ 4e-18``), unlike ``(1 + tanh(x / 2)) / 2``.
    """
    x = Interval.of(x)
    out = (1.0 + iexp(-x)).reciprocal()
    return Interval(np.clip(out.lo, 0.0, 1.0), np.clip(out.hi, 0.0, 1.0))


def isoftplus(x: Any) -> Interval:
    """Enclosure of ``softplus(x) = log(1 + exp(x))`` (increasing): at each endpoint ``p`` the
    interval value of ``max(p, 0) + log1p(exp(-|p|))`` (no overflow), and at least ``max(x, 0)``."""
    x = Interval.of(x)

    def at(p: np.ndarray) -> Interval:
        e = iexp(-iabs(Interval(p)))
        return np.maximum(p, 0.0) + ilog1p(Interval(np.fmax(e.lo, 0.0), np.fmin(e.hi, 1.0)))

    a, b = at(x.lo), at(x.hi)
    return Interval(np.fmax(a.lo, np.maximum(x.lo, 0.0)), b.hi)


def irelu(x: Any) -> Interval:
    """Enclosure of ``relu(x) = max(x, 0)`` (exact)."""
    return imaximum(x, 0.0)


def ileaky_relu(x: Any, alpha: float = 0.01) -> Interval:
    """Enclosure of ``max(x, 0) + alpha min(x, 0)``: exact where ``x >= 0``, ``alpha x`` rounded
    outward below 0 (increasing for ``alpha >= 0``: endpoint values; any other ``alpha`` by the
    interval composition)."""
    x = Interval.of(x)
    alpha = float(alpha)
    if not alpha >= 0:
        return imaximum(x, 0.0) + iminimum(x, 0.0) * alpha
    with np.errstate(invalid="ignore", over="ignore"):
        lo = np.where(x.lo >= 0, x.lo, round_down(alpha * np.minimum(x.lo, 0.0)))
        hi = np.where(x.hi >= 0, x.hi, round_up(alpha * np.minimum(x.hi, 0.0)))
    return Interval(lo, hi)


#: The unit roundoff of round-to-nearest doubles.
_U = 2.0**-53


def interval_affine(W: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> Interval:
    """Enclosure of ``W x + b`` for ``x`` in the boxes ``[lo, hi]`` (shape ``(k, m)``: ``k`` inputs,
    ``m`` boxes), as two matrix products; returns intervals of shape ``(rows of W, m)``.

    With ``W = W+ + W-`` (positive and negative parts) the exact range is
    ``[W+ lo + W- hi + b, W+ hi + W- lo + b]``. Each bound is one dot product of length
    ``p = 2 k + 1`` (``[W+, W-, b] . [lo, hi, 1]``), computed in round-to-nearest in any order
    (BLAS, FMA or not): its error is at most ``gamma_p sum |terms| + p eta`` with
    ``gamma_p = p u / (1 - p u)``, ``u = 2^-53`` and ``eta = 2^-1074`` (Higham, *Accuracy and
    Stability of Numerical Algorithms*, 2nd ed., (3.5) with underflow). The computed sum of
    ``|terms|`` is itself within ``gamma_p`` of the exact one, so ``2 gamma_p`` times it (``p u <
    0.01`` here) plus ``(p + 2) 2^-1022`` bounds the error; the bound is subtracted (added) with
    :func:`round_down` (:func:`round_up`). Infinite box bounds give NaN, read as "no bound".
    """
    W = np.asarray(W, dtype=float)
    b = np.asarray(b, dtype=float)
    k = W.shape[1]
    p = 2 * k + 1
    if not p * _U < 0.01:
        raise RoaInputError(f"interval_affine: {k} inputs is too many for the error bound")
    gamma = p * _U / (1.0 - p * _U)
    Wp, Wn = np.maximum(W, 0.0), np.minimum(W, 0.0)  # exact: the parts are entries of W or 0
    with np.errstate(invalid="ignore", over="ignore"):
        # the sum of |terms| of either bound is at most |W| max(|lo|, |hi|) + |b| (each input
        # enters one bound through W+ or W-, never both): one product for both errors
        err = (np.abs(W) @ np.maximum(np.abs(lo), np.abs(hi)) + np.abs(b)[:, None]) * (
            2.0 * gamma
        ) + (p + 2) * _TINY
        s_lo = Wp @ lo + Wn @ hi + b[:, None]  # the p terms summed in some order
        s_hi = Wp @ hi + Wn @ lo + b[:, None]
        return Interval(round_down(s_lo - err), round_up(s_hi + err))


def interval_network(net: Any, x: list[Any]) -> list[Interval]:
    """The outputs of the network ``net`` (:class:`roa.nn.MLP`, uncentred) over the boxes ``x``
    (intervals or floats): :func:`interval_affine` per affine step and the interval activations
    of :data:`INTERVAL`, so an enclosure of the real network under :data:`LIBM_ULPS`."""
    ivs = [Interval.of(v) for v in x]
    lows = np.broadcast_arrays(*[v.lo for v in ivs], *[v.hi for v in ivs])
    shape = lows[0].shape
    lo = np.stack(lows[: net.n_in]).reshape(net.n_in, -1)
    hi = np.stack(lows[net.n_in :]).reshape(net.n_in, -1)
    h = Interval(lo, hi)
    for op in net.ops:
        if isinstance(op, Affine):
            h = interval_affine(op.W, op.b, h.lo, h.hi)
        else:
            h = getattr(INTERVAL, op.name)(h, *op.args)
    return [Interval(h.lo[i].reshape(shape), h.hi[i].reshape(shape)) for i in range(len(h.lo))]


INTERVAL = SimpleNamespace(
    name="interval",
    interval=Interval,  # the constructor, for code that must not import this module
    network=interval_network,  # a network (roa.nn.MLP) called in this namespace
    sqrt=isqrt,
    abs=iabs,
    sin=isin,
    cos=icos,
    tan=itan,
    exp=iexp,
    log=ilog,
    arctan=iarctan,
    arcsinh=iarcsinh,
    arctanh=iarctanh,
    tanh=itanh,
    sigmoid=isigmoid,
    relu=irelu,
    leaky_relu=ileaky_relu,
    softplus=isoftplus,
    minimum=iminimum,
    maximum=imaximum,
    clip=iclip,
)
"""Interval namespace: ``system.field(t, x, INTERVAL)`` encloses the field over boxes."""


def box_offsets(lo: np.ndarray, hi: np.ndarray, mid: np.ndarray) -> list[Interval]:
    """Intervals enclosing ``x - mid`` for ``x`` in the boxes ``[lo, hi]``, one per coordinate.

    ``lo - mid`` and ``hi - mid`` are rounded outward (at least one ulp), so the centred and
    Taylor forms built on them are strict enclosures even when rounding to nearest would move
    them inward. (Their coefficients, the jet gradients and Hessians, are enclosures too.)

    Parameters
    ----------
    lo, hi : numpy.ndarray
        Box corners, shape ``(m, n)``.
    mid : numpy.ndarray
        Expansion points (any floats inside the boxes), shape ``(m, n)``.
    """
    return [
        Interval(round_down(lo[:, i] - mid[:, i]), round_up(hi[:, i] - mid[:, i]))
        for i in range(lo.shape[1])
    ]
