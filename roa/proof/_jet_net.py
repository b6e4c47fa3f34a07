"""Interval jets through a network as array operations: value, gradient and Hessian of every unit.

:func:`network_jet` is the :data:`~roa.proof.JET` evaluation of a :class:`roa.nn.MLP`: the
same chain rule as evaluating the network neuron by neuron with :class:`~roa.proof.Jet`
arithmetic, and the same claims (every coefficient an outward-rounded enclosure), with all units
of a layer and all boxes in one array per coefficient. Layout: values ``(k, m)`` (``k`` units,
``m`` boxes), gradients ``(k, m, n)`` and the Hessian's upper triangle ``(k, m, P)`` with
``P = n (n + 1) / 2`` pairs ``(p, q), p <= q``.

* **Affine layer** ``W h + b``: each coefficient array by
  :func:`~roa.proof.interval_affine` (Higham's bound of the float matrix product,
  rounded outward; the bias enters the value only);
* **smooth activation** ``f`` (tanh, sigmoid, softplus): ``f(z)``, ``f'(z) g`` and
  ``f''(z) g_p g_q + f'(z) h_pq`` in interval arithmetic, with ``f'``, ``f''`` the enclosures of
  :data:`~roa.proof.JET`;
* **piecewise linear activation** (relu, leaky_relu, clip, identity): on a box where the unit's
  range lies on one piece, that piece's affine function (slope 0, 1 or ``alpha``: exact); across
  a kink the hull of the pieces' gradients (Clarke's generalised gradient: the centred form stays
  a proof by Lebourg's mean value theorem) and the whole line for the Hessian, except the entries
  ``(p, q)`` where the unit's gradient is an exact zero in ``p`` or ``q`` (the kink does not move
  along those coordinates), as in :func:`roa.proof._jet._branch`.

The unit's range (which piece, and the argument of ``f``, ``f'``, ``f''``) is the value enclosure
intersected, for centred jets (:meth:`roa.proof.Jet.variables`), with the centred form
``c + sum_p g_p d_p`` (the mean value theorem); ``c`` is propagated through the network in
interval arithmetic. Entries that are exact zeros for every box (a coordinate the network does
not depend on) stay the symbolic ``0.0`` of :mod:`roa.proof._jet`. Boxes are processed in chunks
of :data:`CHUNK`.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np

from roa.proof._interval import INTERVAL, Interval, interval_affine
from roa.proof._jet import JET_FUNCTIONS, Jet, _kink

#: Boxes per array step (the Hessian holds ``k * CHUNK * P`` intervals per layer).
CHUNK = 4096
_SMOOTH = ("tanh", "sigmoid", "softplus")
_PIECEWISE = ("relu", "leaky_relu", "clip", "identity")


def _derivatives(name: str) -> tuple[Any, Any, Any]:
    """``(f, f', f'')`` of a smooth activation as interval functions (those of the JET namespace)."""
    from roa.proof import _jet as J

    return {
        "tanh": (INTERVAL.tanh, J._dtanh, J._d2tanh),
        "sigmoid": (INTERVAL.sigmoid, J._dsigmoid, J._d2sigmoid),
        "softplus": (INTERVAL.softplus, INTERVAL.sigmoid, J._dsigmoid),
    }[name]


def supported(net: Any) -> bool:
    """Whether every activation of ``net`` has an array rule here."""
    from roa.nn._ops import Affine

    return all(isinstance(op, Affine) or op.name in _SMOOTH + _PIECEWISE for op in net.ops)


def _iv(e: Any, shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    iv = Interval.of(e)
    return np.broadcast_to(iv.lo, shape), np.broadcast_to(iv.hi, shape)


def _affine(W: np.ndarray, b: np.ndarray, X: Interval) -> Interval:
    """``W X + b`` over the first axis of ``X`` (any trailing shape), rounded outward."""
    k = X.lo.shape[0]
    rest = X.lo.shape[1:]
    out = interval_affine(W, b, X.lo.reshape(k, -1), X.hi.reshape(k, -1))
    return Interval(out.lo.reshape((W.shape[0], *rest)), out.hi.reshape((W.shape[0], *rest)))


def _hull0(X: Interval) -> Interval:
    """The hull of ``X`` and 0 (``[0, 1] X``)."""
    return Interval(np.minimum(X.lo, 0.0), np.maximum(X.hi, 0.0))


def _select(mask: np.ndarray, a: Interval, b: Interval) -> Interval:
    return Interval(np.where(mask, a.lo, b.lo), np.where(mask, a.hi, b.hi))


class _State:
    """The jets of one layer's units on a chunk of boxes (module doc: layout)."""

    def __init__(self, v: Interval, g: Interval, h: Interval | None, c: Interval | None,
                 zg: np.ndarray, zh: np.ndarray | None) -> None:  # fmt: skip
        self.v, self.g, self.h, self.c = v, g, h, c
        self.zg, self.zh = zg, zh  # (k, n) / (k, P): exact zeros for every box


def _range(s: _State, d: Interval | None) -> Interval:
    """The value enclosure met with the centred form ``c + sum_p g_p d_p`` (when centred)."""
    if s.c is None or d is None:
        return s.v
    cen = s.c
    for p in range(s.g.lo.shape[2]):
        if not s.zg[:, p].all():
            cen = cen + Interval(s.g.lo[:, :, p], s.g.hi[:, :, p]) * Interval(
                d.lo[:, p], d.hi[:, p]
            )
    lo, hi = np.maximum(s.v.lo, cen.lo), np.minimum(s.v.hi, cen.hi)
    ok = lo <= hi  # always, for enclosures of the same values; be safe
    return Interval(np.where(ok, lo, s.v.lo), np.where(ok, hi, s.v.hi))


def _step(s: _State, op: Any, d: Interval | None, iu: np.ndarray, ju: np.ndarray) -> _State:
    from roa.nn._ops import Affine

    if isinstance(op, Affine):
        W = np.asarray(op.W, dtype=float)
        nz = W != 0.0
        zero = np.zeros(W.shape[0])
        zg = ~(nz.astype(int) @ (~s.zg).astype(int)).astype(bool)
        h = zh = None
        if s.h is not None and s.zh is not None:
            h = _affine(W, zero, s.h)
            zh = ~(nz.astype(int) @ (~s.zh).astype(int)).astype(bool)
        c = None if s.c is None else _affine(W, op.b, s.c)
        g = _affine(W, zero, s.g)
        return _State(_affine(W, op.b, s.v), _zg(g, zg), _zeroed(h, zh), c, zg, zh)
    name = op.name
    if name == "identity":
        return s
    r = _range(s, d)
    if name in _SMOOTH:
        f0, f1, f2 = _derivatives(name)
        d1 = f1(r)
        d1x = Interval(d1.lo[:, :, None], d1.hi[:, :, None])
        g = _times_nonneg(d1x, s.g)
        h = None
        if s.h is not None:
            d2 = f2(r)
            h = Interval(d2.lo[:, :, None], d2.hi[:, :, None]) * _pair_products(s.g, iu, ju)
            h = h + _times_nonneg(d1x, s.h)
        c = None if s.c is None else f0(s.c)
        zh = None if s.zh is None else s.zh & (s.zg[:, iu] | s.zg[:, ju])
        return _State(f0(r), _zg(g, s.zg), _zeroed(h, zh), c, s.zg, zh)
    _kink(name)
    # pieces: (lower end, upper end, slope, value offset) with f = slope z + offset on the piece
    if name == "relu":
        pieces = [(-np.inf, 0.0, 0.0), (0.0, np.inf, 1.0)]
    elif name == "leaky_relu":
        pieces = [(-np.inf, 0.0, float(op.args[0])), (0.0, np.inf, 1.0)]
    else:  # clip
        lo_c, hi_c = float(op.args[0]), float(op.args[1])
        pieces = [(-np.inf, lo_c, 0.0), (lo_c, hi_c, 1.0), (hi_c, np.inf, 0.0)]
    fn = getattr(INTERVAL, name)
    v = fn(r, *op.args)
    c = None if s.c is None else fn(s.c, *op.args)
    slopes = [a for _, _, a in pieces]
    smin, smax = min(slopes), max(slopes)
    # across a kink: the hull of the pieces' gradients (slopes between smin and smax, >= 0)
    g = Interval(np.minimum(s.g.lo * smin, s.g.lo * smax), np.maximum(s.g.hi * smin, s.g.hi * smax))
    kinked = np.ones(r.lo.shape, dtype=bool)
    h = None
    if s.h is not None:
        assert s.zh is not None
        flat = s.zg[:, iu] | s.zg[:, ju]  # (k, P): the kink does not move along p or q
        hk = Interval(np.minimum(s.h.lo * smin, s.h.lo * smax),
                      np.maximum(s.h.hi * smin, s.h.hi * smax))  # fmt: skip
        whole = Interval(np.full(s.h.lo.shape, -np.inf), np.full(s.h.lo.shape, np.inf))
        h = _select(flat[:, None, :], hk, whole)
    for a_lo, a_hi, a in pieces:
        on = (r.lo >= a_lo) & (r.hi <= a_hi)  # the range lies on this piece
        kinked &= ~on
        ga = s.g * a if a not in (0.0, 1.0) else (s.g if a == 1.0 else _zeros(s.g))
        g = _select(on[:, :, None], ga, g)
        if h is not None and s.h is not None:
            ha = s.h * a if a not in (0.0, 1.0) else (s.h if a == 1.0 else _zeros(s.h))
            h = _select(on[:, :, None], ha, h)
    # the products of float slopes (0, 1, alpha) with a bound round outward: g * alpha above is
    # an Interval product; the hulls use round-to-nearest products, widened here
    g = _widen(g, smin, smax)
    h = None if h is None else _widen(h, smin, smax)
    zh = None if s.zh is None else s.zh & (s.zg[:, iu] | s.zg[:, ju])
    return _State(v, _zg(g, s.zg), _zeroed(h, zh), c, s.zg, zh)


def _times_nonneg(a: Interval, X: Interval) -> Interval:
    """``a X`` for ``a >= 0`` (the derivative of a monotone activation), two products instead of
    four: the lower end is ``a_lo X_lo`` where ``X_lo >= 0``, else ``a_hi X_lo``; the upper
    ``a_hi X_hi`` where ``X_hi >= 0``, else ``a_lo X_hi``. ``0 x inf`` (NaN) is 0, as in
    :meth:`Interval.__mul__` (the factor is then exactly 0, or 0 is the bound). The general
    product where some ``a_lo < 0``."""
    if not np.all(a.lo >= 0):
        return a * X
    from roa.proof._interval import round_down, round_up

    with np.errstate(invalid="ignore"):
        lo = np.where(X.lo >= 0, a.lo, a.hi) * X.lo
        hi = np.where(X.hi >= 0, a.hi, a.lo) * X.hi
    lo = np.where(np.isnan(lo), 0.0, lo)
    hi = np.where(np.isnan(hi), 0.0, hi)
    return Interval(round_down(lo), round_up(hi))


def _pair_products(g: Interval, iu: np.ndarray, ju: np.ndarray) -> Interval:
    """``g_p g_q`` for the pairs ``(iu, ju)`` (last axis): squares on the diagonal (never
    negative, tighter than the product of two equal intervals), products elsewhere."""
    diag = iu == ju
    lo = np.empty(g.lo.shape[:-1] + (len(iu),))
    hi = np.empty_like(lo)
    sq = Interval(g.lo[..., iu[diag]], g.hi[..., iu[diag]]).square()
    off = Interval(g.lo[..., iu[~diag]], g.hi[..., iu[~diag]]) * Interval(
        g.lo[..., ju[~diag]], g.hi[..., ju[~diag]]
    )
    lo[..., diag], hi[..., diag] = sq.lo, sq.hi
    lo[..., ~diag], hi[..., ~diag] = off.lo, off.hi
    return Interval(lo, hi)


def _widen(X: Interval, smin: float, smax: float) -> Interval:
    """``X`` rounded outward by one ulp unless every slope is 0 or 1 (exact products)."""
    if {smin, smax} <= {0.0, 1.0}:
        return X
    from roa.proof._interval import round_down, round_up

    with np.errstate(invalid="ignore"):
        return Interval(round_down(X.lo), round_up(X.hi))


def _zeros(X: Interval) -> Interval:
    z = np.zeros(X.lo.shape)
    return Interval(z, z)


def _zg(X: Interval, z: np.ndarray) -> Interval:
    out = _zeroed(X, z)
    assert out is not None
    return out


def _zeroed(X: Interval | None, z: np.ndarray | None) -> Interval | None:
    """``X`` with the exact-zero entries (``z``, per unit and coordinate) set to 0."""
    if X is None or z is None or not z.any():
        return X
    zz = z[:, None, :]
    return Interval(np.where(zz, 0.0, X.lo), np.where(zz, 0.0, X.hi))


def network_jet(net: Any, x: list[Any]) -> list[Any] | None:
    """The outputs of ``net`` (uncentred) as jets of the input jets ``x`` (module doc), or None when
    an input is not a jet of a form handled here (the caller evaluates neuron by neuron)."""
    jets = [e for e in x if isinstance(e, Jet)]
    if not jets or not supported(net):
        return None
    n = len(jets[0].g)
    order2 = jets[0].h is not None
    if any(len(j.g) != n or (j.h is not None) != order2 for j in jets):
        return None
    centred = all(j.c is not None and j.d is not None for j in jets)
    shapes = [np.shape(j.v.lo) for j in jets] + [np.shape(Interval.of(e).lo) for j in jets
                                                 for e in j.g if type(e) is not float]  # fmt: skip
    try:
        full = np.broadcast_shapes(*shapes)
    except ValueError:
        return None
    if len(full) != 1:
        return None
    m = full[0] if full else 1
    k0 = len(x)
    iu, ju = np.triu_indices(n)
    P = len(iu)
    jx = [e if isinstance(e, Jet) else jets[0]._const(e) for e in x]
    zg = np.array([[type(e) is float and e == 0.0 for e in j.g] for j in jx])
    zh = None
    if order2:
        zh = np.array([[type(j.h[p][q]) is float and j.h[p][q] == 0.0  # type: ignore[index]
                        for p, q in zip(iu, ju, strict=True)] for j in jx])  # fmt: skip
    d = None
    if centred:
        dd = jets[0].d
        assert dd is not None
        d = Interval(np.stack([np.broadcast_to(Interval.of(e).lo, (m,)) for e in dd], 1),
                     np.stack([np.broadcast_to(Interval.of(e).hi, (m,)) for e in dd], 1))  # fmt: skip
    outs: list[_State] = []
    for s0 in range(0, m, CHUNK):
        rows = slice(s0, min(m, s0 + CHUNK))
        mc = rows.stop - rows.start

        def arr(es: list[Any], rows: slice = rows, mc: int = mc) -> Interval:
            pairs = [_iv(e, (m,)) for e in es]
            return Interval(np.stack([p[0][rows] for p in pairs]),
                            np.stack([p[1][rows] for p in pairs]))  # fmt: skip

        v = arr([j.v for j in jx])
        gs = [arr(j.g) for j in jx]
        g = Interval(np.stack([e.lo.T for e in gs]), np.stack([e.hi.T for e in gs]))
        h = None
        if order2:
            hs = [arr([j.h[p][q] for p, q in zip(iu, ju, strict=True)]) for j in jx]  # type: ignore[index]
            h = Interval(np.stack([e.lo.T for e in hs]), np.stack([e.hi.T for e in hs]))
        c = arr([j.c for j in jx]) if centred else None
        dc = None if d is None else Interval(d.lo[rows], d.hi[rows])
        s = _State(v, g, h, c, zg, zh)
        with np.errstate(invalid="ignore", over="ignore"):  # inf * 0: NaN, read as unbounded
            for op in net.ops:
                s = _step(s, op, dc, iu, ju)
        outs.append(s)
    assert k0 == net.n_in
    return [_assemble(outs, i, n, P, iu, ju, order2, jets[0].d if centred else None)
            for i in range(outs[0].v.lo.shape[0])]  # fmt: skip


def _assemble(outs: list[_State], i: int, n: int, P: int, iu: np.ndarray, ju: np.ndarray,
              order2: bool, d: list[Any] | None) -> Jet:  # fmt: skip
    """Output ``i`` as a :class:`Jet` (chunks concatenated; exact zeros symbolic)."""

    def cat(get: Any) -> Interval:
        return Interval(np.concatenate([get(s).lo for s in outs]),
                        np.concatenate([get(s).hi for s in outs]))  # fmt: skip

    s0 = outs[0]
    v = cat(lambda s: Interval(s.v.lo[i], s.v.hi[i]))
    g: list[Any] = [
        0.0 if s0.zg[i, p] else cat(lambda s, p=p: Interval(s.g.lo[i, :, p], s.g.hi[i, :, p]))
        for p in range(n)
    ]
    h = None
    if order2:
        assert s0.zh is not None
        h = [[0.0] * n for _ in range(n)]
        for t in range(P):
            if not s0.zh[i, t]:
                h[iu[t]][ju[t]] = cat(lambda s, t=t: Interval(s.h.lo[i, :, t], s.h.hi[i, :, t]))
    c = None if s0.c is None or d is None else cat(lambda s: Interval(s.c.lo[i], s.c.hi[i]))
    return Jet(v, g, h, c, d)


JET = SimpleNamespace(**vars(JET_FUNCTIONS), network=network_jet)
"""Interval-jet namespace: the functions of :data:`roa.proof._jet.JET_FUNCTIONS` and networks
(:class:`roa.nn.MLP`) evaluated as whole layers (:func:`network_jet`)."""

__all__ = ["CHUNK", "JET", "network_jet", "supported"]
