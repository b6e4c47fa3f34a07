"""Divergence by growth: a run still going at ``t_final`` that is plainly blowing up.

A run only reaches ``diverge_bound`` if it gets there before ``t_final``; one at ``|x| = 1e5`` and
still growing at ``t_final`` would otherwise be ``undecided``. :func:`blows_up` names it
``diverged`` when all three hold, with ``r(t) = ||x(t) - x_eq||``, ``T = t_final`` and ``G`` the
factor :attr:`roa.StopRules.diverge_growth`:

1. far out: ``r(T) >= diverge_bound / G``;
2. grown: ``r(T) >= G * max_{t <= T/2} r(t)`` (a run that went out early and stayed there, on a
   large limit cycle say, has not grown);
3. still growing exponentially: the radial rate at the end, ``(x - x_eq) . f(x) / r^2``, is at
   least half the mean exponential rate ``ln(r(T) / r(T/2)) / (T/2)`` of the second half (a run
   levelling off, towards a far equilibrium or cycle, has a rate near 0 at the end).

This is a rule on the computed trajectory, not a proof of unboundedness: a run meeting it would
have to turn back after growing by ``G`` over half the horizon at an undiminished exponential
rate. Polynomial growth (``r ~ t``) fails (2), a run settling far away fails (3).
"""

from __future__ import annotations

import numpy as np

from roa.status import StopRules


def blows_up(
    t: np.ndarray, x: np.ndarray, f_end: np.ndarray, x_eq: np.ndarray, rules: StopRules
) -> bool:
    """Whether the run ``(t, x)`` (``t`` increasing from 0 to ``rules.t_final``, ``x`` of shape
    ``(m, n)``) meets the growth rule of the module docstring; ``f_end`` is the field at
    ``x[-1]``. Always false when ``rules.diverge_growth`` is ``None``."""
    G = rules.diverge_growth
    if G is None or len(t) < 2:
        return False
    t = np.asarray(t, dtype=float)
    d = np.asarray(x, dtype=float) - np.asarray(x_eq, dtype=float)
    f_end = np.asarray(f_end, dtype=float)
    if not (np.all(np.isfinite(d)) and np.all(np.isfinite(f_end))):
        return False
    r = np.linalg.norm(d, axis=1)
    T = float(t[-1])
    half = T / 2
    r_end = float(r[-1])
    if r_end < rules.diverge_bound / G:
        return False
    first = r[t <= half]
    r_half = float(np.interp(half, t, r))
    r_first = max(float(first.max()) if first.size else 0.0, r_half)
    if not r_end >= G * r_first:
        return False
    if r_half <= 0:
        return False
    mean_rate = float(np.log(r_end / r_half)) / half
    rate_end = float(d[-1] @ f_end) / r_end**2
    return mean_rate > 0 and rate_end >= 0.5 * mean_rate


def growth_message(r_end: float, rules: StopRules) -> str:
    """The message of a run that :func:`blows_up`."""
    return (
        f"diverged by growth: ||x - x_eq|| = {r_end:.3g} at t_final = {rules.t_final:g}, at least "
        f"{rules.diverge_growth:g} x its largest value over the first half and still growing "
        f"exponentially (diverge_bound {rules.diverge_bound:g} not reached; --diverge-growth "
        "sets the factor)"
    )
