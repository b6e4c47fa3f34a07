"""Forward-mode Taylor jets over intervals: value, gradient and Hessian enclosures.

:class:`Jet` carries value, gradient and (optionally) Hessian of an expression (forward-mode
automatic differentiation over :class:`roa.proof.Interval`), used for the centred form and
for the second-order proof near the equilibrium. Every jet coefficient is either an
:class:`Interval` (outward rounded) or a Python float that is *exactly* the coefficient (``0.0``, the
seeds ``1.0``, an exactly representable constant, or an exactly representable product or sum of
such floats, checked in rational arithmetic); constants entering a jet are enclosed, never rounded.
:data:`JET` is the namespace of jets in the style of :mod:`roa.model._backend`.
"""

from __future__ import annotations

import contextvars
import math
from collections.abc import Callable
from fractions import Fraction
from types import SimpleNamespace
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.proof._interval import (  # noqa: F401
    Interval,
    enclose_constant,
    iabs,
    iarcsinh,
    iarctan,
    iarctanh,
    iclip,
    icos,
    iexp,
    ileaky_relu,
    ilog,
    imaximum,
    iminimum,
    isigmoid,
    isin,
    isoftplus,
    isqrt,
    itan,
    itanh,
    round_down,
    round_up,
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
    iv = enclose_constant(c)
    if iv.lo.ndim == 0 and iv.lo == iv.hi:
        return float(iv.lo)
    return iv


def _fmul(a: float, b: float) -> Any:
    """``a * b`` of two exact float coefficients: the float if exact, else an enclosure."""
    p = a * b
    if math.isfinite(p) and Fraction(p) == Fraction(a) * Fraction(b):
        return p
    return Interval(a) * b


def add_exact(a: float, b: float) -> Any:
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


def _sq(a: Any) -> Any:
    """The square of a coefficient (an enclosure: a float's square is rounded outward)."""
    if type(a) is float:
        return 0.0 if a == 0.0 else (1.0 if abs(a) == 1.0 else Interval(a).square())
    return Interval.of(a).square()


def _a(a: Any, b: Any) -> Any:
    """Sum of coefficients; exact zeros skipped, float + float only when exact."""
    if type(a) is float:
        if a == 0.0:
            return b
        if type(b) is float:
            return a if b == 0.0 else add_exact(a, b)
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
    a, b = v ** float(round_down(f)), v ** float(round_up(f))
    return Interval(np.minimum(a.lo, b.lo), np.maximum(a.hi, b.hi))


class Jet:
    """Value, gradient and optionally Hessian of an expression.

    ``Jet.variables(box_lo, box_hi)`` seeds the coordinates; arithmetic and the namespace
    :data:`JET` propagate derivatives by the chain rule. ``h`` is ``None`` for first order. The
    value is an :class:`Interval`; a gradient or Hessian entry is an :class:`Interval` or a Python
    float that is exactly the entry (``0.0`` for an exact zero, skipped in arithmetic). Only the
    upper triangle ``h[i][j], j >= i`` of the Hessian is computed (the lower one holds ``0.0``).
    An :class:`Interval` operand (e.g. an uncertain parameter's range) is a constant of the jet.

    Centred jets (``Jet.variables(..., centred=True)``) also carry ``c``, an enclosure of the
    expression at the boxes' midpoints ``m``, and ``d``, enclosures of ``x_i - m_i`` over the boxes.
    The nonsmooth functions (:func:`jminimum`, ...) decide their branch on the tighter range ``v``
    intersected with the centred form ``c + sum_i g_i d_i`` (:meth:`range`): the natural extension
    alone puts many boxes across a kink that their argument never reaches (on the saturated IPC,
    most undecided boxes). ``c`` costs more per evaluation and changes nothing for smooth
    expressions evaluated here, so callers centre the jets of an expression that
    :func:`nonsmooth` finds kinked, and of one that calls a network: the layer jets of
    :mod:`roa.proof._jet_net` take every unit's range (the argument of ``tanh``, ``tanh'``,
    ``tanh''``) from the centred form, much tighter than the natural extension after a layer.
    """

    __slots__ = ("v", "g", "h", "c", "d")
    defers_to_interval = True  # Interval operators return NotImplemented: ours run
    __array_priority__ = 1000

    def __init__(
        self, v: Any, g: list, h: list | None, c: Interval | None = None, d: list | None = None
    ) -> None:
        self.v, self.g, self.h = Interval.of(v), g, h
        self.c, self.d = c, d

    def range(self) -> Interval:
        """The value enclosure ``v`` intersected with the centred form ``c + sum_i g_i d_i``.

        Sound by the mean value theorem (Lebourg's for Lipschitz expressions with kinks): ``g``
        encloses the (generalised) gradient over the box, ``c`` the value at its midpoint.
        """
        if self.c is None or self.d is None:
            return self.v
        cen = self.c
        for gi, di in zip(self.g, self.d, strict=True):
            if not _zero(gi):
                cen = cen + di * gi
        lo, hi = np.maximum(self.v.lo, cen.lo), np.minimum(self.v.hi, cen.hi)
        if not np.all(lo <= hi):  # impossible for enclosures of the same value; be safe
            return self.v
        return Interval(lo, hi)

    @classmethod
    def variables(cls, lo: Any, hi: Any, *, order: int = 1, centred: bool = False) -> list[Jet]:
        """Coordinate jets on the boxes ``[lo, hi]`` (shape ``(m, n)``), up to ``order`` (1 or 2).

        ``centred``: carry midpoint values (see the class doc; for a kinked expression).
        """
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        n = lo.shape[-1]
        centre = centred
        if not (centre and np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):  # finite boxes
            out = []
            for i in range(n):
                g = [1.0 if j == i else 0.0 for j in range(n)]
                h = [[0.0] * n for _ in range(n)] if order >= 2 else None
                out.append(cls(Interval(lo[..., i], hi[..., i]), g, h))
            return out
        with np.errstate(invalid="ignore", over="ignore"):
            mid = np.clip(0.5 * lo + 0.5 * hi, lo, hi)
            d = [Interval(np.fmin(round_down(lo[..., i] - mid[..., i]), 0.0),
                          np.fmax(round_up(hi[..., i] - mid[..., i]), 0.0)) for i in range(n)]  # fmt: skip
        out = []
        for i in range(n):
            g = [1.0 if j == i else 0.0 for j in range(n)]
            h = [[0.0] * n for _ in range(n)] if order >= 2 else None
            out.append(cls(Interval(lo[..., i], hi[..., i]), g, h, Interval(mid[..., i]), d))
        return out

    def _const(self, c: Any) -> Jet:
        if isinstance(c, Jet):
            return c
        n = len(self.g)
        h = [[0.0] * n for _ in range(n)] if self.h is not None else None
        v = Interval.of(_coef(c))
        return Jet(v, [0.0] * n, h, v, self.d)

    def __neg__(self) -> Jet:
        h = None if self.h is None else [[_n(e) for e in row] for row in self.h]
        c = None if self.c is None else -self.c
        return Jet(-self.v, [_n(e) for e in self.g], h, c, self.d)

    def _mid(self, other: Jet, op: Any) -> tuple[Interval | None, list | None]:
        """``c`` and ``d`` of a binary operation (``None`` unless both operands carry ``c``)."""
        if self.c is None or other.c is None:
            return None, None
        return op(self.c, other.c), self.d if self.d is not None else other.d

    def __add__(self, other: Any) -> Jet:
        if not isinstance(other, Jet):
            k = _coef(other)
            c = None if self.c is None else self.c + k
            return Jet(self.v + k, self.g, self.h, c, self.d)
        o = other
        h = (
            None
            if self.h is None
            else [
                [_a(a, b) for a, b in zip(r1, r2, strict=True)]
                for r1, r2 in zip(self.h, _hessian(o), strict=True)
            ]
        )
        c, d = self._mid(o, lambda a, b: a + b)
        return Jet(self.v + o.v, [_a(a, b) for a, b in zip(self.g, o.g, strict=True)], h, c, d)

    __radd__ = __add__

    def __sub__(self, other: Any) -> Jet:
        if not isinstance(other, Jet):
            k = _coef(other)
            c = None if self.c is None else self.c - k
            return Jet(self.v - k, self.g, self.h, c, self.d)
        return self + (-other)

    def __rsub__(self, other: Any) -> Jet:
        return (-self) + other

    def __mul__(self, other: Any) -> Jet:
        if not isinstance(other, Jet):
            c = _coef(other)
            h = None if self.h is None else [[_m(e, c) for e in row] for row in self.h]
            cm = None if self.c is None else self.c * c
            return Jet(self.v * c, [_m(e, c) for e in self.g], h, cm, self.d)
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
        if o is self:
            cm, d = (None, None) if self.c is None else (self.c.square(), self.d)
        else:
            cm, d = self._mid(o, lambda a, b: a * b)
        return Jet(v, g, h, cm, d)

    __rmul__ = __mul__

    def apply(self, f0: Any, f1: Any, f2: Any = None) -> Jet:
        """Chain rule for a scalar function with value ``f0``, derivatives ``f1``, ``f2`` (intervals)."""
        d1 = f1(self.v)
        g = [_m(d1, e) for e in self.g]
        h = None
        if self.h is not None:
            d2 = f2(self.v)
            n = len(self.g)
            # f'' g_i g_j + f' h_ij, with g_i^2 as a square on the diagonal (never negative)
            h = [
                [
                    _a(_m(d2, _sq(self.g[i]) if j == i else _m(self.g[i], self.g[j])),
                       _m(d1, self.h[i][j])) if j >= i else 0.0
                    for j in range(n)
                ]
                for i in range(n)
            ]  # fmt: skip
        c = None if self.c is None else f0(self.c)
        return Jet(f0(self.v), g, h, c, self.d)

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


# -- nonsmooth functions: min, max, clip, abs, relu, leaky_relu -------------------------------------
# On a box where the branch is decided (e.g. a <= b everywhere for min(a, b)) the function *is* one
# branch, a smooth composition, and takes that branch's jet. Elsewhere (the box straddles the kink):
#
# * gradient: the hull of the branches' gradients, entry by entry. It holds Clarke's generalised
#   gradient at every point of the box (d min(a, b) in conv{d a, d b}; the sum, product and chain
#   rules hold as inclusions for Lipschitz functions), so by Lebourg's mean value theorem
#   f(x) - f(m) = zeta . (x - m) with zeta in the enclosure: the centred form stays a proof, and the
#   gradient holds every one-sided directional derivative (e.g. clip' in [0, 1] across a bound);
# * Hessian: the whole line (the kink's second derivative is a Dirac mass), so a second-order Taylor
#   form or an interval-Hessian (negative definiteness) test on such a box proves nothing. Entries
#   (i, j) where neither branch depends on x_i (or on x_j) -- both gradient entries exact zeros --
#   keep the branches' hull: the kink does not move along those coordinates.
def _decided(take_a: Any, take_b: Any, a: Any, b: Any, kink: Any) -> Any:
    """A coefficient that is ``a`` where ``take_a``, ``b`` where ``take_b``, ``kink`` elsewhere."""
    if type(a) is float and type(b) is float and type(kink) is float and a == b == kink:
        return a  # the same exact coefficient everywhere (e.g. an exact zero stays symbolic)
    if np.all(take_a):
        return a
    if np.all(take_b):
        return b
    A, B, K = Interval.of(a), Interval.of(b), Interval.of(kink)
    lo = np.where(take_a, A.lo, np.where(take_b, B.lo, K.lo))
    hi = np.where(take_a, A.hi, np.where(take_b, B.hi, K.hi))
    return Interval(lo, hi)


def _hull(a: Any, b: Any) -> Any:
    if type(a) is float and type(b) is float and a == b:
        return a  # equal exact coefficients (e.g. both 0.0): the hull is the coefficient
    A, B = Interval.of(a), Interval.of(b)
    return Interval(np.minimum(A.lo, B.lo), np.maximum(A.hi, B.hi))


_WHOLE_LINE = Interval(-np.inf, np.inf)
#: The kinks met while :func:`nonsmooth` evaluates an expression (None outside it).
_KINKS: contextvars.ContextVar[list[str] | None] = contextvars.ContextVar("kinks", default=None)


def _kink(name: str) -> None:
    seen = _KINKS.get()
    if seen is not None:
        seen.append(name)


def nonsmooth(expression: Callable[[], Any]) -> bool:
    """Whether evaluating ``expression()`` (on jets) meets a nonsmooth function (min, max, clip,
    abs, relu, leaky_relu): its jets are then worth centring (:meth:`Jet.variables`). No state
    outlives the call."""
    seen: list[str] = []
    token = _KINKS.set(seen)
    try:
        expression()
    finally:
        _KINKS.reset(token)
    return bool(seen)


def _zero(e: Any) -> bool:
    return type(e) is float and e == 0.0


def _branch(
    a: Jet, b: Jet, take_a: Any, take_b: Any, v: Interval, c: Interval | None = None
) -> Jet:
    """The jet of a function equal to ``a`` where ``take_a``, ``b`` where ``take_b`` (per box),
    with a kink between them elsewhere; value enclosure ``v``, midpoint enclosure ``c`` (see the
    comment above)."""
    n = len(a.g)
    g = [_decided(take_a, take_b, a.g[i], b.g[i], _hull(a.g[i], b.g[i])) for i in range(n)]
    h = None
    if a.h is not None:
        ah, bh = a.h, _hessian(b)
        flat = [_zero(a.g[i]) and _zero(b.g[i]) for i in range(n)]  # the kink ignores x_i
        h = [
            [
                _decided(take_a, take_b, ah[i][j], bh[i][j],
                         _hull(ah[i][j], bh[i][j]) if flat[i] or flat[j] else _WHOLE_LINE)
                if j >= i
                else 0.0
                for j in range(n)
            ]
            for i in range(n)
        ]  # fmt: skip
    return Jet(v, g, h, c, a.d if a.d is not None else b.d)


def _as_jets(a: Any, b: Any) -> tuple[Jet, Jet]:
    _kink("min/max")
    if isinstance(a, Jet):
        return a, a._const(b)
    return b._const(a), b


def _extreme(a: Any, b: Any, fn: Any, lower: bool) -> Any:
    """``fn(a, b)`` for ``fn`` the interval minimum (``lower``) or maximum, on jets: the jet of
    the argument that is the extreme on the whole box, else the range of ``fn``."""
    if not (isinstance(a, Jet) or isinstance(b, Jet)):
        return fn(a, b)
    a, b = _as_jets(a, b)
    ra, rb = a.range(), b.range()
    c = None if a.c is None or b.c is None else fn(a.c, b.c)
    if lower:
        return _branch(a, b, ra.hi <= rb.lo, rb.hi <= ra.lo, fn(ra, rb), c)
    return _branch(a, b, ra.lo >= rb.hi, rb.lo >= ra.hi, fn(ra, rb), c)


def jminimum(a: Any, b: Any) -> Any:
    """``min(a, b)`` for jets (or an interval if neither argument is a jet)."""
    return _extreme(a, b, iminimum, True)


def jmaximum(a: Any, b: Any) -> Any:
    """``max(a, b)`` for jets (or an interval if neither argument is a jet)."""
    return _extreme(a, b, imaximum, False)


def jclip(x: Any, lo: Any, hi: Any) -> Any:
    """``clip(x, lo, hi) = min(max(x, lo), hi)`` for jets: derivative 1 inside, 0 beyond a bound,
    ``[0, 1]`` times the argument's on a box across a bound."""
    if not any(isinstance(e, Jet) for e in (x, lo, hi)):
        return iclip(x, lo, hi)
    return jminimum(jmaximum(x, lo), hi)


def jabs(x: Any) -> Any:
    """``|x|`` for jets: ``x`` where ``x >= 0`` on the box, ``-x`` where ``x <= 0``, else the kink."""
    if not isinstance(x, Jet):
        return iabs(x)
    _kink("abs")
    r = x.range()
    c = None if x.c is None else iabs(x.c)
    return _branch(x, -x, r.lo >= 0, r.hi <= 0, iabs(r), c)


def jrelu(x: Any) -> Any:
    """``relu(x) = max(x, 0)`` for jets: the jet of ``x`` where ``x >= 0`` on the box, the zero
    jet where ``x <= 0``, else the kink (gradient ``[0, 1]`` times ``x``'s, Hessian unbounded)."""
    if not isinstance(x, Jet):
        return imaximum(x, 0.0)
    return jmaximum(x, 0.0)


def jleaky_relu(x: Any, alpha: float = 0.01) -> Any:
    """``max(x, 0) + alpha min(x, 0)`` for jets: ``x`` where ``x >= 0`` on the box, ``alpha x``
    where ``x <= 0``, else the kink (the hull of ``1`` and ``alpha`` times ``x``'s gradient: the
    generalised gradient; Hessian unbounded)."""
    if not isinstance(x, Jet):
        return ileaky_relu(x, alpha)
    _kink("leaky_relu")
    r = x.range()
    c = None if x.c is None else ileaky_relu(x.c, alpha)
    return _branch(x, x * float(alpha), r.lo >= 0, r.hi <= 0, ileaky_relu(r, alpha), c)


def _dtanh(v: Interval) -> Interval:
    """``tanh' = 1 - tanh^2`` in ``[0, 1]``."""
    t = itanh(v)
    d = 1.0 - t.square()
    return Interval(np.fmax(d.lo, 0.0), np.fmin(d.hi, 1.0))


def _d2tanh(v: Interval) -> Interval:
    """``tanh'' = -2 tanh (1 - tanh^2)``."""
    return -2.0 * itanh(v) * _dtanh(v)


def _dsigmoid(v: Interval) -> Interval:
    """``sigmoid' = sigmoid (1 - sigmoid) = (1 - tanh(x / 2)^2) / 4`` in ``[0, 1/4]`` (one
    occurrence of the argument: no dependency loss)."""
    d = _dtanh(v * 0.5) * 0.25
    return Interval(np.fmax(d.lo, 0.0), np.fmin(d.hi, 0.25))


def _d2sigmoid(v: Interval) -> Interval:
    """``sigmoid'' = sigmoid' (1 - 2 sigmoid) = -tanh(x / 2) (1 - tanh(x / 2)^2) / 4``."""
    return -0.25 * itanh(v * 0.5) * _dtanh(v * 0.5)


def _jet_fn(f0: Any, f1: Any, f2: Any) -> Any:
    def fn(x: Any) -> Any:
        if isinstance(x, Jet):
            return x.apply(f0, f1, f2)
        return f0(x)

    return fn


JET_FUNCTIONS = SimpleNamespace(
    name="interval-jet",
    interval=Interval,  # the constructor, for code that must not import this module
    abs=jabs,
    minimum=jminimum,
    maximum=jmaximum,
    clip=jclip,
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
    tanh=_jet_fn(itanh, _dtanh, _d2tanh),
    sigmoid=_jet_fn(isigmoid, _dsigmoid, _d2sigmoid),
    softplus=_jet_fn(isoftplus, isigmoid, _dsigmoid),
    relu=jrelu,
    leaky_relu=jleaky_relu,
)
"""Jet namespace (first/second-order interval AD) for the functions of :mod:`roa.model._backend` it supports."""
