"""Proved box covers of the sublevel sets of a general Lyapunov candidate (for the validation).

A box ``B`` *covers* ``{V <= level}`` in one of two ways:

* **globally** (:func:`gram_cover`): a :class:`~roa.lyapunov.PolynomialLyapunov` built
  from a Gram matrix ``Q`` over a basis holding the linear monomials (or its whitening
  :class:`~roa.proof.Whitened`, whose exact coefficients in ``y`` are those of
  ``m(y)' T' Q T m(y)`` when ``m(M y) = T m(y)``) satisfies
  ``V(d) = m(d)' Q' m(d) >= lambda |d|^2`` with ``Q'`` the Gram matrix that reproduces the
  coefficients exactly (floats, or the exact rationals of a whitened V) and ``Q' - lambda E``
  positive definite, checked in exact rationals (the largest of 0.999, 0.99, 0.9 times the least
  float eigenvalue that passes); then
  ``{V <= level}`` lies in the cube ``|d_i| <= sqrt(level / lambda)``;
* **by its boundary** (:func:`prove_boundary`): ``V > level`` on every face of ``B`` (interval
  branch and bound with the mean-value form), so the connected component of ``{V <= level}``
  holding the equilibrium lies inside ``B``. The box is either given or proposed by the caller
  (found along rays by :func:`roa.search.ray_box`).

:func:`prove_cover` tries them in that order (the validation's and the containment's cover);
:func:`connected_to_center` proves a point to lie in the equilibrium's component of the set.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from fractions import Fraction
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.proof._exact import exact_positive_definite
from roa.proof._interval import INTERVAL, Interval, round_up


def gram_cover(lyap: Lyapunov, level: float) -> tuple[np.ndarray, dict[str, Any]] | None:
    """Half-widths of a cube around the centre that holds all of ``{V <= level}``, or None."""
    gram = lyap.gram_view()
    if gram is None:
        return None
    basis, Q = gram
    n = lyap.n
    lin = {b.index(1): i for i, b in enumerate(basis) if sum(b) == 1}
    if sorted(lin) != list(range(n)):
        return None
    m = len(basis)
    Qx = [[Fraction(float(Q[i, j])) for j in range(m)] for i in range(m)]
    for i in range(m):  # exactly symmetric (a whitened T'QT is so only up to rounding)
        for j in range(i + 1, m):
            Qx[i][j] = Qx[j][i] = (Qx[i][j] + Qx[j][i]) / 2
    pairs: dict[tuple[int, ...], list[tuple[int, int]]] = {}
    for i, j in itertools.product(range(m), range(m)):
        key = tuple(p + q for p, q in zip(basis[i], basis[j], strict=True))
        pairs.setdefault(key, []).append((i, j))
    terms = lyap.polynomial_view() or {}
    if set(terms) - set(pairs):
        return None
    for key, idx in pairs.items():  # make m' Qx m equal the polynomial exactly
        q = terms.get(key, 0.0)  # a float coefficient (taken exactly) or an exact Fraction
        diff = (q if isinstance(q, Fraction) else Fraction(float(q))) - sum(
            Qx[i][j] for i, j in idx
        )
        if diff:
            i, j = min(idx)
            if i == j:
                Qx[i][i] += diff
            else:
                Qx[i][j] += diff / 2
                Qx[j][i] += diff / 2
    lam_f = float(np.linalg.eigvalsh(np.array(Qx, dtype=float))[0])
    if not lam_f > 0:
        return None
    for shrink in (0.999, 0.99, 0.9):  # the largest lambda proved: the smallest cube
        lam = Fraction(shrink * lam_f)
        A = [
            [Qx[i][j] - (lam if i == j and i in lin.values() else 0) for j in range(m)]
            for i in range(m)
        ]
        if exact_positive_definite(A)[0]:
            break
    else:
        return None
    half = float(round_up(np.sqrt(float(Fraction(level) / lam)), 4))
    return np.full(n, half), {"cover": "global (Gram lower bound)", "component": False,
                              "lambda": float(lam)}  # fmt: skip


def bisect_widest(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every box ``[lo, hi]`` (rows) cut in two halves across its widest side."""
    k = np.argmax(hi - lo, axis=1)
    rows = np.arange(len(lo))
    cut = 0.5 * (lo[rows, k] + hi[rows, k])
    lo2, hi1 = lo.copy(), hi.copy()
    hi1[rows, k] = cut
    lo2[rows, k] = cut
    return np.concatenate([lo, lo2]), np.concatenate([hi1, hi])


def interval_value(lyap: Lyapunov, lo: np.ndarray, hi: np.ndarray) -> Interval:
    """Enclosure of V on boxes: natural extension intersected with the mean-value form."""
    n = lyap.n
    X = [Interval(lo[:, i], hi[:, i]) for i in range(n)]
    nat = Interval.of(lyap.expr(X, INTERVAL))
    mid = 0.5 * (lo + hi)
    M = [Interval(mid[:, i]) for i in range(n)]
    mv = Interval.of(lyap.expr(M, INTERVAL))
    g = lyap.gradient_expr(X, INTERVAL)
    for i in range(n):
        gi = g[i] if isinstance(g[i], Interval) else Interval(np.full(len(lo), float(g[i])))
        mv = mv + gi * (X[i] - M[i])
    lo_b = np.broadcast_to(np.maximum(nat.lo, mv.lo), (len(lo),))
    hi_b = np.broadcast_to(np.minimum(nat.hi, mv.hi), (len(lo),))
    return Interval(lo_b, hi_b)


def prove_boundary(
    lyap: Lyapunov, lo: np.ndarray, hi: np.ndarray, level: float, *, budget: int = 400_000
) -> tuple[bool, int]:
    """Prove ``V > level`` on every face of the box ``[lo, hi]`` (returns (proved, boxes));
    not proved once more than ``budget`` boxes are evaluated (the validation passes its own
    ``max_boxes``)."""
    n = lyap.n
    boxes = 0
    for k, side in itertools.product(range(n), (0, 1)):
        flo, fhi = lo.copy()[None, :], hi.copy()[None, :]
        flo[:, k] = fhi[:, k] = (lo if side == 0 else hi)[k]
        while len(flo):
            boxes += len(flo)
            if boxes > budget:
                return False, boxes
            V = interval_value(lyap, flo, fhi)
            und = ~(V.lo > level)
            flo, fhi = flo[und], fhi[und]
            if not len(flo):
                break
            if np.any(lyap.value(0.5 * (flo + fhi)) <= level):
                return False, boxes  # the level set reaches this face
            w = (fhi - flo) * (np.arange(n) != k)
            j = np.argmax(w, axis=1)
            if np.max(w) < 1e-9 * max(1.0, float(np.max(hi - lo))):
                return False, boxes
            rows = np.arange(len(flo))
            mid = 0.5 * (flo[rows, j] + fhi[rows, j])
            a_hi, b_lo = fhi.copy(), flo.copy()
            a_hi[rows, j] = mid
            b_lo[rows, j] = mid
            flo, fhi = np.concatenate([flo, b_lo]), np.concatenate([a_hi, fhi])
    return True, boxes


def prove_cover(
    lyap: Lyapunov,
    level: float,
    bounding_box: Any,
    budget: int = 400_000,
    estimate: Callable[[Lyapunov, float], np.ndarray | None] | None = None,
) -> tuple[Any, dict[str, Any], str]:
    """(lo, hi) of a proved cover, its description (``info["component"]``: whether it holds only
    the equilibrium's component of ``{V <= level}``), or (None, info, why not); ``budget``: boxes
    of the face proofs (:func:`roa.proof._cover.prove_boundary`) over all the boxes tried;
    ``estimate(V, level)``: half-widths of a box reached by the level set (a proposal, e.g.
    :func:`roa.search.ray_box`; None when V stays below the level along some ray), grown
    until ``V > level`` is proved on its faces, when there is neither a Gram cover nor a
    ``bounding_box``."""
    c = lyap.center
    found = gram_cover(lyap, level)
    if found is not None:
        return (c - found[0], c + found[0]), found[1], ""
    if bounding_box is not None:
        b = np.asarray(bounding_box, dtype=float)
        if b.shape == (lyap.n,):
            lo, hi = c - b, c + b
        elif b.shape == (2, lyap.n):
            lo, hi = b[0], b[1]
        else:
            raise RoaInputError(
                f"bounding_box must be {lyap.n} half-widths or a (lo, hi) pair of {lyap.n}-vectors"
            )
        if not (np.all(np.isfinite(b)) and np.all(lo < c) and np.all(c < hi)):
            raise RoaInputError("bounding_box must be finite and hold the equilibrium inside")
        ok, nb = prove_boundary(lyap, lo, hi, level, budget=budget)
        info = {"cover": "given box, V > level on its faces (component of x_eq)", "component": True,
                "cover_boxes": nb}  # fmt: skip
        return ((lo, hi), info, "") if ok else (None, info, "V > level not proved on its faces")
    if estimate is None:
        return None, {}, "no Gram cover, no bounding box and no estimate of one (rays) given"
    w = estimate(lyap, level)
    if w is None:
        return None, {}, "V stays below the level along some ray: the sublevel set is unbounded"
    total = 0
    for k in range(6):
        half = w * 1.05 * 1.3**k + 1e-12 * (1 + np.abs(c))
        ok, nb = prove_boundary(lyap, c - half, c + half, level, budget=budget - total)
        total += nb
        if ok:
            info = {"cover": "box from rays, V > level on its faces (component of x_eq)",
                    "component": True, "cover_boxes": total}  # fmt: skip
            return (c - half, c + half), info, ""
        if total >= budget:
            break
    return None, {"cover_boxes": total}, (f"V > level could not be proved on the faces of a box "
                                          f"({total} boxes, budget {budget})")  # fmt: skip


def connected_to_center(lyap: Lyapunov, w: np.ndarray, level: float, *, rounds: int = 40) -> bool:
    """Prove that the segment from the equilibrium to ``w`` lies in ``{V <= level}`` (so ``w`` is
    in the connected component of the equilibrium): interval enclosures of V on boxes covering
    pieces of the segment, pieces split until proved (False if not proved)."""
    c = np.asarray(lyap.center, dtype=float)
    w = np.asarray(w, dtype=float)
    t = np.linspace(0.0, 1.0, 65)
    t0, t1 = t[:-1], t[1:]
    for _ in range(rounds):
        a = c + t0[:, None] * (w - c)
        b = c + t1[:, None] * (w - c)
        V = interval_value(lyap, np.minimum(a, b), np.maximum(a, b))
        if np.any(V.lo > level):
            return False  # the segment leaves the set: no proof along it
        todo = ~(V.hi <= level)
        if not todo.any():
            return True
        mid = 0.5 * (t0[todo] + t1[todo])
        t0 = np.concatenate([t0[todo], mid])
        t1 = np.concatenate([mid, t1[todo]])
        if len(t0) > 100_000:
            return False
    return False
