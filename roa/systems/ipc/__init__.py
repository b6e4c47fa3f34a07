"""Inverted pendulum on a cart (IPC) under the flatness-based controller of the seed paper.

Two systems with the same trajectories (for |theta| < pi/2):

* :func:`closed_loop` -- physical coordinates ``(q, q', theta, theta')``, the model derived in
  :mod:`roa.systems.ipc.model` with the corrected linearising force (2.5) and the law (3.3);
* :func:`transformed` -- the closed loop (3.8) in flat coordinates ``(z1, z2, w1, w2)``, which does
  not depend on the mass ratio delta.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.system import System
from roa.systems.ipc.controller import (
    Gains,
    Reference,
    force,
    make_reference,
    virtual_input,
)
from roa.systems.ipc.coordinates import (
    HALF_PI,
    from_flat,
    physical_to_flat_or_inf,
    to_flat,
    to_flat_components,
)
from roa.systems.ipc.model import DEFAULT_DELTA, accelerations, check_delta, phi0

__all__ = [
    "closed_loop",
    "transformed",
    "control_force",
    "Gains",
    "make_reference",
    "to_flat",
    "from_flat",
    "DEFAULT_DELTA",
    "phi0",
    "physical_to_flat_or_inf",
    "REFERENCE_BOX",
]

PHYSICAL_NAMES = ("q", "q_dot", "theta", "theta_dot")
PHYSICAL_UNITS = ("-", "1/s", "rad", "rad/s")  # normalised length (-) and time
FLAT_NAMES = ("z1", "z2", "w1", "w2")


def _settings(gains: Gains | None, reference: Reference | str | None) -> tuple[Gains, Reference]:
    gains = Gains.default() if gains is None else gains
    if not isinstance(reference, Reference):
        reference = make_reference(reference)
    return gains, reference


def control_force(
    t: Any,
    x: Any,
    *,
    delta: float = DEFAULT_DELTA,
    gains: Gains | None = None,
    reference: Reference | str | None = None,
    saturation: float | None = None,
    xp: Any = None,
) -> Any:
    """The force u(t, x) of the closed loop, in physical coordinates (components of ``x``)."""
    from roa.backend import NP

    xp = NP if xp is None else xp
    gains, reference = _settings(gains, reference)
    zeta = to_flat_components(x[0], x[1], x[2], x[3], xp=xp)
    v = virtual_input(t, zeta, gains, reference)
    u = force(v, zeta[2], zeta[3], check_delta(delta), xp)
    if saturation is not None:
        if getattr(xp, "name", "") != "numpy":
            raise RoaInputError("saturation is only available with the numpy backend")
        u = np.clip(u, -saturation, saturation)
    return u


def closed_loop(
    *,
    delta: float = DEFAULT_DELTA,
    gains: Gains | None = None,
    reference: Reference | str | None = None,
    saturation: float | None = None,
) -> System:
    """The IPC with the flatness controller, in physical coordinates ``(q, q', theta, theta')``.

    Parameters
    ----------
    delta : float
        Mass ratio M/m > 0 (default 1.0; the paper gives none).
    gains : Gains, optional
        Hurwitz coefficients of p(s); default (s + 1)^4.
    reference : Reference or str, optional
        F*(t); default zero (regulation to the upright equilibrium).
    saturation : float, optional
        Actuator limit |u| <= saturation (> 0); default none.
    """
    delta = check_delta(delta)
    if saturation is not None and not (float(saturation) > 0):
        raise RoaInputError(f"saturation must be a force bound > 0, got {saturation!r}")
    gains, reference = _settings(gains, reference)
    sat = None if saturation is None else float(saturation)

    def field(t: Any, x: Any, xp: Any) -> tuple:
        q, qd, th, thd = x[0], x[1], x[2], x[3]
        u = control_force(
            t,
            (q, qd, th, thd),
            delta=delta,
            gains=gains,
            reference=reference,
            saturation=sat,
            xp=xp,
        )
        qdd, thdd = accelerations(qd, th, thd, u, delta, xp)
        return (qd, qdd, thd, thdd)

    def margin(x: Any, xp: Any) -> Any:
        return HALF_PI - xp.abs(x[2])

    return System(
        name="ipc",
        field=field,
        equilibrium=None if not reference.is_zero else (0.0, 0.0, 0.0, 0.0),
        state_names=PHYSICAL_NAMES,
        state_units=PHYSICAL_UNITS,
        margin=margin,
        domain_description="|theta| < pi/2 rad",
        time_varying=not reference.is_zero,
        meta={
            "delta": delta,
            "gains": gains.h,
            "reference": reference.description,
            "saturation": sat,
            **_numba_meta("physical", reference, delta=delta, h=gains.h, saturation=sat),
        },
    )


def transformed(*, gains: Gains | None = None, reference: Reference | str | None = None) -> System:
    """The closed loop (3.8) in flat coordinates ``(z1, z2, w1, w2)``; independent of delta.

    With the paper's gains and no reference, the system carries the paper's V (3.11),
    ``P = T' P_q T``, as its ``lyapunov`` and the paper's ball ``||T xi||^2`` as its ``norm``.
    """
    gains, reference = _settings(gains, reference)

    def field(t: Any, x: Any, xp: Any) -> tuple:
        z1, z2, w1, w2 = x[0], x[1], x[2], x[3]
        v = virtual_input(t, (z1, z2, w1, w2), gains, reference)
        return (z2, w1 + phi0(w1, xp) * w2 * w2, w2, v)

    paper_v = reference.is_zero and np.allclose(gains.h, Gains.default().h)
    from roa.systems.ipc.lyapunov import P_Q, T

    return System(
        name="ipc_flat",
        field=field,
        equilibrium=None if not reference.is_zero else (0.0, 0.0, 0.0, 0.0),
        # the paper's V (3.11) and ball ||q||^2 = ||T xi||^2 are for its gains, p(s) = (s + 1)^4
        lyapunov=T.T @ P_Q @ T if paper_v else None,
        norm=T.T @ T if paper_v else None,
        state_names=FLAT_NAMES,
        state_units=("-", "1/s", "-", "1/s"),
        margin=None,
        domain_description="R^4 (w1 = tan(theta) covers |theta| < pi/2)",
        time_varying=not reference.is_zero,
        meta={
            "gains": gains.h,
            "reference": reference.description,
            **_numba_meta("flat", reference, h=gains.h),
        },
    )


def _numba_meta(which: str, reference: Reference, **kw: Any) -> dict[str, Any]:
    """``{"numba": factory}`` for the batch integrator (zero reference only; see ipc/fast.py), and
    for the physical loop without saturation ``analysis_coords`` (terminal sets in flat or hybrid
    coordinates, roa/montecarlo/terminal.py)."""
    if not reference.is_zero:
        return {}
    from roa.systems.ipc import fast

    if which != "physical":
        return {"numba": fast.FlatKernels(**kw)}
    meta: dict[str, Any] = {"numba": fast.PhysicalKernels(**kw)}
    if kw.get("saturation") is None:  # terminal sets in flat/hybrid coordinates (terminal.py)
        default = np.allclose(kw["h"], Gains.default().h)
        meta["analysis_coords"] = fast.AnalysisCoords(default_gains=bool(default))
    return meta


#: The reference 4D box of physical initial states (q, q', theta, theta') shared by the Monte Carlo
#: and certification experiments; it contains the paper's claimed sector |theta(0)| < 60 deg.
REFERENCE_BOX = ((-1.0, 1.0), (-1.0, 1.0), (-np.pi / 3, np.pi / 3), (-1.0, 1.0))
