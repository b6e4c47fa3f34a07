"""A wall-clock budget for a basin run: chunks stop cleanly when it runs out.

Claims: a chunk is either run completely or not at all (a chunk cut by the budget returns no
statuses and is never saved), so a run cut by its budget is resumed from its completed chunks and
the statuses of every initial condition are those of a run without a budget (each trajectory is
integrated on its own; slicing a chunk changes nothing).

Granularity: the budget is checked before each chunk, between slices of :data:`SLICE` initial
conditions inside the numba kernel's chunks (numba cannot read a clock in compiled code; one
trajectory is bounded by ``t_final`` and the minimum step), and at every field evaluation of the
numpy integrator (so a slow Python field is stopped within one evaluation).

Assumption: the deadline is absolute wall-clock time (``time.time()``) so that worker processes,
and Dask workers on other machines with synchronised clocks, compare against the same instant.
"""

from __future__ import annotations

import time

#: Initial conditions integrated by the numba kernel between two checks of the budget.
SLICE = 32


class BudgetExhausted(Exception):
    """The wall-clock budget ran out inside a chunk (the chunk's statuses are discarded)."""


def now() -> float:
    """Wall-clock time in seconds (a function of its own so that tests can replace the clock)."""
    return time.time()


def deadline_of(time_limit: float | None) -> float | None:
    """The absolute deadline of a budget of ``time_limit`` seconds from now (None: no budget)."""
    return None if time_limit is None else now() + float(time_limit)


def expired(deadline: float | None) -> bool:
    """Whether ``deadline`` (absolute, from :func:`deadline_of`) has passed."""
    return deadline is not None and now() >= deadline


def check(deadline: float | None) -> None:
    """Raise :class:`BudgetExhausted` if ``deadline`` has passed."""
    if expired(deadline):
        raise BudgetExhausted
