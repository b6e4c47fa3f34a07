"""A wall-clock limit on each long step of a command: ``--time-limit`` where a step has no
budget of its own.

Interval validations and the V-s iteration stop at their own budget with a result that says so
(inconclusive, stopped). Other long steps (the SOS program's assembly and solve, a level search,
tracing a field with sympy, compiling a kernel) have no such budget: under :func:`limit` each
outermost step (a :func:`roa.progress.step`, or :func:`guard` directly) raises
:class:`roa.errors.TimeLimitReached` once it has run for the limit, naming the step.

Claims and assumptions: the limit is a POSIX interval timer (``SIGALRM``), armed only in the
main thread; the exception is raised between two Python bytecodes, so native code (a solver's
iteration, a numba kernel) ends its call first. Nested steps run under the outermost step's
timer. The library sets no limit unless :func:`limit` is called (the CLI does for
``--time-limit``).
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from roa.errors import TimeLimitReached

_LIMIT: float | None = None
#: "idle" (no step), "armed" (an outermost step under the timer), "own" (a step with its own
#: budget: the timer paused, nested steps not limited).
_STATE = "idle"


def limit(seconds: float | None) -> None:
    """Limit every later outermost step to ``seconds`` of wall-clock time (``None``: no limit)."""
    global _LIMIT
    _LIMIT = None if seconds is None else float(seconds)


@contextmanager
def guard(label: str, *, own_budget: bool = False) -> Iterator[None]:
    """Run the block as the step ``label``: under the limit when it is the outermost step;
    a step with ``own_budget`` pauses the timer of an enclosing step (it stops itself) and the
    steps inside it are not limited."""
    global _STATE
    usable = hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()
    if _LIMIT is None or not usable:
        yield
        return
    if own_budget:
        before = _STATE
        left = signal.setitimer(signal.ITIMER_REAL, 0)[0] if before == "armed" else 0.0
        _STATE = "own"
        try:
            yield
        finally:
            _STATE = before
            if before == "armed":
                signal.setitimer(signal.ITIMER_REAL, max(left, 1e-3))
        return
    if _STATE != "idle":  # nested: under the enclosing step's timer, or its own budget
        yield
        return
    seconds = _LIMIT
    # a timer the caller had armed (e.g. a test's watchdog) is kept: it fires on time, through
    # its own handler, and runs on after the step
    prev_left = signal.getitimer(signal.ITIMER_REAL)[0]
    t0 = time.monotonic()

    def on_alarm(signum: int, frame: Any) -> None:
        if time.monotonic() - t0 < seconds * (1 - 1e-3) and callable(old):  # the caller's
            old(signum, frame)
            return
        raise TimeLimitReached(
            f"the time limit of {seconds:g} s ran out during the step {label!r} (a step "
            "without a budget of its own is stopped at the limit); no result"
        )

    old = signal.signal(signal.SIGALRM, on_alarm)
    _STATE = "armed"
    signal.setitimer(signal.ITIMER_REAL, min(seconds, prev_left) if prev_left > 0 else seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
        _STATE = "idle"
        if prev_left > 0:
            signal.setitimer(signal.ITIMER_REAL, max(prev_left - (time.monotonic() - t0), 1e-3))
