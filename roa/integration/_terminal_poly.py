"""Membership in a polynomial terminal set: one arithmetic, in numpy and in the numba kernels.

The set (:meth:`roa.integration.TerminalSet.polynomial`) is

    { y : z = Mi (y - c) in [lo, hi],  V(y) + g S(y) <= thr },

with ``V = sum_k a_k prod_i d_i^E[k, i]`` (``d = y - c``), ``S = sum_k |a_k prod_i d_i^E[k, i]|``
and ``thr = level (1 - REL_MARGIN)``. ``g = 2 (K + deg + n + 1) u`` (``deg`` the total degree,
``u`` the unit roundoff) bounds three roundings together:

* V computed this way (the coefficients ``a_k`` are doubles already; powers by repeated
  multiplication, each term with at most ``deg + n`` rounded multiplications, ``K`` terms summed
  in order): ``|fl(V) - V(d)| <= gamma_{K + deg + n} S``, Higham's gamma;
* ``d = fl(y - c)`` itself: each component is off by a factor ``1 + delta``, ``|delta| <= u``,
  so each term by at most ``gamma_deg`` of its size, V by at most ``gamma_deg S``;
* ``S`` computed in floats, and ``g S`` (relative error ``gamma_{K + 2 deg + n + 1}``): a
  second-order term.

Their sum is below ``(K + 2 deg + n) u (1 + O(u)) S <= g fl(S)`` (``g`` leaves ``(K + n + 2) u
S`` for the second-order terms; Higham's model excludes underflow, whose absolute errors of at
most 2^-1074 per operation are far below ``level REL_MARGIN``): a point counts only if V at the
exact ``y - c`` is below ``thr``. The rounding of the final sum ``V + g S`` is covered by
``REL_MARGIN``, that of ``z`` by the box's own shrink
(:data:`roa.proof._component.BOX_MARGIN`). The coordinate map (the analysis
coordinates of a simulated state, e.g. ``z1 = q + arsinh(tan theta)``, which can cancel) is
evaluated in floats as in the quadratic test: its rounding is part of the simulated state's own
error, which no terminal set test bounds (nor does the baseline's integration).

:func:`member_numpy` (rows of an array) and :func:`member_numba` (one point, in the kernels) do
the same operations in the same order, so they give the same bits (tests/integration/test_terminal_poly.py);
the box test comes first, so a point outside the box costs ``n^2`` multiply-adds, not V.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numba
import numpy as np

from roa.errors import RoaInputError

#: Unit roundoff of IEEE double.
UNIT_ROUNDOFF = 2.0**-53


class PolyArrays(NamedTuple):
    """The arrays of a polynomial terminal set, as the kernels take them."""

    Mi: np.ndarray  # (n, n): inverse of the frame, z = Mi (y - c)
    E: np.ndarray  # (K, n) int64: exponents
    A: np.ndarray  # (K,): coefficients
    B: np.ndarray  # (2, n): the box [lo, hi] in z
    g: float  # rounding bound factor
    D: int  # largest exponent of one variable


def poly_arrays(V: Any, frame: np.ndarray, box: tuple[np.ndarray, np.ndarray]) -> PolyArrays:
    """The arrays of ``{V <= .}`` in ``box`` (frame ``z = frame^-1 (y - V.center)``)."""
    terms = V.polynomial_view()
    if terms is None:
        raise RoaInputError(f"V {V.name!r} is not polynomial: no polynomial terminal set")
    E = np.array(list(terms), dtype=np.int64).reshape(len(terms), V.n)
    A = np.array(list(terms.values()), dtype=float)
    n, K, D = V.n, E.shape[0], int(E.max())
    g = 2.0 * (K + int(E.sum(axis=1).max()) + n + 1) * UNIT_ROUNDOFF
    Mi = np.ascontiguousarray(np.linalg.inv(np.asarray(frame, dtype=float)))
    B = np.ascontiguousarray(np.stack([np.asarray(box[0], float), np.asarray(box[1], float)]))
    for a in (Mi, E, A, B):  # part of an immutable TerminalSet
        a.setflags(write=False)
    return PolyArrays(Mi, E, A, B, g, D)


def member_numpy(Y: np.ndarray, c: np.ndarray, arr: PolyArrays, thr: float) -> np.ndarray:
    """Rows of ``Y`` (analysis coordinates, shape ``(m, n)``) in the set (NaN rows are not)."""
    Mi, E, A, B, g, D = arr
    n = c.shape[0]
    with np.errstate(all="ignore"):
        d = np.asarray(Y, dtype=float) - c
        ok = np.ones(d.shape[0], bool)
        for i in range(n):
            z = np.zeros(d.shape[0])
            for j in range(n):
                z = z + Mi[i, j] * d[:, j]
            ok &= (z >= B[0, i]) & (z <= B[1, i])
        pw = [[np.ones(d.shape[0])] for _ in range(n)]
        for i in range(n):
            for _ in range(D):
                pw[i].append(pw[i][-1] * d[:, i])
        v = np.zeros(d.shape[0])
        s = np.zeros(d.shape[0])
        for k in range(E.shape[0]):
            m = np.full(d.shape[0], A[k])
            for i in range(n):
                m = m * pw[i][E[k, i]]
            v = v + m
            s = s + np.abs(m)
        return ok & (v + g * s <= thr)


@numba.njit(cache=True, error_model="numpy")
def member_numba(w, c, Mi, E, A, B, thr, g, d, pw):  # pragma: no cover - compiled
    """One point ``w`` in the set; ``d`` (n,) and ``pw`` (n, D + 1) are scratch arrays."""
    n = w.shape[0]
    for i in range(n):
        d[i] = w[i] - c[i]
    for i in range(n):
        z = 0.0
        for j in range(n):
            z += Mi[i, j] * d[j]
        if not (z >= B[0, i] and z <= B[1, i]):  # NaN: outside
            return False
    top = pw.shape[1]
    for i in range(n):
        p = 1.0
        pw[i, 0] = p
        for k in range(1, top):
            p *= d[i]
            pw[i, k] = p
    v = 0.0
    s = 0.0
    for k in range(E.shape[0]):
        m = A[k]
        for i in range(n):
            m *= pw[i, E[k, i]]
        v += m
        s += abs(m)
    return v + g * s <= thr
