"""The change of coordinates (2.2) and its inverse, vectorised.

Physical state ``x = (q, q', theta, theta')``; flat coordinates ``xi = (z1, z2, w1, w2)``::

    z1 = q + 2 artanh(tan(theta / 2))      w1 = tan(theta)
    z2 = q' + theta' sec(theta)            w2 = theta' sec^2(theta)

valid for |theta| < pi/2. We use the identity 2 artanh(tan(theta/2)) = arsinh(tan(theta)) (the
inverse Gudermannian), which is checked in tests and is better conditioned near the boundary.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.model import NP

HALF_PI = np.pi / 2


def check_physical(x: np.ndarray) -> np.ndarray:
    """Validate physical states of shape ``(..., 4)``: finite and |theta| < pi/2."""
    x = np.asarray(x, dtype=float)
    if x.ndim == 0 or x.shape[-1] != 4:
        raise RoaInputError(
            f"IPC state must have 4 components (q, q_dot, theta, theta_dot); got shape {x.shape}"
        )
    if not np.all(np.isfinite(x)):
        raise RoaInputError("IPC state must be finite (no NaN/inf) in q, q_dot, theta, theta_dot")
    th = x[..., 2]
    if np.any(np.abs(th) >= HALF_PI):
        worst = float(th.flat[np.argmax(np.abs(th))])
        raise RoaInputError(
            f"theta = {worst:.6g} rad is outside the domain |theta| < pi/2 = {HALF_PI:.6f} rad "
            "where the coordinates (2.2) and the controller are defined"
        )
    return x


def to_flat_components(q: Any, qd: Any, th: Any, thd: Any, xp: Any = NP) -> tuple:
    """(2.2) on components, for any namespace (no validation)."""
    w1 = xp.tan(th)
    sec = 1 / xp.cos(th)
    return q + xp.arcsinh(w1), qd + thd * sec, w1, thd * sec * sec


def from_flat_components(z1: Any, z2: Any, w1: Any, w2: Any, xp: Any = NP) -> tuple:
    """Inverse of (2.2) on components, for any namespace (no validation)."""
    r = 1 + w1 * w1
    th = xp.arctan(w1)
    thd = w2 / r
    return z1 - xp.arcsinh(w1), z2 - w2 / xp.sqrt(r), th, thd


def to_flat(x: np.ndarray) -> np.ndarray:
    """Map physical states ``(..., 4)`` to flat coordinates ``(..., 4)``; raises outside the domain."""
    x = check_physical(x)
    return np.stack(to_flat_components(*np.moveaxis(x, -1, 0)), axis=-1)


def from_flat(xi: np.ndarray) -> np.ndarray:
    """Map flat coordinates ``(..., 4)`` (any finite values) back to physical states."""
    xi = np.asarray(xi, dtype=float)
    if xi.ndim == 0 or xi.shape[-1] != 4:
        raise RoaInputError(
            f"flat state must have 4 components (z1, z2, w1, w2); got shape {xi.shape}"
        )
    if not np.all(np.isfinite(xi)):
        raise RoaInputError("flat state must be finite (no NaN/inf) in z1, z2, w1, w2")
    return np.stack(from_flat_components(*np.moveaxis(xi, -1, 0)), axis=-1)


def physical_to_flat_or_inf(x: np.ndarray) -> np.ndarray:
    """(2.2) without raising: states with |theta| >= pi/2 or non-finite map to inf (for set tests)."""
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(x).all(axis=-1) & (np.abs(x[..., 2]) < HALF_PI)
    safe = np.where(ok[..., None], x, 0.0)
    y = np.stack(to_flat_components(*np.moveaxis(safe, -1, 0)), axis=-1)
    return np.where(ok[..., None], y, np.inf)
