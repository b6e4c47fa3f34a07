"""Bounds of ``V'`` and of the multiplier function on boxes by linear relaxation (CROWN).

The hook of the branch and bound (:func:`roa.proof.evaluate_boxes`) into
:mod:`roa.proof._relax`: on the boxes the interval forms leave undecided, ``V' = grad V . f`` is
evaluated in the linear-relaxation namespace :data:`~roa.proof._relax.LINEAR` (networks by CROWN
back-substitution, the rest by McCormick products and proved lines of the elementwise functions;
everything rounded outward), and its upper bound over the box replaces the interval one where it
is smaller. On the boxes that reach past the level surface the multiplier function
``F = V' + lambda (level - V)`` (``lambda >= 0``, any float: see :mod:`roa.proof._validate`) is
bounded from the affine upper bound of ``V'`` and an affine lower bound of ``V``: the tangent
plane at the box centre when ``V`` is a quadratic form proved convex (exact rational check of its
matrix; the plane's value and slope enclosed in intervals), else ``V`` in the same namespace.

Only for systems whose field calls a network (:class:`roa.nn.MLP`): for the others the interval
forms are as tight and cheaper. Every bound returned is an enclosure, so meeting it with the
interval forms keeps the branch and bound's claims as they are.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np

from roa.lyapunov import Lyapunov
from roa.model._system import System
from roa.proof._interval import INTERVAL, Interval, round_up
from roa.proof._relax import LINEAR, Lin, combine, network_calls, variables

#: Switch for comparisons (``benchmarks/bench_nn.py`` measures the branch and bound without it).
ENABLED = True
#: Boxes per vectorised relaxation step (the back-substitution holds a matrix per box and unit).
CHUNK = 2048


def has_network(system: System) -> bool:
    """Whether the field (or the map) calls a network in the linear namespace (one probe box;
    cached)."""
    cached = getattr(system, "_relax_network", None)
    if cached is not None:
        return bool(cached)
    n = system.n
    x, _ = variables(np.full((1, n), -1e-3), np.full((1, n), 1e-3))
    try:
        with network_calls() as calls, np.errstate(all="ignore"):
            system.dynamics(0.0, x, LINEAR)
        found = bool(calls)
    except (TypeError, ValueError, AttributeError, ArithmeticError, KeyError):
        found = False
    try:
        object.__setattr__(system, "_relax_network", found)
    except AttributeError:
        pass
    return found


def _convex_quadratic(lyap: Lyapunov) -> bool:
    """``V = d' G d`` with ``G`` positive semidefinite, proved in exact rationals (cached)."""
    cached = getattr(lyap, "_relax_convex", None)
    if cached is not None:
        return bool(cached)
    from roa.proof._exact import exact_positive_definite

    terms = lyap.polynomial_view()
    ok = False
    if terms and all(sum(a) == 2 for a in terms):
        n = lyap.n
        G = [[Fraction(0)] * n for _ in range(n)]
        exact = True
        for a, q in terms.items():
            idx = [i for i, k in enumerate(a) for _ in range(k)]
            qf = q if isinstance(q, Fraction) else Fraction(float(q))
            exact = exact and np.isfinite(float(q))
            i, j = idx
            if i == j:
                G[i][i] += qf
            else:
                G[i][j] += qf / 2
                G[j][i] += qf / 2
        ok = exact and exact_positive_definite(G)[0]
    try:
        object.__setattr__(lyap, "_relax_convex", ok)
    except AttributeError:
        pass
    return ok


def _v_lower(lyap: Lyapunov, X: list[Lin], mid: np.ndarray) -> Lin:
    """An affine lower bound of V on the boxes (module doc)."""
    if not _convex_quadratic(lyap):
        return Interval.of(0.0) + lyap.expr(X, LINEAR)
    m = len(mid)
    M = [Interval(mid[:, i]) for i in range(lyap.n)]
    v0 = Interval.of(lyap.expr(M, INTERVAL))
    g = [Interval.of(e) for e in lyap.gradient_expr(M, INTERVAL)]
    # V(x) >= V(m) + grad V(m) . (x - m): the slope's interval width moves into the offset
    terms = []
    for i, gi in enumerate(g):
        lo = np.broadcast_to(gi.lo, (m,))
        hi = np.broadcast_to(gi.hi, (m,))
        s = 0.5 * lo + 0.5 * hi
        # (g - s) . d >= -max(|lo - s|, |hi - s|) r: a term with scalar s and a bounded remainder
        terms.append((s, s, X[i] - Interval(mid[:, i])))
        spread = Interval(round_up(np.maximum(s - lo, hi - s))) * Interval(X[i].r[:, i])
        v0 = v0 - Interval(-spread.hi, spread.hi)
    v0lo = np.broadcast_to(v0.lo, (m,))
    whole = Interval(np.full(m, -np.inf), np.full(m, np.inf))
    return combine(terms, whole, (v0lo, np.full(m, np.inf)))  # no upper bound: not needed


def relaxation_bounds(
    system: System,
    lyap: Lyapunov,
    lo: np.ndarray,
    hi: np.ndarray,
    level: float,
    V: Interval,
    vdot: Interval,
    F_hi: np.ndarray,
    n_par: int = 0,
) -> tuple[Interval, np.ndarray]:
    """``(vdot, F_hi)`` tightened on the boxes still undecided (module doc); unchanged without a
    network in the field or with uncertain parameters (``n_par > 0``)."""
    if n_par or not ENABLED or not has_network(system):
        return vdot, F_hi
    # where the interval forms' bound of V' is mostly negative (its centre below 0): the boxes
    # the relaxation's tighter bound may decide; the others are split without it
    vlo, vhi = np.broadcast_to(vdot.lo, (len(lo),)), np.broadcast_to(vdot.hi, (len(lo),))
    promising = (vhi < -vlo) | (F_hi < np.inf)
    todo = np.flatnonzero(~(V.lo > level) & ~(vdot.hi < 0) & ~(F_hi < 0) & promising)
    if not len(todo):
        return vdot, F_hi
    m = len(lo)
    vd_lo = np.array(np.broadcast_to(vdot.lo, (m,)), dtype=float)
    vd_hi = np.array(np.broadcast_to(vdot.hi, (m,)), dtype=float)
    F_hi = F_hi.copy()
    Vhi = np.broadcast_to(V.hi, (m,))
    for s in range(0, len(todo), CHUNK):
        idx = todo[s : s + CHUNK]
        X, mid = variables(lo[idx], hi[idx])
        with np.errstate(all="ignore"):
            vd = lyap.vdot_expr(system, X, LINEAR)
            if not isinstance(vd, Lin):
                continue
            a, b = vd.bounds()
            vd_lo[idx] = np.maximum(vd_lo[idx], a)
            vd_hi[idx] = np.minimum(vd_hi[idx], b)
            edge = np.flatnonzero((Vhi[idx] > level) & ~(vd_hi[idx] < 0))
            if len(edge):
                F_hi[idx[edge]] = np.minimum(F_hi[idx[edge]], _multiplier_hi(
                    lyap, [_rows(x, edge) for x in X], _rows(vd, edge), mid[edge], level))  # fmt: skip
    return Interval(vd_lo, np.maximum(vd_lo, vd_hi)), F_hi


def _rows(q: Lin, k: np.ndarray) -> Lin:
    return Lin(q.lA[k], q.lc[k], q.uA[k], q.uc[k], Interval(q.iv.lo[k], q.iv.hi[k]), q.r[k])


def _multiplier_hi(lyap: Lyapunov, X: list[Lin], vd: Lin, mid: np.ndarray, level: float) -> Any:
    """An upper bound over each box of ``V' + lambda (level - V)`` with ``lambda >= 0`` the
    float that makes the affine bounds' slopes cancel best (least squares)."""
    Vl = _v_lower(lyap, X, mid)
    gv = Vl.lA
    with np.errstate(all="ignore"):
        lam = np.sum(vd.uA * gv, axis=1) / np.sum(gv * gv, axis=1)
    lam = np.where(np.isfinite(lam) & (lam > 0), lam, 0.0)
    const = Interval(lam) * Interval(level)
    F = combine([(np.ones(len(lam)), np.ones(len(lam)), vd), (-lam, -lam, Vl)],
                Interval(np.full(len(lam), -np.inf), np.inf), (const.lo, const.hi))  # fmt: skip
    return F.bounds()[1]
