"""Normalised cart-pole model, derived from its Lagrangian (not transcribed from the paper).

Cart of mass M at position x, point mass m on a massless rod of length l at angle theta from the
upward vertical (positive towards +x), horizontal force F on the cart::

    L = (M + m) x'^2 / 2 + m l cos(theta) x' theta' + m l^2 theta'^2 / 2 - m g l cos(theta)

Euler-Lagrange, then normalised with q = x / l, tau = t sqrt(g / l), u = F / (m g), delta = M / m::

    (1 + delta) q'' + cos(theta) theta'' - sin(theta) theta'^2 = u
    cos(theta) q'' + theta'' - sin(theta) = 0

Solved for the accelerations (den = delta + sin^2 theta)::

    q''     = ( u + theta'^2 sin(theta) - sin(theta) cos(theta) ) / den
    theta'' = ( -u cos(theta) - theta'^2 sin(theta) cos(theta) + (1 + delta) sin(theta) ) / den

The paper's (2.1) prints these two right-hand sides with q'' and theta'' swapped (erratum E1);
``ipc_paper/tests/test_symbolic.py`` re-derives them from the Lagrangian with sympy.

The functions phi0..phi3 are those of (2.3) in the coordinates (2.2), with w = tan(theta); phi1 and
phi2 carry a factor (1 + w^2)^(3/2) that the paper's (2.4) drops (erratum E2).
"""

from __future__ import annotations

from typing import Any

from roa.errors import RoaInputError
from roa.model import NP

#: Default mass ratio delta = M / m. The paper gives none; 1.0 (equal masses) is documented here.
#: The closed loop in transformed coordinates does not depend on it (ipc_paper/tests/test_ipc.py).
DEFAULT_DELTA = 1.0


#: Mass ratios allowed: beyond them the model's arithmetic (delta + sin^2, 1 / delta) is not
#: meaningful in doubles (a subnormal delta made the field NaN at the equilibrium).
DELTA_RANGE = (1e-6, 1e6)


def check_delta(delta: float) -> float:
    """``delta`` as a float in :data:`DELTA_RANGE`, else a :class:`RoaInputError` naming it."""
    try:
        delta = float(delta)
    except (TypeError, ValueError):
        raise RoaInputError(f"delta (mass ratio M/m) must be a number, got {delta!r}") from None
    lo, hi = DELTA_RANGE
    if not lo <= delta <= hi:
        raise RoaInputError(
            f"delta (mass ratio M/m) must be a number in [{lo:g}, {hi:g}], got {delta!r}"
        )
    return delta


def accelerations(q_dot: Any, theta: Any, theta_dot: Any, u: Any, delta: float, xp: Any = NP):
    """Return ``(q'', theta'')`` of the normalised cart-pole for force ``u``."""
    s, c = xp.sin(theta), xp.cos(theta)
    den = delta + s * s
    qdd = (u + theta_dot**2 * s - s * c) / den
    thdd = (-u * c - theta_dot**2 * s * c + (1 + delta) * s) / den
    return qdd, thdd


def phi0(w: Any, xp: Any = NP) -> Any:
    """phi0(w) = w (1 + w^2)^(-3/2), the only nonlinearity left in the closed loop (3.8)."""
    r = 1 + w * w
    return w / (r * xp.sqrt(r))


def phi1(w: Any, delta: float, xp: Any = NP) -> Any:
    """Corrected phi1(w) = (1 + w^2)^(3/2) / (delta (1 + w^2) + w^2)  (erratum E2)."""
    r = 1 + w * w
    return r * xp.sqrt(r) / (delta * r + w * w)


def phi2(w: Any, delta: float, xp: Any = NP) -> Any:
    """Corrected phi2(w) = (1 + delta) w (1 + w^2)^(3/2) / (delta (1 + w^2) + w^2)  (erratum E2)."""
    r = 1 + w * w
    return (1 + delta) * w * r * xp.sqrt(r) / (delta * r + w * w)


def phi3(w: Any, delta: float, xp: Any = NP) -> Any:
    """phi3(w) = w / (1 + w^2)^2 (-(1 + w^2) / (delta (1 + w^2) + w^2) + 2 (1 + w^2)), as printed."""
    r = 1 + w * w
    return w / (r * r) * (-r / (delta * r + w * w) + 2 * r)
