"""The IPC closed loop (3.8) in "hybrid" coordinates ``y = (q, z2, w1, w2)``.

The flat coordinates ``(z1, z2, w1, w2)`` of (2.2) with ``z1`` replaced by the cart position
``q = z1 - arsinh(w1)``. The map is a global diffeomorphism of R^4 (inverse ``z1 = q + arsinh(w1)``),
so the closed loop keeps the domain R^4 of (3.8), while the paper's sector of initial states
``q = q' = theta' = 0`` becomes the straight line ``y = (0, 0, tan(theta), 0)`` (in flat
coordinates it is the curve ``(arsinh(tan theta), 0, tan theta, 0)``, which a quadratic V fits
badly). By the chain rule, with ``s = (1 + w1^2)^(-1/2)`` (so ``d arsinh(w1)/dt = s w2``)::

    q'  = z2 - s w2
    z2' = w1 + phi0(w1) w2^2
    w1' = w2
    w2' = v(t, (q + arsinh(w1), z2, w1, w2))        (the law (3.3))

Physical states map to ``y`` by ``q = q``, ``z2 = q' + theta' sec(theta)``, ``w1 = tan(theta)``,
``w2 = theta' sec^2(theta)`` (|theta| < pi/2).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ipc_paper.system.controller import Gains, Reference, make_reference, virtual_input
from ipc_paper.system.coordinates import physical_to_flat_or_inf
from ipc_paper.system.model import phi0
from roa.model import System

HYBRID_NAMES = ("q", "z2", "w1", "w2")


def hybrid(*, gains: Gains | None = None, reference: Reference | str | None = None) -> System:
    """The closed loop (3.8) in hybrid coordinates ``(q, z2, w1, w2)`` (module docstring).

    Parameters
    ----------
    gains : Gains, optional
        Hurwitz coefficients of p(s); default (s + 1)^4.
    reference : Reference or str, optional
        F*(t); default zero (regulation to the upright equilibrium).
    """
    gains = Gains.default() if gains is None else gains
    if not isinstance(reference, Reference):
        reference = make_reference(reference)

    def field(t: Any, x: Any, xp: Any) -> tuple:
        q, z2, w1, w2 = x[0], x[1], x[2], x[3]
        r = 1 + w1 * w1
        v = virtual_input(t, (q + xp.arcsinh(w1), z2, w1, w2), gains, reference)
        return (z2 - w2 / xp.sqrt(r), w1 + phi0(w1, xp) * w2 * w2, w2, v)

    return System(
        name="ipc_hybrid",
        field=field,
        equilibrium=None if not reference.is_zero else (0.0, 0.0, 0.0, 0.0),
        state_names=HYBRID_NAMES,
        state_units=("1", "1/s", "1", "1/s"),
        margin=None,
        domain_description="R^4 (w1 = tan(theta) covers |theta| < pi/2)",
        time_varying=not reference.is_zero,
        meta={"gains": gains.h, "reference": reference.description},
    )


def flat_to_hybrid(xi: np.ndarray) -> np.ndarray:
    """Flat ``(z1, z2, w1, w2)`` -> hybrid ``(q, z2, w1, w2)``, states of shape ``(..., 4)``."""
    xi = np.asarray(xi, dtype=float)
    y = xi.copy()
    y[..., 0] = xi[..., 0] - np.arcsinh(xi[..., 2])
    return y


def hybrid_to_flat(y: np.ndarray) -> np.ndarray:
    """Hybrid ``(q, z2, w1, w2)`` -> flat ``(z1, z2, w1, w2)``, states of shape ``(..., 4)``."""
    y = np.asarray(y, dtype=float)
    xi = y.copy()
    xi[..., 0] = y[..., 0] + np.arcsinh(y[..., 2])
    return xi


def physical_to_hybrid_or_inf(x: np.ndarray) -> np.ndarray:
    """Physical states -> hybrid coordinates; |theta| >= pi/2 or non-finite map to inf (set tests)."""
    x = np.asarray(x, dtype=float)
    y = physical_to_flat_or_inf(x)  # inf rows outside the domain
    y[..., 0] = np.where(np.isfinite(y[..., 0]), x[..., 0], np.inf)  # z1 -> q
    return y


def hybrid_to_physical(y: np.ndarray) -> np.ndarray:
    """Hybrid coordinates ``(..., 4)`` -> physical states ``(q, q', theta, theta')``."""
    y = np.asarray(y, dtype=float)
    q, z2, w1, w2 = np.moveaxis(y, -1, 0)
    r = 1 + w1 * w1
    return np.stack([q, z2 - w2 / np.sqrt(r), np.arctan(w1), w2 / r], axis=-1)
