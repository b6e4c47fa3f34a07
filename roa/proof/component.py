"""The certified part of ``{V <= level}`` for a non-quadratic V, for terminal sets.

For a quadratic V the level set is an ellipsoid and all of it is certified. For any other V the
interval validation (:func:`roa.proof.validate.validate_level`) proves ``V' < 0`` on
``{V <= level} ∩ B`` for a box ``B`` of its frame ``y`` (``x = c + M y``, ``M`` the whitening in
the certificate, else the identity) with ``V > level`` on the faces of ``B``, so ``B`` holds the
connected component ``C0`` of ``{V <= level}`` that contains the equilibrium ``c``. The box ``B``
is not in the certificate, but every box holding ``C0`` holds its bounding box, so the bounding
box of points *proved* to lie in ``C0`` lies in ``B``, and ``{V <= level}`` inside it is
certified (other components of ``{V <= level}``, which no certificate covers, are left out).

:func:`component_box` finds those points along rays from ``c`` (first exit of the level set,
then :func:`roa.proof.cover.connected_to_center`: interval enclosures prove the segment
from ``c`` lies in the set) and returns their bounding box in ``y``, shrunk by a relative
``1e-9`` against rounding in ``y = M^-1 (x - c)``.
"""

from __future__ import annotations

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov

#: Relative shrink of the proved box (rounding of the frame map).
BOX_MARGIN = 1e-9


def _exits(V: Lyapunov, level: float, U: np.ndarray) -> np.ndarray:
    """Per direction (rows of ``U``, in x): the last t before V first exceeds ``level`` along
    ``c + t u`` (inf if it never does for t <= 1e6), to 50 bisection steps."""
    from roa.proof.cover import ray_exits

    lo, _, found = ray_exits(V.value, np.asarray(V.center, dtype=float), U, level)
    return np.where(found, lo, np.inf)


def _points(V: Lyapunov, level: float, M: np.ndarray, Z: np.ndarray) -> tuple[np.ndarray, ...]:
    """Exit points (x, slightly inside) along the frame directions ``Z`` and their ``y``."""
    c = np.asarray(V.center, dtype=float)
    U = Z @ M.T  # the frame's directions in x
    t = _exits(V, level, U)
    keep = np.isfinite(t) & (t > 0)
    X = c + (t[keep] * (1 - 1e-6))[:, None] * U[keep]
    return X, np.linalg.solve(M, (X - c).T).T


def component_box(
    V: Lyapunov,
    level: float,
    M: np.ndarray | None = None,
    *,
    n_dirs: int = 2000,
    seed: int = 0,
    tries: int = 6,
) -> tuple[np.ndarray, np.ndarray]:
    """``(lo, hi)`` in the frame ``y = M^-1 (x - c)``: a box inside the bounding box of the
    component of ``{V <= level}`` holding the centre ``c`` (see the module docstring).

    Per side of the box: exits along ``n_dirs`` random directions, the axes and the extreme
    directions of V's quadratic part, the best refined by random perturbations; the most extreme
    exit point proved connected to ``c`` (of the ``tries`` best) gives the side (0 if none)."""
    from roa.proof.cover import connected_to_center

    n = V.n
    M = np.eye(n) if M is None else np.asarray(M, dtype=float)
    if M.shape != (n, n) or not np.isfinite(M).all() or abs(np.linalg.det(M)) == 0:
        raise RoaInputError(f"the certificate's frame M must be an invertible {n}x{n} matrix")
    rng = np.random.default_rng(seed)
    H = M.T @ V.hessian_at_center() @ M  # V's Hessian in the frame
    try:
        quad = np.linalg.solve(H, np.eye(n)).T  # rows: extreme directions of y_k on y'Hy = 1
    except np.linalg.LinAlgError:
        quad = np.eye(n)
    Z = np.concatenate([np.eye(n), quad, rng.standard_normal((n_dirs, n))])
    Z = np.concatenate([Z, -Z])
    Z /= np.linalg.norm(Z, axis=1, keepdims=True)
    X, Y = _points(V, level, M, Z)
    lo, hi = np.zeros(n), np.zeros(n)
    for k in range(n):
        for sgn, out in ((1.0, hi), (-1.0, lo)):
            Xs, Ys = X, Y
            if len(Y):
                best = Y[np.argmax(sgn * Y[:, k])]
                for sigma in (0.2, 0.05, 0.0125, 0.003):  # refine the best direction
                    d = best / np.linalg.norm(best) + sigma * rng.standard_normal((64, n))
                    Xp, Yp = _points(V, level, M, d / np.linalg.norm(d, axis=1, keepdims=True))
                    Xs, Ys = np.concatenate([Xs, Xp]), np.concatenate([Ys, Yp])
                    best = Ys[np.argmax(sgn * Ys[:, k])]
            for i in np.argsort(-sgn * Ys[:, k])[:tries]:
                if sgn * Ys[i, k] <= 0:
                    break
                if connected_to_center(V, Xs[i], level):
                    out[k] = Ys[i, k]
                    break
    w = hi - lo
    return lo + BOX_MARGIN * w, hi - BOX_MARGIN * w
