"""Box evaluations of the branch and bound spread over worker processes.

:func:`box_evaluator` returns a callable with the signature of
:func:`roa.proof.evaluate_boxes` restricted to ``(lo, hi)``: with ``workers > 1`` it
splits each batch into ``workers`` contiguous pieces, evaluates them in forked processes (the
system and the candidate are inherited by ``fork``, never pickled: fields may be closures) and
concatenates the results in order. Every enclosure of a box depends on that box alone (the
interval, jet and relaxation operations are elementwise over boxes), so the results, and the
branch and bound's verdict and box count, are the same for every number of workers. Without
``fork`` (not POSIX), in a daemonic process or with ``workers <= 1`` the evaluation runs in the
calling process.
"""

from __future__ import annotations

import contextlib
import contextvars
import multiprocessing as mp
from collections.abc import Iterator
from typing import Any

import numpy as np

from roa.proof._interval import Interval

_STATE: dict[str, Any] = {}


def _evaluate(lo: np.ndarray, hi: np.ndarray) -> tuple[Any, ...]:
    s = _STATE
    V, Vd, F_hi, score, margin = s["evaluate"](s["system"], s["lyap"], lo, hi, s["level"],
                                               s["k"], skip_outside=True)  # fmt: skip
    m = len(lo)

    def flat(iv: Interval | None) -> tuple[np.ndarray, np.ndarray] | None:
        if iv is None:
            return None
        return np.broadcast_to(iv.lo, (m,)).copy(), np.broadcast_to(iv.hi, (m,)).copy()

    return flat(V), flat(Vd), F_hi, score, flat(margin)


def _join(parts: list[tuple[Any, ...]]) -> tuple[Any, ...]:
    def iv(k: int) -> Interval | None:
        if parts[0][k] is None:
            return None
        return Interval(np.concatenate([p[k][0] for p in parts]),
                        np.concatenate([p[k][1] for p in parts]))  # fmt: skip

    F = np.concatenate([p[2] for p in parts])
    score = np.concatenate([p[3] for p in parts])
    return iv(0), iv(1), F, score, iv(4)


class _Pool:
    """Forked workers for one ``(system, lyap, level, k)``, made on first use."""

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self.pool: Any = None
        self.key: Any = None

    def __call__(self, evaluate: Any, system: Any, lyap: Any, lo: np.ndarray, hi: np.ndarray,
                 level: float, k: int) -> tuple[Any, ...]:  # fmt: skip
        key = (id(evaluate), id(system), id(lyap), level, k)
        if key != self.key:  # the workers inherit the state at fork: a new one needs new workers
            self.close()
            _STATE.update(evaluate=evaluate, system=system, lyap=lyap, level=level, k=k)
            self.pool, self.key = mp.get_context("fork").Pool(self.workers), key
        if len(lo) < 2 * self.workers:
            return _join([_evaluate(lo, hi)])
        assert self.pool is not None
        cuts = np.array_split(np.arange(len(lo)), self.workers)
        jobs = [self.pool.apply_async(_evaluate, (lo[c], hi[c])) for c in cuts]
        return _join([j.get() for j in jobs])

    def close(self) -> None:
        if self.pool is not None:
            self.pool.terminate()
            self.pool.join()
        self.pool = self.key = None


_ACTIVE: contextvars.ContextVar[_Pool | None] = contextvars.ContextVar("box_pool", default=None)


@contextlib.contextmanager
def box_workers(workers: int) -> Iterator[None]:
    """Inside the block, :func:`evaluate_batch` spreads batches over ``workers`` forked processes
    (module doc); ``workers <= 1`` or no ``fork``: in the calling process."""
    if workers <= 1 or "fork" not in mp.get_all_start_methods() or mp.current_process().daemon:
        yield  # a daemonic process (e.g. a multiprocessing.Pool worker) may not have children
        return
    pool = _Pool(workers)
    token = _ACTIVE.set(pool)
    try:
        yield
    finally:
        _ACTIVE.reset(token)
        pool.close()
        _STATE.clear()


def evaluate_batch(evaluate: Any, system: Any, lyap: Any, lo: np.ndarray, hi: np.ndarray,
                   level: float, k: int) -> tuple[Any, ...]:  # fmt: skip
    """``evaluate`` (:func:`roa.proof.evaluate_boxes`, with ``skip_outside``) on the
    boxes, by the workers of the enclosing :func:`box_workers` block if any."""
    pool = _ACTIVE.get()
    if pool is None:
        return evaluate(system, lyap, lo, hi, level, k, skip_outside=True)
    return pool(evaluate, system, lyap, lo, hi, level, k)
