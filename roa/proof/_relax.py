"""Linear relaxations on boxes with outward rounding: a namespace, and CROWN through networks.

A :class:`Lin` holds, for ``m`` boxes at once, a lower and an upper affine function of the
offsets ``d = x - mid`` (``mid`` the box centres, ``|d_i| <= r_i`` on the box) and an interval::

    lA . d + lc  <=  q(x)  <=  uA . d + uc,      q(x) in iv,      for every x of the box.

:data:`LINEAR` is a namespace in the style of :mod:`roa.model._backend`: a field or a Lyapunov candidate
evaluated on :func:`variables` gives such bounds of the exact real expression. What each step does:

* sums and float multiples: the affine functions combined; products of two bounded quantities:
  the McCormick planes (``(p - p_lo)(q - q_lo) >= 0`` and its three mirrors), per box the pair
  with the better bound over the box;
* an elementwise function ``f`` of a quantity known to lie in ``[l, u]`` on the box (the
  interval meet of ``iv`` and the affine bounds): lines ``a z + b`` below and above ``f`` on
  ``[l, u]``, the slope ``a`` any float (the chord's), the offset ``b`` proved for that slope
  (below); then composed with the affine bounds of the argument by the sign of ``a``;
* a network (:class:`roa.nn.MLP`, called in this namespace): **CROWN** -- each activation
  relaxed by lines over its pre-activation interval, the bounds of a layer back-substituted
  through every layer before it down to the network's inputs (so the relaxations of all units
  enter at once, with the signs of the weights of the layers above), then composed with the
  affine bounds of the inputs. Pre-activation intervals come from the same back-substitution
  (intersected with the interval product :func:`roa.proof.interval_affine`).

**Offsets proved for a float slope.** ReLU, leaky ReLU, abs and clip are piecewise linear:
``f(z) - a z`` takes its extrema over ``[l, u]`` at the ends or a kink inside, evaluated in
interval arithmetic. A smooth ``f`` (tanh, sigmoid, softplus, sin, cos, exp, ...) is split into
:data:`PIECES` pieces of ``[l, u]``; on a piece ``P`` with centre ``p``,
``f(z) - a z in f(p) - a p + (f'(P) - a)(P - p)`` (mean value theorem; the interval enclosures of
:data:`roa.proof.INTERVAL` for ``f`` and ``f'``); the least (largest) lower (upper)
end over the pieces is the offset. Where a bound is not finite the step falls back to the
interval (slope 0).

**Rounding.** Every affine function is computed in round-to-nearest from float slopes and
offsets; the error of each computed coefficient against the exact combination is at most
``gamma_K`` times the sum of the magnitudes combined (Higham (3.5), ``K`` terms, with underflow),
so the error of the computed function over the box is at most ``2 gamma_K`` times the same
combination of magnitudes evaluated at ``|d_i| = r_i``, plus the underflow part ``(K + 2)
2^-1022 (1 + sum_i r_i)`` (each coefficient may be off by ``K 2^-1075`` absolutely, and it is
multiplied by ``d_i``; likewise with the magnitudes of a layer's values in a network); it is
subtracted from the lower and added to the upper offset with :func:`~roa.proof.round_down`
/ :func:`~roa.proof.round_up`. The products of back-substitution through a network are
matrix products (BLAS, any summation order): their error is bounded the same way from the
products of the magnitudes (``|Lambda| |W|`` times the magnitude bound of the layer's values).
The libm functions are assumed within :data:`~roa.proof.LIBM_ULPS` ulps, as for the
intervals.

Why written here rather than taken from auto_LiRPA: auto_LiRPA computes its bounds in float32 or
float64 with round-to-nearest and no error terms, so its bounds are not enclosures of the real
network (and it brings PyTorch); the bound propagation needed here is a few hundred lines of numpy.
"""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Callable, Iterator, Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np

from roa.proof._interval import (
    INTERVAL,
    Interval,
    interval_affine,
    interval_network,
    round_down,
    round_up,
)

_U = 2.0**-53
_TINY = 2.0**-1022
#: Pieces of the argument's interval on which the offsets of a smooth function are proved.
PIECES = 3


def _gamma2(k: int) -> float:
    """``2 gamma_k`` slightly rounded up (``gamma_k = k u / (1 - k u)``)."""
    return 2.0 * (k * _U / (1.0 - k * _U)) * (1.0 + 1e-6)


def _abs_dot(A: np.ndarray, r: np.ndarray) -> np.ndarray:
    """An upper bound of ``sum_i |A_i| r_i`` over the last axis (``r >= 0``)."""
    k = A.shape[-1]
    s = np.sum(np.abs(A) * r, axis=-1)
    return round_up(s * (1.0 + _gamma2(k + 1)) + (k + 1) * _TINY)


def _underflow(k: int, mag: np.ndarray) -> np.ndarray:
    """``k 2^-1022 (1 + sum_i mag_i)``: a bound of the underflow part of the error of an affine
    function whose coefficients are sums of at most ``k`` products, each off by at most
    ``2^-1075`` absolutely, the coefficients multiplied by values ``|z_i| <= mag_i`` (last axis).
    It exceeds that part by a factor ``2^53``, so the float evaluation of the sum needs no
    rounding term. Without the factor ``1 + sum mag`` a coefficient that underflows to 0 would
    lose its whole term over a wide box (``(x 1e-200) 1e-200`` on ``|x| <= 1e300``)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return (k * _TINY) * (1.0 + np.sum(mag, axis=-1))


class Lin:
    """Affine lower/upper bounds in the box offsets and an interval, for ``m`` boxes (module doc).

    ``r`` (shape ``(m, n)``) is shared by every quantity of one evaluation."""

    __slots__ = ("lA", "lc", "uA", "uc", "iv", "r")
    __array_ufunc__ = None  # numpy scalars and arrays defer to our reflected operators
    defers_to_interval = True  # Interval's operators return NotImplemented: ours run

    def __init__(self, lA: Any, lc: Any, uA: Any, uc: Any, iv: Interval, r: np.ndarray) -> None:
        self.lA, self.lc, self.uA, self.uc, self.iv, self.r = lA, lc, uA, uc, iv, r

    # -- bounds -----------------------------------------------------------------------------------
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(lo, hi)``: the interval meet of ``iv`` and the affine bounds over the box."""
        with np.errstate(invalid="ignore", over="ignore"):
            lo = round_down(self.lc - _abs_dot(self.lA, self.r))
            hi = round_up(self.uc + _abs_dot(self.uA, self.r))
        lo = np.where(np.isnan(lo), -np.inf, lo)
        hi = np.where(np.isnan(hi), np.inf, hi)
        return np.maximum(lo, self.iv.lo), np.minimum(hi, self.iv.hi)

    def range(self) -> Interval:
        lo, hi = self.bounds()
        return Interval(lo, np.maximum(lo, hi))

    @classmethod
    def const(cls, c: Any, r: np.ndarray) -> Lin:
        """A constant (float, array or Interval per box or scalar)."""
        iv = Interval.of(c)
        m, n = r.shape
        lo = np.broadcast_to(iv.lo, (m,)).astype(float)
        hi = np.broadcast_to(iv.hi, (m,)).astype(float)
        z = np.zeros((m, n))
        return cls(z, lo, z, hi, Interval(lo, hi), r)

    def _of(self, other: Any) -> Lin:
        return other if isinstance(other, Lin) else Lin.const(other, self.r)

    # -- arithmetic -------------------------------------------------------------------------------
    def __add__(self, other: Any) -> Lin:
        if type(other) is float and other == 0.0:
            return self
        o = self._of(other)
        one = np.ones(len(self.lc))
        return combine([(one, one, self), (one, one, o)], self.iv + o.iv)

    __radd__ = __add__

    def __neg__(self) -> Lin:
        return Lin(-self.uA, -self.uc, -self.lA, -self.lc, -self.iv, self.r)

    def __sub__(self, other: Any) -> Lin:
        if type(other) is float and other == 0.0:
            return self
        return self + (-self._of(other))

    def __rsub__(self, other: Any) -> Lin:
        return self._of(other) - self

    def __mul__(self, other: Any) -> Lin:
        if isinstance(other, Lin):
            if other is self:
                return self.square()
            return _mccormick(self, other)
        if type(other) is float or isinstance(other, int | np.floating):
            s = float(other)
            if s == 1.0:
                return self
            v = np.full(len(self.lc), s)
            return combine([(v, v, self)], self.iv * s)
        iv = Interval.of(other)
        if np.all(iv.lo == iv.hi):  # exact floats per box
            v = np.broadcast_to(iv.lo, (len(self.lc),)).astype(float)
            return combine([(v, v, self)], self.iv * iv)
        return _mccormick(self, Lin.const(iv, self.r))

    __rmul__ = __mul__

    def square(self) -> Lin:
        return _unary(self, _SQUARE)

    def __truediv__(self, other: Any) -> Lin:
        if isinstance(other, Lin):
            return self * other.reciprocal()
        return self * Interval.of(other).reciprocal()

    def __rtruediv__(self, other: Any) -> Lin:
        return self.reciprocal() * other

    def reciprocal(self) -> Lin:
        return _unary(self, _RECIPROCAL)

    def __pow__(self, p: Any) -> Lin:
        if float(p) == 2.0:
            return self.square()
        if float(p) == 1.0:
            return self
        if float(p).is_integer() and 0 < float(p) <= 16:
            out = self
            for _ in range(int(p) - 1):
                out = out * self
            return out.meet_iv(self.iv ** int(p))
        return _unary(self, _power(float(p)))

    def meet_iv(self, iv: Interval) -> Lin:
        lo, hi = np.maximum(self.iv.lo, iv.lo), np.minimum(self.iv.hi, iv.hi)
        return Lin(self.lA, self.lc, self.uA, self.uc, Interval(lo, np.maximum(lo, hi)), self.r)


def combine(terms: Sequence[tuple[np.ndarray, np.ndarray, Lin]], iv: Interval,
            const: tuple[Any, Any] = (0.0, 0.0)) -> Lin:  # fmt: skip
    """``sum_k s_k q_k + g`` with per-box float scalars ``s_k`` (one for the lower side, one for
    the upper: the relaxation lines of a function may differ) and ``g`` in ``const`` (lower and
    upper float bounds per box); ``iv`` encloses the result (intersected). Rounding: module doc."""
    q0 = terms[0][2]
    r = q0.r
    m, n = r.shape
    g_lo = np.broadcast_to(np.asarray(const[0], dtype=float), (m,))
    g_hi = np.broadcast_to(np.asarray(const[1], dtype=float), (m,))
    sides = []
    for side in (0, 1):  # 0: lower, 1: upper
        A = np.zeros((m, n))
        c = np.array(g_lo if side == 0 else g_hi, dtype=float)
        mag = np.abs(c)
        for s_lo, s_hi, q in terms:
            s = s_lo if side == 0 else s_hi
            pos = s >= 0
            # the lower side takes the lower bound of q where s >= 0, the upper one where s < 0
            take_l = pos if side == 0 else ~pos
            Aq = np.where(take_l[:, None], q.lA, q.uA)
            cq = np.where(take_l, q.lc, q.uc)
            with np.errstate(invalid="ignore", over="ignore"):
                A += s[:, None] * Aq
                c += s * cq
                mag += np.abs(s) * (np.sum(np.abs(Aq) * r, axis=1) + np.abs(cq))
        k = len(terms) + 1
        with np.errstate(invalid="ignore", over="ignore"):
            err = round_up(mag * (1.0 + _gamma2(n + 1)) * _gamma2(k + n) + _underflow(k + n + 2, r))
            c = round_down(c - err) if side == 0 else round_up(c + err)
        sides.append((A, c))
    return _settle(sides[0][0], sides[0][1], sides[1][0], sides[1][1], iv, r)


def _settle(lA: np.ndarray, lc: np.ndarray, uA: np.ndarray, uc: np.ndarray, iv: Interval,
            r: np.ndarray) -> Lin:  # fmt: skip
    """A :class:`Lin` whose non-finite rows fall back to the interval (slope 0)."""
    m = len(r)
    ivlo = np.broadcast_to(iv.lo, (m,))
    ivhi = np.broadcast_to(iv.hi, (m,))
    bad_l = ~(np.all(np.isfinite(lA), axis=1) & np.isfinite(lc))
    bad_u = ~(np.all(np.isfinite(uA), axis=1) & np.isfinite(uc))
    if bad_l.any():
        lA = np.where(bad_l[:, None], 0.0, lA)
        lc = np.where(bad_l, ivlo, lc)
    if bad_u.any():
        uA = np.where(bad_u[:, None], 0.0, uA)
        uc = np.where(bad_u, ivhi, uc)
    out = Lin(lA, lc, uA, uc, Interval(ivlo, ivhi), r)
    lo, hi = out.bounds()
    out.iv = Interval(lo, np.maximum(lo, hi))
    return out


def _mccormick(p: Lin, q: Lin) -> Lin:
    """``p q`` by the McCormick planes over the ranges of ``p`` and ``q`` (module doc)."""
    pr, qr = p.range(), q.range()
    pl, pu, ql, qu = pr.lo, pr.hi, qr.lo, qr.hi
    iv = pr * qr
    ok = np.isfinite(pl) & np.isfinite(pu) & np.isfinite(ql) & np.isfinite(qu)

    def f(a: np.ndarray) -> np.ndarray:
        return np.where(ok, a, 0.0)

    # lower: (p - pl)(q - ql) >= 0 -> pq >= ql p + pl q - pl ql; (pu - p)(qu - q) >= 0 likewise
    # upper: (p - pl)(qu - q) >= 0 -> pq <= qu p + pl q - pl qu; (pu - p)(q - ql) >= 0 likewise
    cands = []
    for (a1, b1, c1), (a2, b2, c2) in (((ql, pl, (pl, ql)), (qu, pl, (pl, qu))),
                                       ((qu, pu, (pu, qu)), (ql, pu, (pu, ql)))):  # fmt: skip
        k_lo = -(Interval(f(c1[0])) * Interval(f(c1[1]))).hi
        k_hi = -(Interval(f(c2[0])) * Interval(f(c2[1]))).lo
        cands.append(combine([(f(a1), f(a2), p), (f(b1), f(b2), q)], iv,
                             (np.where(ok, k_lo, iv.lo), np.where(ok, k_hi, iv.hi))))  # fmt: skip
    a, b = cands
    al, ah = a.bounds()
    bl, bh = b.bounds()
    tl, tu = al >= bl, ah <= bh  # per box the better plane on each side
    return _settle(np.where(tl[:, None], a.lA, b.lA), np.where(tl, a.lc, b.lc),
                   np.where(tu[:, None], a.uA, b.uA), np.where(tu, a.uc, b.uc), iv, p.r)  # fmt: skip


# -- elementwise functions: lines below and above on [l, u] -------------------------------------------
class Fn:
    """An elementwise function for relaxation: its interval enclosure, and either the interval
    enclosure of its derivative (smooth) or its kinks (piecewise linear)."""

    def __init__(self, f: Callable[[Interval], Interval],
                 df: Callable[[Interval], Interval] | None = None,
                 kinks: Callable[[], Sequence[float]] | None = None) -> None:  # fmt: skip
        self.f, self.df, self.kinks = f, df, kinks


def _offsets(
    fn: Fn, a: np.ndarray, ls: np.ndarray, us: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Proved ``(b_lo, b_hi)`` with ``b_lo <= f(z) - a z <= b_hi`` on ``[ls, us]`` (module doc)."""
    A = Interval(a)
    if fn.kinks is not None:
        pts = [ls, us] + [np.clip(k, ls, us) for k in fn.kinks()]
        at = [fn.f(Interval(p)) - Interval(p) * A for p in pts]
        return np.minimum.reduce([e.lo for e in at]), np.maximum.reduce([e.hi for e in at])
    assert fn.df is not None
    t = np.linspace(0.0, 1.0, PIECES + 1)
    edges = [ls + (us - ls) * s for s in t]
    edges[0], edges[-1] = ls, us  # consecutive pieces share their ends: they cover [ls, us]
    b_lo, b_hi = np.full(ls.shape, np.inf), np.full(ls.shape, -np.inf)
    for k in range(PIECES):
        lo_k = np.minimum(edges[k], edges[k + 1])
        hi_k = np.maximum(edges[k], edges[k + 1])
        P = Interval(lo_k, hi_k)
        Pc = Interval(0.5 * lo_k + 0.5 * hi_k)
        g = fn.f(Pc) - Pc * A + (fn.df(P) - A) * (P - Pc)
        g = Interval(np.fmax(g.lo, (fn.f(P) - P * A).lo), g.hi)
        b_lo, b_hi = np.minimum(b_lo, g.lo), np.maximum(b_hi, g.hi)
    return b_lo, b_hi


def relax(fn: Fn, l: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, ...]:
    """Float slopes and proved offsets ``(a_lo, b_lo, a_hi, b_hi)`` with
    ``a_lo z + b_lo <= f(z) <= a_hi z + b_hi`` for ``z`` in ``[l, u]`` (elementwise, any shape;
    module doc). Candidate slopes: the chord's, and the derivative at the centre (smooth ``f``) or 0 and 1 (piecewise linear); per element and side the line with the best
    mean over ``[l, u]``. Non-finite data give slope 0 and the interval range of ``f``."""
    l, u = np.asarray(l, dtype=float), np.asarray(u, dtype=float)
    fin = np.isfinite(l) & np.isfinite(u)
    ls, us = np.where(fin, l, 0.0), np.where(fin, u, 0.0)
    with np.errstate(all="ignore"):
        fl, fu = fn.f(Interval(ls)), fn.f(Interval(us))
        w = us - ls
        chord = (0.5 * (fu.lo + fu.hi) - 0.5 * (fl.lo + fl.hi)) / np.where(w > 0, w, 1.0)
        cands = [np.where(w > 0, chord, 0.0)]
        if fn.df is not None:
            for p in (0.5 * ls + 0.5 * us,):
                d = fn.df(Interval(p))
                cands.append(0.5 * d.lo + 0.5 * d.hi)
        else:
            cands += [np.zeros_like(ls), np.ones_like(ls)]
        centre = 0.5 * ls + 0.5 * us
        best = None
        for a in cands:
            a = np.where(np.isfinite(a), a, 0.0)
            b_lo, b_hi = _offsets(fn, a, ls, us)
            mean_lo, mean_hi = a * centre + b_lo, a * centre + b_hi
            if best is None:
                best = [a, b_lo, mean_lo, a.copy(), b_hi, mean_hi]
                continue
            up = mean_lo > best[2]  # a higher lower line, a lower upper line
            dn = mean_hi < best[5]
            best[0], best[1], best[2] = (np.where(up, a, best[0]), np.where(up, b_lo, best[1]),
                                         np.where(up, mean_lo, best[2]))  # fmt: skip
            best[3], best[4], best[5] = (np.where(dn, a, best[3]), np.where(dn, b_hi, best[4]),
                                         np.where(dn, mean_hi, best[5]))  # fmt: skip
        assert best is not None
        a_lo, b_lo, _, a_hi, b_hi, _ = best
        rng = fn.f(
            Interval(np.where(np.isfinite(l), l, -np.inf), np.where(np.isfinite(u), u, np.inf))
        )
    ok_lo = fin & np.isfinite(b_lo) & np.isfinite(a_lo)
    ok_hi = fin & np.isfinite(b_hi) & np.isfinite(a_hi)
    return (np.where(ok_lo, a_lo, 0.0), np.where(ok_lo, b_lo, rng.lo),
            np.where(ok_hi, a_hi, 0.0), np.where(ok_hi, b_hi, rng.hi))  # fmt: skip


def _unary(q: Lin, fn: Fn) -> Lin:
    R = q.range()
    a_lo, b_lo, a_hi, b_hi = relax(fn, R.lo, R.hi)
    return combine([(a_lo, a_hi, q)], fn.f(R), (b_lo, b_hi))


def _d(expr: Callable[[Interval], Any]) -> Callable[[Interval], Interval]:
    return lambda z: Interval.of(expr(z))


_SQUARE = Fn(lambda z: z.square(), _d(lambda z: z * 2.0))
_RECIPROCAL = Fn(lambda z: z.reciprocal(), _d(lambda z: -(z.square().reciprocal())))


def _power(p: float) -> Fn:
    return Fn(lambda z: z**p, _d(lambda z: (z ** (p - 1.0)) * p))


def _sig(z: Interval) -> Interval:
    return INTERVAL.sigmoid(z)


FUNCTIONS: dict[str, Fn] = {
    "sin": Fn(INTERVAL.sin, INTERVAL.cos),
    "cos": Fn(INTERVAL.cos, _d(lambda z: -INTERVAL.sin(z))),
    "exp": Fn(INTERVAL.exp, INTERVAL.exp),
    "log": Fn(INTERVAL.log, _d(lambda z: z.reciprocal())),
    "sqrt": Fn(INTERVAL.sqrt, _d(lambda z: (INTERVAL.sqrt(z) * 2.0).reciprocal())),
    "arctan": Fn(INTERVAL.arctan, _d(lambda z: (z.square() + 1.0).reciprocal())),
    "arcsinh": Fn(INTERVAL.arcsinh, _d(lambda z: INTERVAL.sqrt(z.square() + 1.0).reciprocal())),
    "arctanh": Fn(INTERVAL.arctanh, _d(lambda z: (1.0 - z.square()).reciprocal())),
    "tan": Fn(INTERVAL.tan, _d(lambda z: INTERVAL.tan(z).square() + 1.0)),
    "tanh": Fn(INTERVAL.tanh, _d(lambda z: 1.0 - INTERVAL.tanh(z).square())),
    "sigmoid": Fn(_sig, _d(lambda z: _sig(z) * (1.0 - _sig(z)))),
    "softplus": Fn(INTERVAL.softplus, _sig),
    "relu": Fn(INTERVAL.relu, kinks=lambda: (0.0,)),
    "abs": Fn(INTERVAL.abs, kinks=lambda: (0.0,)),
}


def activation_fn(name: str, args: Sequence[float] = ()) -> Fn:
    """The :class:`Fn` of a network activation (or any elementwise function of :data:`LINEAR`)."""
    if name == "leaky_relu":
        alpha = float(args[0]) if args else 0.01
        return Fn(lambda z: INTERVAL.leaky_relu(z, alpha), kinks=lambda: (0.0,))
    if name == "clip":
        lo, hi = float(args[0]), float(args[1])
        return Fn(lambda z: INTERVAL.clip(z, lo, hi), kinks=lambda: (lo, hi))
    if name == "identity":
        return Fn(lambda z: z, kinks=lambda: ())
    return FUNCTIONS[name]


def _lift(name: str) -> Callable[..., Any]:
    def fn(x: Any, *args: Any) -> Any:
        if not isinstance(x, Lin):
            return getattr(INTERVAL, name)(x, *args)
        return _unary(x, activation_fn(name, args))

    return fn


def _maximum(a: Any, b: Any) -> Any:
    if not (isinstance(a, Lin) or isinstance(b, Lin)):
        return INTERVAL.maximum(a, b)
    p = a if isinstance(a, Lin) else b
    a, b = p._of(a), p._of(b)
    return (b + _unary(a - b, FUNCTIONS["relu"])).meet_iv(INTERVAL.maximum(a.iv, b.iv))


def _minimum(a: Any, b: Any) -> Any:
    if not (isinstance(a, Lin) or isinstance(b, Lin)):
        return INTERVAL.minimum(a, b)
    p = a if isinstance(a, Lin) else b
    a, b = p._of(a), p._of(b)
    return (a - _unary(a - b, FUNCTIONS["relu"])).meet_iv(INTERVAL.minimum(a.iv, b.iv))


def _clip(x: Any, lo: Any, hi: Any) -> Any:
    if isinstance(x, Lin) and not isinstance(lo, Lin) and not isinstance(hi, Lin):
        if np.ndim(lo) == 0 and np.ndim(hi) == 0 and not isinstance(lo, Interval | Lin):
            return _unary(x, activation_fn("clip", (float(lo), float(hi))))
    return _minimum(_maximum(x, lo), hi)


def variables(lo: np.ndarray, hi: np.ndarray) -> tuple[list[Lin], np.ndarray]:
    """The coordinates ``x_i`` on the boxes ``[lo, hi]`` (shape ``(m, n)``) as :class:`Lin`
    (``x_i = mid_i + d_i`` exactly, ``|d_i| <= r_i`` with ``r`` rounded up) and the centres."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    m, n = lo.shape
    mid = 0.5 * lo + 0.5 * hi
    r = np.maximum(round_up(hi - mid), round_up(mid - lo))
    out = []
    for i in range(n):
        A = np.zeros((m, n))
        A[:, i] = 1.0
        out.append(Lin(A, mid[:, i].copy(), A, mid[:, i].copy(), Interval(lo[:, i], hi[:, i]), r))
    return out, mid


#: The networks evaluated by :func:`crown` while :func:`network_calls` watches (None otherwise).
_CALLS: contextvars.ContextVar[list[Any] | None] = contextvars.ContextVar("calls", default=None)


@contextlib.contextmanager
def network_calls() -> Iterator[list[Any]]:
    """A list that collects the networks :func:`crown` evaluates inside the block."""
    seen: list[Any] = []
    token = _CALLS.set(seen)
    try:
        yield seen
    finally:
        _CALLS.reset(token)


# -- CROWN through a network ------------------------------------------------------------------------
def _stack_inputs(x: Sequence[Any], r: np.ndarray) -> tuple[np.ndarray, ...]:
    """The inputs as arrays ``(LA, Lc, UA, Uc, lo, hi)`` with shapes ``(m, k, n)`` / ``(m, k)``."""
    qs = [v if isinstance(v, Lin) else Lin.const(v, r) for v in x]
    rng = [q.range() for q in qs]
    return (np.stack([q.lA for q in qs], 1), np.stack([q.lc for q in qs], 1),
            np.stack([q.uA for q in qs], 1), np.stack([q.uc for q in qs], 1),
            np.stack([e.lo for e in rng], 1), np.stack([e.hi for e in rng], 1))  # fmt: skip


def _mag(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.maximum(np.abs(lo), np.abs(hi))


def _back(ops: Sequence[Any], rel: dict[int, tuple[np.ndarray, ...]], mags: list[np.ndarray],
          upto: int, m: int, upper: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """Back-substitute the bound (lower, or ``upper``) of the values after op ``upto - 1`` to the
    network's inputs: ``(Lam, c, err)`` with the bound ``Lam . z0 + c`` (for the lower side ``Lam
    . z0 + c - err <= value``; upper: ``<= Lam . z0 + c + err``). ``mags[k]``: a bound of the
    magnitude of the values entering op ``k``; ``rel[k]``: the relaxation lines of the
    activation op ``k``."""
    from roa.nn._ops import Affine

    width = mags[upto].shape[1]
    Lam = np.broadcast_to(np.eye(width), (m, width, width)).copy()
    c = np.zeros((m, width))
    err = np.zeros((m, width))
    for k in range(upto - 1, -1, -1):
        op = ops[k]
        if isinstance(op, Affine):
            with np.errstate(invalid="ignore", over="ignore"):
                absL = np.abs(Lam)
                e = ((absL @ np.abs(op.W)) @ mags[k][:, :, None])[..., 0] + (
                    absL @ np.abs(op.b) + np.abs(c)
                )
                c = c + Lam @ op.b
                Lam = Lam @ op.W
            p = op.W.shape[0] + 1
            err = err + (e * _gamma2(p) + _underflow(p + 2, mags[k])[:, None])
        else:
            a_lo, b_lo, a_hi, b_hi = rel[k]
            pos = Lam >= 0
            if upper:
                a1, b1, a2, b2 = a_hi, b_hi, a_lo, b_lo
            else:
                a1, b1, a2, b2 = a_lo, b_lo, a_hi, b_hi
            A = np.where(pos, a1[:, None, :], a2[:, None, :])
            B = np.where(pos, b1[:, None, :], b2[:, None, :])
            with np.errstate(invalid="ignore", over="ignore"):
                absL = np.abs(Lam)
                e = np.sum(absL * (np.abs(A) * mags[k][:, None, :] + np.abs(B)), axis=2)
                e = e + np.abs(c)
                c = c + np.sum(Lam * B, axis=2)
                Lam = Lam * A
            p = mags[k].shape[1] + 2
            err = err + (e * _gamma2(p) + _underflow(p + 2, mags[k])[:, None])
    return Lam, c, err


def crown(net: Any, x: Sequence[Any]) -> list[Lin] | list[Interval]:
    """The outputs of the network ``net`` (:class:`roa.nn.MLP`, uncentred) on the inputs ``x``
    (:class:`Lin`, or constants) by CROWN (module doc)."""
    from roa.nn._ops import Affine

    if not any(isinstance(v, Lin) for v in x):
        return interval_network(net, [Interval.of(v) for v in x])
    seen = _CALLS.get()
    if seen is not None:
        seen.append(net)
    r = next(v.r for v in x if isinstance(v, Lin))
    m, n = r.shape
    LA, Lc, UA, Uc, zlo, zhi = _stack_inputs(x, r)
    ops = net.ops
    mags = [_mag(zlo, zhi)]  # magnitude of the values entering op k
    los, his = [zlo], [zhi]  # bounds of the values entering op k
    rel: dict[int, tuple[np.ndarray, ...]] = {}
    outs: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
    for k, op in enumerate(ops):
        lo_k, hi_k = los[k], his[k]
        if isinstance(op, Affine):
            ibp = interval_affine(op.W, op.b, lo_k.T, hi_k.T)
            nlo, nhi = ibp.lo.T, ibp.hi.T
            last = k == len(ops) - 1
            nxt_act = not last and not isinstance(ops[k + 1], Affine)
            if nxt_act or last:
                mags.append(_mag(nlo, nhi))  # provisional, refined below
                bounds = []
                for upper in (False, True):
                    Lam, c, err = _back(ops, rel, mags, k + 1, m, upper)
                    A, cc = _compose_in(Lam, c, err, (LA, Lc, UA, Uc), r, upper)
                    bounds.append((A, cc))
                (lA, lc), (uA, uc) = bounds
                with np.errstate(invalid="ignore", over="ignore"):
                    clo = round_down(lc - _abs_dot(lA, r[:, None, :]))
                    chi = round_up(uc + _abs_dot(uA, r[:, None, :]))
                clo = np.where(np.isnan(clo), -np.inf, clo)
                chi = np.where(np.isnan(chi), np.inf, chi)
                nlo, nhi = np.maximum(nlo, clo), np.minimum(nhi, chi)
                nhi = np.maximum(nlo, nhi)
                mags[-1] = _mag(nlo, nhi)
                if last:
                    outs = [(lA[:, i], lc[:, i], uA[:, i], uc[:, i]) for i in range(lA.shape[1])]
            else:
                mags.append(_mag(nlo, nhi))
        else:
            fn = activation_fn(op.name, op.args)
            rel[k] = relax(fn, lo_k, hi_k)
            iv = fn.f(Interval(lo_k, hi_k))
            nlo, nhi = iv.lo, iv.hi
            mags.append(_mag(nlo, nhi))
            if k == len(ops) - 1:  # a network ending in an activation: relax it once more
                Lams = []
                for upper in (False, True):
                    Lam, c, err = _back(ops, rel, mags, k + 1, m, upper)
                    Lams.append(_compose_in(Lam, c, err, (LA, Lc, UA, Uc), r, upper))
                (lA, lc), (uA, uc) = Lams
                outs = [(lA[:, i], lc[:, i], uA[:, i], uc[:, i]) for i in range(lA.shape[1])]
        los.append(nlo)
        his.append(nhi)
    return [_settle(a, b, c, d, Interval(los[-1][:, i], his[-1][:, i]), r)
            for i, (a, b, c, d) in enumerate(outs)]  # fmt: skip


def _compose_in(Lam: np.ndarray, c: np.ndarray, err: np.ndarray, inp: tuple[np.ndarray, ...],
                r: np.ndarray, upper: bool) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """``Lam . z0 + c`` (-+ ``err``) with ``z0`` between its affine bounds: an affine function of
    ``d`` as ``(A, c)`` of shapes ``(m, o, n)``, ``(m, o)`` (lower, or ``upper``), every rounding
    error moved into ``c``."""
    LA, Lc, UA, Uc = inp
    P, N = np.maximum(Lam, 0.0), np.minimum(Lam, 0.0)
    fA, fc, sA, sc = (UA, Uc, LA, Lc) if upper else (LA, Lc, UA, Uc)
    k = Lam.shape[2]
    with np.errstate(invalid="ignore", over="ignore"):
        A = np.einsum("mok,mkn->mon", P, fA) + np.einsum("mok,mkn->mon", N, sA)
        cc = c + np.einsum("mok,mk->mo", P, fc) + np.einsum("mok,mk->mo", N, sc)
        rr = r[:, None, :]
        mf = np.sum(np.abs(fA) * rr, axis=2) + np.abs(fc)  # (m, k)
        ms = np.sum(np.abs(sA) * rr, axis=2) + np.abs(sc)
        mag = np.einsum("mok,mk->mo", P, mf) - np.einsum("mok,mk->mo", N, ms) + np.abs(c)
        e = round_up(err + mag * (1.0 + _gamma2(r.shape[1] + 1)) * _gamma2(2 * k + 2)
                     + _underflow(2 * k + 4, r)[:, None])  # fmt: skip
        cc = round_up(cc + e) if upper else round_down(cc - e)
    return A, cc


LINEAR = SimpleNamespace(
    name="linear",
    network=crown,  # a network (roa.nn.MLP): CROWN
    **{k: _lift(k) for k in FUNCTIONS},
    leaky_relu=_lift("leaky_relu"),
    minimum=_minimum,
    maximum=_maximum,
    clip=_clip,
)
"""Linear-relaxation namespace: ``system.field(t, variables(lo, hi), LINEAR)`` bounds the field
on boxes by affine functions of the state (module doc)."""
