"""The certified part of ``{V <= level}`` for a non-quadratic V, for terminal sets.

For a quadratic V the level set is an ellipsoid and all of it is certified. For any other V the
interval validation (:func:`roa.proof.validate_level`) proves ``V' < 0`` on
``{V <= level} ∩ B`` for a box ``B`` of its frame ``y`` (``x = c + M y``, ``M`` the whitening in
the certificate, else the identity) with ``V > level`` on the faces of ``B``, so ``B`` holds the
connected component ``C0`` of ``{V <= level}`` that contains the equilibrium ``c``. The box ``B``
is not in the certificate, but every box holding ``C0`` holds its bounding box, so the bounding
box of points *proved* to lie in ``C0`` lies in ``B``, and ``{V <= level}`` inside it is
certified (other components of ``{V <= level}``, which no certificate covers, are left out).

:func:`roa.search.component_candidates` proposes those points along rays from ``c`` (first
exit of the level set); :func:`component_box` proves them (:func:`roa.proof.connected_to_center`:
interval enclosures prove the segment from ``c`` lies in the set) and returns their bounding box in
``y``, shrunk by a relative ``1e-9`` against rounding in ``y = M^-1 (x - c)``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov

#: Relative shrink of the proved box (rounding of the frame map).
BOX_MARGIN = 1e-9


def component_box(
    V: Lyapunov,
    level: float,
    M: np.ndarray | None,
    candidates: Sequence[tuple[int, float, Sequence[tuple[np.ndarray, float]]]],
) -> tuple[np.ndarray, np.ndarray]:
    """``(lo, hi)`` in the frame ``y = M^-1 (x - c)``: a box inside the bounding box of the
    component of ``{V <= level}`` holding the centre ``c`` (see the module docstring).

    ``candidates``: per side ``(k, sign, points)``, the proposed points ``(x, y_k)`` of that side
    (:func:`roa.search.component_candidates`), most extreme first; the first point proved
    connected to ``c`` (:func:`roa.proof.connected_to_center`) gives the side, a side
    without one stays at 0. Only the proof decides: a point not in the component is never used."""
    from roa.proof._cover import connected_to_center

    n = V.n
    M = np.eye(n) if M is None else np.asarray(M, dtype=float)
    if M.shape != (n, n) or not np.isfinite(M).all() or abs(np.linalg.det(M)) == 0:
        raise RoaInputError(f"the certificate's frame M must be an invertible {n}x{n} matrix")
    lo, hi = np.zeros(n), np.zeros(n)
    for k, sgn, points in candidates:
        out = hi if sgn > 0 else lo
        for x, yk in points:
            if sgn * yk <= 0:
                break
            if connected_to_center(V, x, level):
                out[k] = yk
                break
    w = hi - lo
    return lo + BOX_MARGIN * w, hi - BOX_MARGIN * w
