"""Monte Carlo runs of a discrete-time system: the map ``x+ = F(x)`` iterated on a batch.

The discrete counterpart of the batch integrator (:func:`roa.integration._integrator.integrate_batch`
dispatches here for a system with ``system.time == "discrete"``). Every row is iterated until its
own first event, checked at every iterate ``x_k`` (``k = 0, 1, ...``), in this order:

* not finite, or ``|x_k| >= diverge_bound``: ``diverged``;
* ``|x_k - x_eq| <= converge_tol``: ``converged``;
* ``margin(x_k) <= margin_tol``: ``left_domain``;
* inside the terminal set (a certified, invariant ``{V <= c}``): ``converged``, entered;
* ``k * sample_time >= t_final`` without an event: ``undecided``.

``t_end`` is ``k * sample_time`` (the time of the step the event happened at) and ``steps`` is
``k``. Nothing is integrated: the runs are exactly the float iterates of ``F`` evaluated with
numpy, so a batch gives the same codes as iterating each row alone (one row per run; rows never
interact), whatever the chunking.
"""

from __future__ import annotations

import numpy as np

from roa.integration import (
    _budget as budget,
    _dopri as I,  # noqa: N812
)
from roa.integration._terminal import ENTERED, BoundTerminal
from roa.model._backend import NP
from roa.model._system import System
from roa.status import StopRules


def max_steps(system: System, t_final: float) -> int:
    """The number of steps standing for ``t_final``: ``ceil(t_final / sample_time)`` (at least 1,
    with a relative slack of 1e-9 so that ``t_final = k h`` in decimals gives ``k``)."""
    h = float(system.sample_time or 1.0)
    return max(1, int(np.ceil(t_final / h * (1 - 1e-9))))


def _events(system: System, x: np.ndarray, rules: StopRules, margin_tol: float) -> np.ndarray:
    """Per row the code of its event at ``x`` (-1: none), in the order of the module doc."""
    code = np.full(len(x), -1, np.int8)
    with np.errstate(all="ignore"):
        finite = np.isfinite(x).all(axis=1)
        big = ~finite | ~(np.linalg.norm(x, axis=1) < rules.diverge_bound)
        code[big] = I.DIVERGED
        near = np.linalg.norm(x - system.x_eq, axis=1) <= rules.converge_tol
        code[(code < 0) & near] = I.CONVERGED
        if system.margin is not None:
            m = np.broadcast_to(system.margin([x[:, i] for i in range(system.n)], NP), (len(x),))
            code[(code < 0) & ~(m > margin_tol)] = I.LEFT_DOMAIN
    return code


def iterate_map(
    system: System,
    x0: np.ndarray,
    *,
    rules: StopRules,
    margin_tol: float = 0.0,
    terminal: BoundTerminal | None = None,
    deadline: float | None = None,
) -> I.BatchResult:
    """Iterate ``system``'s map from every row of ``x0`` (shape ``(m, n)``) until its event
    (module doc). Runs that enter ``terminal`` get the internal code
    :data:`roa.integration._terminal.ENTERED`; past ``deadline`` the next step raises
    :class:`roa.integration._budget.BudgetExhausted`."""
    x0 = np.asarray(x0, dtype=float)
    m = len(x0)
    h = float(system.sample_time or 1.0)
    code = np.full(m, -1, np.int8)
    t_end = np.zeros(m)
    x_end = x0.copy()
    steps = np.zeros(m, np.int64)
    idx = np.arange(m)
    y = x0.copy()
    last = max_steps(system, rules.t_final)
    for k in range(last + 1):
        ev = _events(system, y, rules, margin_tol)
        if terminal is not None:
            free = np.flatnonzero(ev < 0)
            if free.size:
                ev[free[terminal.inside(y[free])]] = ENTERED
        if k == last:
            ev[ev < 0] = I.UNDECIDED
        stop = ev >= 0
        rows = idx[stop]
        code[rows], t_end[rows], x_end[rows], steps[rows] = ev[stop], k * h, y[stop], k
        idx, y = idx[~stop], y[~stop]
        if not idx.size:
            break
        budget.check(deadline)
        with np.errstate(all="ignore"):
            y = system.step(y, k * h)
    return I.BatchResult(code, t_end, x_end, steps)


def orbit(
    system: System, x0: np.ndarray, rules: StopRules, deadline: float | None = None
) -> tuple[int, np.ndarray, np.ndarray, bool]:
    """The orbit ``x_0, x_1 = F(x_0), ...`` of one state until its event (module doc):
    ``(code, t, x, timed_out)`` with ``t = k * sample_time`` and ``x`` of shape ``(k + 1, n)``;
    ``timed_out`` when the wall-clock ``deadline`` ended it (code ``undecided``)."""
    import time

    h = float(system.sample_time or 1.0)
    last = max_steps(system, rules.t_final)
    xs = [np.asarray(x0, dtype=float)]
    for k in range(last + 1):
        ev = int(_events(system, xs[-1][None], rules, 0.0)[0])
        if ev >= 0 or k == last:
            break
        if deadline is not None and time.perf_counter() > deadline:
            return I.UNDECIDED, h * np.arange(len(xs)), np.array(xs), True
        with np.errstate(all="ignore"):
            xs.append(system.step(xs[-1], k * h))
    code = ev if ev >= 0 else I.UNDECIDED
    return code, h * np.arange(len(xs)), np.array(xs), False
