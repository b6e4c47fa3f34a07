"""Witnesses re-checked at 50 digits, moved to where they bound the optimum, and refutations.

A float point found by a search is believed only once :func:`recheck_witness` (``V' >= 0`` inside
``{V <= level}`` and the domain) or :func:`recheck_domain_witness` (``V <= level`` outside the
domain) confirms it with mpmath at 50 digits, the float coordinates taken exactly.

A refuted validation returns a point ``w`` with ``V'(w) >= 0`` inside ``{V <= level}``. A proposed
point ``x`` (the lowest such point of its neighbourhood, found by
:func:`roa.search._witness.lowest_confirmed_witness`) is *proved* to be a witness by
:func:`confirmed_bound`: ``V' >= 0`` re-checked at 50 digits and the point proved to lie in the
equilibrium's connected component of ``{V <= V(x)}``. Such a point proves the largest certifiable
level is at most ``V(x)``: every level from ``V(x)`` up is refuted by it. Nothing here optimises
or samples.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.model._backend import namespace
from roa.model._system import System
from roa.proof._cover import connected_to_center
from roa.proof._validation import Validation
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

    ns = namespace("mpmath")  # every function of roa.model._backend, also minimum, maximum, clip
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


def confirmed_bound(
    system: System, V: Lyapunov, x: np.ndarray
) -> tuple[float, dict[str, Any]] | None:
    """``(V(x), check)`` when the proposed point ``x`` proves the largest certifiable level is at
    most ``V(x)``: ``V(x)`` finite and > 0, ``x`` inside the domain, ``V'(x) >= 0`` at 50 digits
    in ``{V <= V(x) WITNESS_SLACK}`` (``check``, :func:`recheck_witness`) and ``x`` proved to lie
    in the equilibrium's component of that set (:func:`roa.proof.connected_to_center`);
    else None. Where ``x`` comes from (a local minimum of V on ``{V' >= 0}``,
    :func:`roa.search._witness.lowest_confirmed_witness`) does not matter."""
    x = np.asarray(x, dtype=float)
    if system.margin is not None and not system.inside(x[None])[0]:
        return None
    return confirmed_point(V, x, lambda top: recheck_witness(system, V, x, top))


def confirmed_point(
    V: Lyapunov, x: np.ndarray, recheck: Callable[[float], dict[str, Any]]
) -> tuple[float, dict[str, Any]] | None:
    """``(V(x), check)`` when ``V(x)`` is finite and > 0, ``check = recheck(top)`` confirms ``x``
    at ``top = V(x) WITNESS_SLACK`` and ``x`` is proved to lie in the equilibrium's component of
    ``{V <= top}``; else None."""
    with np.errstate(all="ignore"):
        v = float(V.value(x[None])[0])
    if not (np.isfinite(v) and v > 0):
        return None
    top = v * WITNESS_SLACK
    check = recheck(top)
    if check["confirmed"] and connected_to_center(V, x, top):
        return v, check
    return None


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
