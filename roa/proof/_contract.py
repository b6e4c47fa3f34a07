"""Boxes shrunk to the part of them that can meet a sublevel set of a quadratic V.

For ``V = sum_{p <= q} c_pq d_p d_q`` (``d = x - c``, :class:`roa.proof.QuadraticForm`)
and a box ``B``, every point of ``B`` with ``V <= level`` has, for each coordinate ``i`` with
``c_ii > 0``,

    c_ii d_i^2 <= level - R_i,     R_i = sum of the other terms, enclosed on B,

so ``|d_i| <= sqrt((level - min R_i) / c_ii)``. :func:`contract` replaces each side of ``B`` by its
intersection with that interval, coordinate after coordinate (each step keeps every point of
``B`` with ``V <= level``, so the sequence does), in outward-rounded arithmetic. A box left empty
has ``V > level`` everywhere. The branch and bound evaluates and splits the shrunk boxes: the
claim ``V' < 0`` on ``{V <= level}`` needs nothing outside them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.proof._interval import Interval, box_offsets, round_down, round_up


def contract(quad: Any, lo: np.ndarray, hi: np.ndarray, level: float
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """``(lo, hi, empty)``: the boxes shrunk (module doc; the columns past ``quad.n``, e.g.
    parameters, unchanged) and the mask of boxes on which ``V > level`` is proved."""
    n = quad.n
    lo, hi = lo.copy(), hi.copy()
    empty = np.zeros(len(lo), dtype=bool)
    c = np.broadcast_to(quad.center, (len(lo), n))
    with np.errstate(invalid="ignore", over="ignore"):
        for i in range(n):
            cii = quad.coef.get((i, i))
            if cii is None:
                continue
            c_lo = float(Interval.of(cii).lo)
            if not c_lo > 0:
                continue
            d = box_offsets(lo[:, :n], hi[:, :n], c)
            rest: Any = 0.0
            for (p, q), cpq in quad.coef.items():
                if p == q == i:
                    continue
                term = d[p].square() * cpq if p == q else (d[p] * d[q]) * cpq
                rest = term + rest
            r_lo = np.broadcast_to(Interval.of(rest).lo, (len(lo),))
            u = round_up(round_up(level - r_lo) / c_lo)  # d_i^2 <= u
            empty |= u < 0
            s = round_up(np.sqrt(np.maximum(u, 0.0)))
            ok = np.isfinite(s)
            new_lo = np.where(ok, np.maximum(lo[:, i], round_down(c[:, i] - s)), lo[:, i])
            new_hi = np.where(ok, np.minimum(hi[:, i], round_up(c[:, i] + s)), hi[:, i])
            empty |= new_lo > new_hi
            lo[:, i] = np.where(empty, lo[:, i], new_lo)
            hi[:, i] = np.where(empty, hi[:, i], new_hi)
    return lo, hi, empty
