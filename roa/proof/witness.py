"""Witnesses re-checked at 50 digits, moved to where they bound the optimum, and refutations.

A float point found by a search is believed only once :func:`recheck_witness` (``V' >= 0`` inside
``{V <= level}`` and the domain) or :func:`recheck_domain_witness` (``V <= level`` outside the
domain) confirms it with mpmath at 50 digits, the float coordinates taken exactly.

A refuted validation returns a point ``w`` with ``V'(w) >= 0`` inside ``{V <= level}``. The lowest
such point of its neighbourhood (a local minimum of V on ``{V' >= 0}``, by SLSQP: a proposal) is
then *proved* to be a witness: ``V' >= 0`` re-checked at 50 digits and the point proved to lie in
the equilibrium's connected component of ``{V <= V(x)}``. Such a point proves the largest
certifiable level is at most ``V(x)``: every level from ``V(x)`` up is refuted by it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.model.backend import namespace
from roa.model.system import System
from roa.proof.cover import connected_to_center
from roa.proof.validation import Validation
from roa.status import Verdict

#: A confirmed witness ``x`` is checked in ``{V <= V(x) WITNESS_SLACK}``: it refutes the levels
#: at or above ``V(x) WITNESS_SLACK``.
WITNESS_SLACK = 1 + 1e-12


def recheck_witness(
    system: System, lyap: Lyapunov, x: np.ndarray, level: float, *, digits: int = 50
) -> dict[str, Any]:
    """``V(x)`` and ``V'(x)`` at ``digits`` digits (``x`` taken exactly) for any candidate:
    ``confirmed`` when ``x != x_eq``, ``x`` is inside the domain, ``V(x) <= level`` and
    ``V'(x) >= 0``."""
    import mpmath as mp

    ns = namespace("mpmath")  # every function of roa.model.backend, also minimum, maximum, clip
    with mp.workdps(digits):
        xs = [mp.mpf(float(v)) for v in x]
        V = lyap.expr(xs, ns)
        Vd = lyap.vdot_expr(system, xs, ns)
        nonzero = any(xs[i] != mp.mpf(float(lyap.center[i])) for i in range(lyap.n))
        inside = system.margin is None or system.margin(xs, ns) > 0
        return {
            "digits": digits,
            "V": mp.nstr(V, 20),
            "Vdot": mp.nstr(Vd, 20),
            "confirmed": bool(nonzero and inside and V <= mp.mpf(float(level)) and Vd >= 0),
        }


def recheck_domain_witness(
    system: System, lyap: Lyapunov, x: np.ndarray, level: float, *, digits: int = 50
) -> dict[str, Any]:
    """Confirm at ``digits`` digits that ``x`` has ``V(x) <= level`` and ``margin(x) <= 0``."""
    import mpmath as mp

    if system.margin is None:
        raise RoaInputError(f"system {system.name!r} has no domain margin")
    ns = namespace("mpmath")
    with mp.workdps(digits):
        xs = [mp.mpf(float(v)) for v in x]
        V = lyap.expr(xs, ns)
        m = system.margin(xs, ns)
        return {
            "digits": digits,
            "V": mp.nstr(V, 20),
            "margin": mp.nstr(m, 20),
            "confirmed": bool(V <= mp.mpf(float(level)) and m <= 0),
        }


def lowest_confirmed_witness(
    system: System, V: Any, w: np.ndarray
) -> tuple[float, np.ndarray | None, dict[str, Any] | None]:
    """``(value, x, check)``: a local minimum ``x`` of V on ``{V' >= delta}`` from ``w`` (SLSQP)
    whose ``V' >= 0`` holds at 50 digits (``check``) and that is proved to lie in the
    equilibrium's component of ``{V <= V(x)}``
    (:func:`roa.proof.cover.connected_to_center`); ``(V(w), None, None)`` when none is
    found at most ``V(w) (1 + 1e-6)`` (SLSQP may end a hair above a ``w`` that is already a
    local minimum; a confirmed ``x`` is a valid bound whatever its value). A confirmed ``x``
    bounds the true optimum of V by ``V(x)`` (the validation's witness sits on the level it
    refuted, the level search's near the touching point; the minimum is where V' = 0 first
    touches a level surface)."""
    from scipy.optimize import minimize

    with np.errstate(all="ignore"):
        best = float(V.value(w[None])[0])

    def vdot(x: np.ndarray) -> float:
        return float(V.derivative(system, x[None])[0])

    for delta in (1e-12, 1e-10, 1e-8):
        with np.errstate(all="ignore"):
            res = minimize(lambda x: float(V.value(x[None])[0]), w, method="SLSQP",
                           constraints=[{"type": "ineq", "fun": lambda x, dl=delta: vdot(x) - dl}],
                           options={"maxiter": 300, "ftol": 1e-15})  # fmt: skip
            x = np.asarray(res.x, dtype=float)
            v = float(V.value(x[None])[0])
        if not (np.isfinite(v) and 0 < v < best * (1 + 1e-6)):
            continue
        if system.margin is not None and not system.inside(x[None])[0]:
            continue
        top = v * WITNESS_SLACK
        check = recheck_witness(system, V, x, top)
        if check["confirmed"] and connected_to_center(V, x, top):
            return v, x, check
    return best, None, None


def refuted_by(
    x: np.ndarray,
    check: dict[str, Any],
    level: float,
    how: str,
    *,
    parameters: dict[str, float] | None = None,
) -> Any:
    """A refutation of ``level`` by a confirmed witness ``x`` with ``V(x) <= level`` (at the
    uncertain ``parameters`` when given)."""
    at = "" if not parameters else " for " + ", ".join(f"{k} = {v:.10g}"
                                                      for k, v in parameters.items())  # fmt: skip
    return Validation(Verdict.REFUTED, level, 0, 0.0, witness=[float(v) for v in x],
                      witness_check=check, witness_parameters=parameters,
                      message=f"V' >= 0 at a point of {{V <= level}} in the equilibrium's "
                      f"component{at} (float and 50 digits; {how})")  # fmt: skip
