"""Certified sectors: a proved lower bound ``t`` with ``form(curve(s)) <= level`` for all ``|s| <= t``.

:func:`roa.search.sector` reads the sector off a float grid and bisection (an estimate).
:func:`certified_sector` proves it: ``[0, t]`` and ``[-t, 0]`` are covered by closed intervals ``S``
of the parameter, each with an interval enclosure (:data:`roa.proof.INTERVAL`, outward
rounding) of ``form(curve(S))`` whose upper bound is ``<= level``. The pieces are found by a
vectorised subdivision: the parameter range is cut into ``pieces`` intervals, the proved prefix is
kept and the first unproved interval is cut again, until it is narrower than ``tol``.

``form`` and ``curve`` are written against a namespace ``xp`` (like a system's field), e.g. a
quadratic form of a coordinate map, :func:`quadratic_form`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from roa.errors import require
from roa.proof._interval import INTERVAL, Interval, round_down
from roa.proof._jet import add_exact

#: ``180 / pi`` rounded down with margin: the exact value is within one ulp of the float.
_DEG_PER_RAD_LOWER = float(round_down(180.0 / np.pi))


def quadratic_form(
    P: np.ndarray, coords: Callable[[Sequence[Any], Any], Sequence[Any]] | None = None
) -> Callable[[Sequence[Any], Any], Any]:
    """``x -> y' P y`` with ``y = coords(x, xp)`` (identity by default), for any namespace ``xp``.

    Evaluated as ``sum_i P_ii y_i^2 + sum_{i<j} (P_ij + P_ji) y_i y_j`` (the squares as squares:
    tight in interval arithmetic). ``P`` is taken exactly (its float entries; in the interval
    namespace ``P_ij + P_ji`` is enclosed when it is not a double).
    """
    P = np.asarray(P, dtype=float)
    require(
        P.ndim == 2 and P.shape[0] == P.shape[1] and bool(np.all(np.isfinite(P))),
        f"P must be a finite square matrix, got shape {P.shape}",
    )
    n = P.shape[0]
    pairs = {
        (i, j): add_exact(float(P[i, j]), float(P[j, i])) for i in range(n) for j in range(i + 1, n)
    }

    def form(x: Sequence[Any], xp: Any) -> Any:
        y = list(x if coords is None else coords(x, xp))
        require(len(y) == n, f"coords give {len(y)} components, P is {n} x {n}")
        interval = getattr(xp, "name", "") == "interval"
        if interval:
            y = [Interval.of(v) for v in y]
        out: Any = 0.0
        for i in range(n):
            if P[i, i] != 0.0:
                sq = y[i].square() if interval else y[i] * y[i]
                out = sq * float(P[i, i]) + out
            for j in range(i + 1, n):
                c = pairs[i, j]
                if interval or isinstance(c, float):
                    if not (isinstance(c, float) and c == 0.0):
                        out = (y[i] * y[j]) * c + out
                else:  # a float namespace: the rounded sum
                    out = (y[i] * y[j]) * (float(P[i, j]) + float(P[j, i])) + out
        return out

    return form


def _reach(form: Callable, level: float, curve: Callable, t_max: float, sign: float, **kw) -> float:
    """Largest proved ``a`` in ``[0, t_max]``: ``form(curve(sign * s)) <= level`` on ``[0, a]``."""
    pieces, tol, max_rounds = kw["pieces"], kw["tol"], kw["max_rounds"]
    a, coarse = 0.0, t_max / pieces
    step = coarse
    proved_any = False
    for _ in range(max_rounds):
        edges = np.minimum(a + step * np.arange(pieces + 1), t_max)
        edges[0] = a
        lo, hi = edges[:-1], edges[1:]
        S = Interval(lo, hi) if sign > 0 else Interval(-hi, -lo)
        with np.errstate(all="ignore"):
            val = Interval.of(form(curve(S, INTERVAL), INTERVAL))
        ok = np.broadcast_to(val.hi <= level, lo.shape)
        k = len(lo) if ok.all() else int(np.argmin(ok))
        if k:
            proved_any = True
            a = float(hi[k - 1])
        if a >= t_max:
            return t_max
        if k < len(lo):  # refine the first unproved piece
            if step <= tol:
                break
            step /= pieces
        else:  # all proved: back to coarser pieces
            step = min(step * pieces, coarse)
    if not proved_any:  # not even [0, first piece]: try the point s = 0 alone
        with np.errstate(all="ignore"):
            val = Interval.of(form(curve(Interval(np.zeros(1)), INTERVAL), INTERVAL))
        return 0.0 if np.all(val.hi <= level) else -np.inf
    return a


def certified_sector(
    form: Callable[[Sequence[Any], Any], Any],
    level: float,
    curve: Callable[[Any, Any], Sequence[Any]],
    t_max: float,
    *,
    pieces: int = 64,
    tol: float = 1e-10,
    max_rounds: int = 400,
) -> float:
    """A proved lower bound ``t`` in ``[0, t_max]`` of the sector of ``{form <= level}`` along ``curve``.

    ``form(curve(s), INTERVAL) <= level`` is proved by interval arithmetic for every real ``s``
    with ``|s| <= t`` (module docstring). ``-inf`` if not even ``s = 0`` can be proved.

    Parameters
    ----------
    form : callable
        ``form(x, xp)``: the function of the state components ``x`` in the namespace ``xp``
        (e.g. :func:`quadratic_form`).
    level : float
        The level (finite).
    curve : callable
        ``curve(s, xp)``: state components along the curve at the parameter(s) ``s`` (an
        :class:`~roa.proof.Interval` of many parameter intervals); components may be
        floats (constants).
    t_max : float
        Largest parameter of interest (finite, > 0); the result is at most ``t_max``.
    pieces : int
        Intervals per subdivision round (>= 2).
    tol : float
        Width (> 0) below which an unproved parameter interval is not cut further; the result
        is within about ``tol`` of what interval evaluation can prove.
    max_rounds : int
        Bound on the subdivision rounds per side (>= 1).
    """
    level, t_max = float(level), float(t_max)
    require(np.isfinite(level), f"level must be finite, got {level!r}")
    require(np.isfinite(t_max) and t_max > 0, f"t_max must be a finite number > 0, got {t_max!r}")
    require(int(pieces) >= 2, f"pieces must be an integer >= 2, got {pieces!r}")
    require(np.isfinite(tol) and tol > 0, f"tol must be a finite number > 0, got {tol!r}")
    require(int(max_rounds) >= 1, f"max_rounds must be an integer >= 1, got {max_rounds!r}")
    kw = {"pieces": int(pieces), "tol": float(tol), "max_rounds": int(max_rounds)}
    return min(
        _reach(form, level, curve, t_max, 1.0, **kw), _reach(form, level, curve, t_max, -1.0, **kw)
    )


def degrees_lower(t: float) -> float:
    """A float ``<=`` the exact ``t * 180 / pi`` for ``t >= 0`` (certified sectors in degrees)."""
    t = float(t)
    require(t >= 0 or t == -np.inf, f"t must be >= 0, got {t!r}")
    if not np.isfinite(t):
        return t
    return float(round_down(t * _DEG_PER_RAD_LOWER))
