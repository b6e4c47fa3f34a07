"""Feedback on long work: one line per step with its time, and tqdm bars only on a terminal.

On a terminal a step shows ``label ...`` while it runs; everywhere it ends with one line
``label: 12.3 s``, so logs of non-interactive runs get a line per step and never a flood of bars.
The library stays silent unless :func:`enable` was called (the CLI does).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, TextIO

_ENABLED = False


def enable(on: bool = True) -> None:
    """Report steps on stderr (the CLI turns this on; library calls are silent by default)."""
    global _ENABLED
    _ENABLED = bool(on)


def enabled() -> bool:
    """Whether steps are reported (see :func:`enable`)."""
    return _ENABLED


def interactive(stream: TextIO | None = None) -> bool:
    """Whether ``stream`` (default stderr) is a terminal."""
    stream = sys.stderr if stream is None else stream
    return bool(getattr(stream, "isatty", lambda: False)())


@contextmanager
def step(label: str, *, stream: TextIO | None = None, min_seconds: float = 0.0,
         own_budget: bool = False) -> Iterator[None]:  # fmt: skip
    """Report ``label`` while it runs (terminal only) and its time when it ends.

    Steps shorter than ``min_seconds`` print nothing at their end. The step runs under the
    wall-clock limit of :mod:`roa.stage_limit` unless it has ``own_budget`` (it stops itself).
    """
    from roa.stage_limit import guard

    with guard(label, own_budget=own_budget), _reported(label, stream, min_seconds):
        yield


@contextmanager
def _reported(label: str, stream: TextIO | None, min_seconds: float) -> Iterator[None]:
    stream = sys.stderr if stream is None else stream
    if not _ENABLED:
        yield
        return
    t0 = time.perf_counter()
    if interactive(stream):
        print(f"  {label} ...", end="\r", file=stream, flush=True)
    try:
        yield
    finally:
        dt = time.perf_counter() - t0
        if dt >= min_seconds:
            print(f"  {label}: {dt:.1f} s", file=stream, flush=True)


def note(text: str, *, stream: TextIO | None = None) -> None:
    """One line on stderr (when enabled): progress between steps, such as an estimate."""
    if _ENABLED:
        print(f"  {text}", file=sys.stderr if stream is None else stream, flush=True)


def bar(total: int, desc: str, **kw: Any) -> Any:
    """A tqdm bar on a terminal, ``None`` elsewhere (callers skip ``update`` when ``None``)."""
    if not interactive():
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, **kw)
