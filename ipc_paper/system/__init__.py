"""Inverted pendulum on a cart (IPC) under the flatness-based controller of the seed paper.

Two systems with the same trajectories (for |theta| < pi/2):

* :func:`closed_loop` -- physical coordinates ``(q, q', theta, theta')``, the model derived in
  :mod:`ipc_paper.system.model` with the corrected linearising force (2.5) and the law (3.3);
* :func:`transformed` -- the closed loop (3.8) in flat coordinates ``(z1, z2, w1, w2)``, which does
  not depend on the mass ratio delta.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ipc_paper.system.controller import (
    Gains,
    Reference,
    force,
    make_reference,
    virtual_input,
)
from ipc_paper.system.coordinates import (
    HALF_PI,
    from_flat,
    physical_to_flat_or_inf,
    to_flat,
    to_flat_components,
)
from ipc_paper.system.model import (
    DEFAULT_DELTA,
    accelerations,
    check_delta,
    phi0,
    phi1,
    phi2,
    phi3,
)
from roa.errors import RoaInputError
from roa.model import System

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


def _saturation(saturation: float | None) -> float | None:
    """The actuator limit as a float (> 0), or None."""
    if saturation is None:
        return None
    if not (float(saturation) > 0 and np.isfinite(float(saturation))):
        raise RoaInputError(f"saturation must be a force bound > 0, got {saturation!r}")
    return float(saturation)


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
    """The normalised force u = F / (m g) of the closed loop at (t, x), in physical coordinates.

    ``saturation``: the actuator limit, ``u`` clipped to ``[-saturation, saturation]`` by
    ``xp.clip`` (so the saturated loop runs in every namespace: numpy, CasADi, sympy, intervals
    and jets, where the validation encloses the kink).
    """
    from roa.model import NP

    xp = NP if xp is None else xp
    gains, reference = _settings(gains, reference)
    zeta = to_flat_components(x[0], x[1], x[2], x[3], xp=xp)
    v = virtual_input(t, zeta, gains, reference)
    u = force(v, zeta[2], zeta[3], check_delta(delta), xp)
    if saturation is not None:
        u = _saturate(u, float(saturation), xp)
    return u


def _saturate(u: Any, limit: float, xp: Any) -> Any:
    """``xp.clip(u, -limit, limit)``; Python's min/max for a namespace of scalars without ``clip``
    (e.g. the mpmath namespace of roa.proof._witness's 50-digit re-checks)."""
    clip = getattr(xp, "clip", None)
    return clip(u, -limit, limit) if clip is not None else min(max(u, -limit), limit)


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
        Actuator limit ``|u| <= saturation`` (> 0) on the normalised force ``u = F / (m g)``
        (:mod:`ipc_paper.system.model`); default none. ``saturation=1`` is the issue's
        ``|u| <= 1``, the saturated basin map's loop (``experiments/basin_q_theta_saturated.toml``).
    """
    delta = check_delta(delta)
    sat = _saturation(saturation)
    gains, reference = _settings(gains, reference)

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
        },
        **_kernels("physical", reference, delta=delta, h=gains.h, saturation=sat),
    )


def transformed(
    *,
    gains: Gains | None = None,
    reference: Reference | str | None = None,
    saturation: float | None = None,
    delta: float = DEFAULT_DELTA,
) -> System:
    """The closed loop (3.8) in flat coordinates ``(z1, z2, w1, w2)``; independent of delta.

    With the paper's gains and no reference, the system carries the paper's V (3.11),
    ``P = T' P_q T``, as its ``lyapunov`` and the paper's ball ``||T xi||^2`` as its ``norm``.

    ``saturation``: the saturated loop of :func:`closed_loop` (``|u| <= saturation``, mass ratio
    ``delta``) in the same coordinates, named ``ipc_flat_saturated``. The force enters only
    ``w2'``: with ``a = phi2(w1) + w2^2 phi3(w1)`` the law is ``u = (a - v) / phi1(w1)`` (2.5), and
    the model gives ``w2' = a - phi1(w1) u`` for any applied force ``u`` (``z2' = w1 + phi0 w2^2``
    does not depend on it), so ``w2' = a - phi1(w1) clip(u, -saturation, saturation)``: ``v`` where
    the force is not saturated. ``ipc_paper/tests/test_saturation.py`` checks it against the physical loop
    pushed through (2.2).
    """
    gains, reference = _settings(gains, reference)
    sat = _saturation(saturation)
    delta = check_delta(delta)

    def field(t: Any, x: Any, xp: Any) -> tuple:
        z1, z2, w1, w2 = x[0], x[1], x[2], x[3]
        v = virtual_input(t, (z1, z2, w1, w2), gains, reference)
        if sat is None:
            return (z2, w1 + phi0(w1, xp) * w2 * w2, w2, v)
        a = phi2(w1, delta, xp) + w2 * w2 * phi3(w1, delta, xp)
        p1 = phi1(w1, delta, xp)
        u = _saturate((a - v) / p1, sat, xp)
        return (z2, w1 + phi0(w1, xp) * w2 * w2, w2, a - p1 * u)

    paper_v = reference.is_zero and np.allclose(gains.h, Gains.default().h)
    from ipc_paper.system.lyapunov import P_Q, T

    return System(
        name="ipc_flat" if sat is None else "ipc_flat_saturated",
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
            **({} if sat is None else {"saturation": sat, "delta": delta}),
        },
        # the batch kernels of fast.py are of the unsaturated flat loop (3.8)
        **(_kernels("flat", reference, h=gains.h) if sat is None else {}),
    )


def transformed_uncertain(
    *,
    delta_low: float = 0.5,
    delta_high: float = 2.0,
    delta: float = DEFAULT_DELTA,
    gains: Gains | None = None,
    saturation: float | None = None,
) -> System:
    """The flat closed loop when the plant's mass ratio differs from the controller's design.

    The controller is designed with mass ratio ``delta`` (nominal, default 1); the real plant's
    ratio ``delta_plant`` is an uncertain parameter in ``[delta_low, delta_high]``. The coordinate
    map (2.2) does not involve the mass ratio, so the loop is still written in ``(z1, z2, w1, w2)``:
    the law (2.5) computes ``u = (a_c - v) / phi1_c`` with the design's ``a_c = phi2(w1, delta) +
    w2^2 phi3(w1, delta)`` and ``phi1_c = phi1(w1, delta)``, and the plant answers with
    ``w2' = a_p - phi1_p u`` (its own ``a_p``, ``phi1_p`` at ``delta_plant``; the same identity as
    :func:`transformed`'s saturated loop), so ``w2' = v`` exactly when ``delta_plant = delta``.
    ``saturation`` clips ``u`` as there. Carries the paper's V and ball (default gains).
    """
    gains, _ = _settings(gains, None)
    sat = _saturation(saturation)
    delta = check_delta(delta)
    lo, hi = check_delta(delta_low), check_delta(delta_high)
    if not lo <= delta <= hi or not lo < hi:
        raise RoaInputError(
            f"delta_low < delta_high with the design delta = {delta} between them, got "
            f"[{delta_low}, {delta_high}]"
        )
    zero = make_reference(None)

    def field(t: Any, x: Any, xp: Any, p: Any) -> tuple:
        z1, z2, w1, w2 = x[0], x[1], x[2], x[3]
        v = virtual_input(t, (z1, z2, w1, w2), gains, zero)
        a_c = phi2(w1, delta, xp) + w2 * w2 * phi3(w1, delta, xp)
        u = (a_c - v) / phi1(w1, delta, xp)
        if sat is not None:
            u = _saturate(u, sat, xp)
        dp = p.delta_plant
        a_p = phi2(w1, dp, xp) + w2 * w2 * phi3(w1, dp, xp)
        return (z2, w1 + phi0(w1, xp) * w2 * w2, w2, a_p - phi1(w1, dp, xp) * u)

    paper_v = np.allclose(gains.h, Gains.default().h)
    from ipc_paper.system.lyapunov import P_Q, T

    return System(
        name="ipc_flat_uncertain" if sat is None else "ipc_flat_uncertain_saturated",
        field=field,
        equilibrium=(0.0, 0.0, 0.0, 0.0),
        lyapunov=T.T @ P_Q @ T if paper_v else None,
        norm=T.T @ T if paper_v else None,
        state_names=FLAT_NAMES,
        state_units=("-", "1/s", "-", "1/s"),
        domain_description="R^4 (w1 = tan(theta) covers |theta| < pi/2)",
        parameters={"delta_plant": (lo, delta, hi)},
        meta={
            "gains": gains.h,
            "design_delta": delta,
            **({} if sat is None else {"saturation": sat}),
        },  # fmt: skip
    )


def closed_loop_uncertain(
    *,
    delta_low: float = 0.5,
    delta_high: float = 2.0,
    delta: float = DEFAULT_DELTA,
    gains: Gains | None = None,
) -> System:
    """The physical closed loop ``(q, q', theta, theta')`` with the law designed for mass ratio
    ``delta`` (nominal) and the plant's ratio ``delta_plant`` uncertain in
    ``[delta_low, delta_high]`` (the same loop as :func:`transformed_uncertain`, in physical
    coordinates: the force of :func:`control_force` at ``delta``, the accelerations of the model at
    ``delta_plant``). No compiled kernels: basins run on the numpy backend."""
    gains, _ = _settings(gains, None)
    delta = check_delta(delta)
    lo, hi = check_delta(delta_low), check_delta(delta_high)
    if not lo <= delta <= hi or not lo < hi:
        raise RoaInputError(
            f"delta_low < delta_high with the design delta = {delta} between them, got "
            f"[{delta_low}, {delta_high}]"
        )

    def field(t: Any, x: Any, xp: Any, p: Any) -> tuple:
        q, qd, th, thd = x[0], x[1], x[2], x[3]
        u = control_force(t, (q, qd, th, thd), delta=delta, gains=gains, xp=xp)
        qdd, thdd = accelerations(qd, th, thd, u, p.delta_plant, xp)
        return (qd, qdd, thd, thdd)

    def margin(x: Any, xp: Any) -> Any:
        return HALF_PI - xp.abs(x[2])

    return System(
        name="ipc_uncertain",
        field=field,
        equilibrium=(0.0, 0.0, 0.0, 0.0),
        state_names=PHYSICAL_NAMES,
        state_units=PHYSICAL_UNITS,
        margin=margin,
        domain_description="|theta| < pi/2 rad",
        parameters={"delta_plant": (lo, delta, hi)},
        meta={"gains": gains.h, "design_delta": delta},
    )


def _kernels(which: str, reference: Reference, **kw: Any) -> dict[str, Any]:
    """The System fields ``numba`` and ``numba_fast`` (factories) for the batch integrator (zero reference only;
    the public array signatures and the pointer-only fast path, see fast.py), and for the
    physical loop without saturation ``analysis_coords`` (terminal sets in flat or hybrid
    coordinates, roa/integration/_terminal.py)."""
    if not reference.is_zero:
        return {}
    from ipc_paper.system import fast

    if which != "physical":
        return {"numba": fast.FlatKernels(**kw), "numba_fast": fast.FlatFastKernels(**kw)}
    meta: dict[str, Any] = {
        "numba": fast.PhysicalKernels(**kw),
        "numba_fast": fast.PhysicalFastKernels(**kw),
    }
    if kw.get("saturation") is None:  # terminal sets in flat/hybrid coordinates (terminal.py)
        default = np.allclose(kw["h"], Gains.default().h)
        meta["analysis_coords"] = fast.AnalysisCoords(default_gains=bool(default))
    return meta


#: The reference 4D box of physical initial states (q, q', theta, theta') shared by the Monte Carlo
#: and certification experiments; it contains the paper's claimed sector |theta(0)| < 60 deg.
REFERENCE_BOX = ((-1.0, 1.0), (-1.0, 1.0), (-np.pi / 3, np.pi / 3), (-1.0, 1.0))
