"""Estimates along rays from the centre of a Lyapunov candidate (proposals, never proofs).

:func:`ray_box` proposes the half-widths of a box reached by ``{V <= level}`` (random directions
and the axes, first exits by bisection, :func:`ray_exits`); :func:`roa.proof.prove_cover`
proves ``V > level`` on the faces of a box grown from it.

:func:`component_candidates` proposes, for each side of a box in the frame ``y = M^-1 (x - c)``,
the exit points of ``{V <= level}`` along rays (random directions, the axes and the extreme
directions of V's quadratic part, the best refined by random perturbations), most extreme first;
:func:`roa.proof._component.component_box` proves which of them lie in the equilibrium's
component.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov


def ray_box(
    lyap: Lyapunov, level: float, *, n_dirs: int = 4000, seed: int = 0
) -> np.ndarray | None:
    """Half-widths of the box around the centre reached by ``{V <= level}`` along rays (an
    estimate, proved afterwards by :func:`prove_boundary`); None if V stays below the level."""
    n, c = lyap.n, lyap.center
    rng = np.random.default_rng(seed)
    U = rng.standard_normal((n_dirs, n)) @ lyap.whitening().T
    U /= np.linalg.norm(U, axis=1, keepdims=True)
    U = np.concatenate([U, np.eye(n), -np.eye(n)])
    _, hi, found = ray_exits(lyap.value, c, U, level)
    if not found.all():
        return None
    return np.max(np.abs(hi[:, None] * U), axis=0)


def ray_exits(
    value: Any, c: np.ndarray, U: np.ndarray, level: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Along the rays ``c + t u`` (rows ``u`` of ``U``): ``(lo, hi, found)``, a bracket of the
    first ``t`` in [1e-6, 1e6] (a geometric grid, then 50 bisections) where ``value`` exceeds
    ``level`` (NaN counts as above); ``found`` is False where it never does on the grid."""
    t = np.geomspace(1e-6, 1e6, 241)
    with np.errstate(all="ignore"):
        above = ~(value(c + t[None, :, None] * U[:, None, :]) <= level)
    k = np.argmax(above, axis=1)
    hi = t[k]
    lo = np.where(k > 0, t[np.maximum(k - 1, 0)], 0.0)
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        with np.errstate(all="ignore"):
            b = ~(value(c + mid[:, None] * U) <= level)
        hi, lo = np.where(b, mid, hi), np.where(b, lo, mid)
    return lo, hi, above.any(axis=1)


def _exits(V: Lyapunov, level: float, U: np.ndarray) -> np.ndarray:
    """Per direction (rows of ``U``, in x): the last t before V first exceeds ``level`` along
    ``c + t u`` (inf if it never does for t <= 1e6), to 50 bisection steps."""
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


def component_candidates(
    V: Lyapunov,
    level: float,
    M: np.ndarray | None = None,
    *,
    n_dirs: int = 2000,
    seed: int = 0,
    tries: int = 6,
) -> list[tuple[int, float, list[tuple[np.ndarray, float]]]]:
    """Per side ``(k, sign)`` of the frame's box, the ``tries`` most extreme exit points
    ``(x, y_k)`` of ``{V <= level}`` along rays (``n_dirs`` random directions, the axes and the
    extreme directions of V's quadratic part, the best refined by random perturbations), most
    extreme first: the proposal :func:`roa.proof._component.component_box` proves."""
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
    out: list[tuple[int, float, list[tuple[np.ndarray, float]]]] = []
    for k in range(n):
        for sgn in (1.0, -1.0):
            Xs, Ys = X, Y
            if len(Y):
                best = Y[np.argmax(sgn * Y[:, k])]
                for sigma in (0.2, 0.05, 0.0125, 0.003):  # refine the best direction
                    d = best / np.linalg.norm(best) + sigma * rng.standard_normal((64, n))
                    Xp, Yp = _points(V, level, M, d / np.linalg.norm(d, axis=1, keepdims=True))
                    Xs, Ys = np.concatenate([Xs, Xp]), np.concatenate([Ys, Yp])
                    best = Ys[np.argmax(sgn * Ys[:, k])]
            order = np.argsort(-sgn * Ys[:, k])[:tries]
            out.append((k, sgn, [(Xs[i], float(Ys[i, k])) for i in order]))
    return out
