"""Connecting to a Dask scheduler with bounded waits, and closing the client quietly."""

from __future__ import annotations

import threading
import warnings
from typing import Any

from roa.errors import RoaInputError, SolverError


def _probe_scheduler(address: str, timeout: float) -> None:
    """Open and close one connection to ``address`` within ``timeout`` seconds (handshake included).

    ``distributed.Client`` does not bound the handshake: a port that accepts and never answers would
    hang it forever. The probe runs in its own thread and event loop, so it also works from a caller
    that already runs an event loop.
    """
    import asyncio

    from distributed.comm import connect

    async def probe() -> None:
        # connect() retries refused connections until ``timeout`` but never bounds the handshake
        comm = await asyncio.wait_for(connect(address, timeout=timeout), timeout + 1.0)
        await comm.close()

    box: dict[str, BaseException] = {}

    def target() -> None:
        try:
            asyncio.run(probe())
        except BaseException as exc:  # noqa: BLE001 - reported to the caller
            box["error"] = exc

    th = threading.Thread(target=target, name="roa-scheduler-probe", daemon=True)
    th.start()
    th.join(timeout + 5.0)
    exc = box.get("error")
    if th.is_alive() or isinstance(exc, asyncio.TimeoutError | TimeoutError):
        raise SolverError(
            f"scheduler {address}: no answer from a Dask scheduler within {timeout + 1:g} s (the "
            "address accepts connections but does not speak the Dask protocol, or is overloaded); "
            "check the address and that `dask scheduler` runs there"
        )
    if isinstance(exc, ValueError):
        raise RoaInputError(
            f"scheduler: {address!r} is not a Dask scheduler address (e.g. tcp://host:8786): {exc}"
        )
    if exc is not None:
        raise SolverError(
            f"scheduler {address}: cannot connect to a Dask scheduler within {timeout:g} s "
            f"({type(exc).__name__}: {exc}); check the address and that `dask scheduler` runs there"
        )


def connect(address: str, timeout: float) -> Any:
    """A Dask client of ``address`` with at least one worker, or a roa error within ~2 x timeout."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise SolverError(
            f"scheduler {address}: dask.distributed is not installed (pip install 'dask[distributed]')"
        ) from None

    _probe_scheduler(address, timeout)
    try:
        client = Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise SolverError(
            f"scheduler {address}: cannot connect to a Dask scheduler within {timeout:g} s "
            f"({type(exc).__name__}: {exc})"
        ) from None
    try:
        client.wait_for_workers(1, timeout=timeout)
    except BaseException as exc:
        close_quietly(client)
        if isinstance(exc, KeyboardInterrupt):
            raise
        raise SolverError(
            f"scheduler {address}: no worker joined within {timeout:g} s; start workers with "
            f"`dask worker {address}` (or give another scheduler)"
        ) from None
    return client


def close_quietly(client: Any, results: Any = None) -> None:
    """Stop pending tasks and close a Dask client without tracebacks or log noise."""
    import logging

    names = ("distributed", "tornado", "asyncio")
    saved = {name: logging.getLogger(name).level for name in names}
    for name in names:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    try:
        if results is not None:
            try:
                with warnings.catch_warnings():  # joblib warns about the tasks it cancels
                    warnings.simplefilter("ignore")
                    results.close()  # joblib cancels the futures it still holds
            except BaseException:  # noqa: BLE001, S110 - closing on the way out
                pass
        try:
            client.close(timeout=5)
        except BaseException:  # noqa: BLE001, S110
            pass
    finally:
        for name, level in saved.items():
            logging.getLogger(name).setLevel(level)


#: Seconds between two looks at the cluster while waiting for results.
POLL = 0.5


class _Watch:
    """The cluster's workers, looked at between waits: :meth:`check` raises a
    :class:`roa.errors.SolverError` once there has been no worker (or no reachable scheduler) for
    ``timeout`` seconds."""

    def __init__(self, client: Any, timeout: float, address: str) -> None:
        self.client, self.timeout, self.address = client, timeout, address
        self.lost_since: float | None = None

    def ok(self) -> None:
        self.lost_since = None

    def check(self, pending: int) -> None:
        import time

        try:
            workers = len(self.client.nthreads(callback_timeout=self.timeout))
        except Exception:  # noqa: BLE001 - an unreachable scheduler counts as no worker
            workers = 0
        if workers:
            self.lost_since = None
            return
        now = time.monotonic()
        self.lost_since = now if self.lost_since is None else self.lost_since
        if now - self.lost_since > self.timeout:
            raise SolverError(
                f"scheduler {self.address}: no Dask worker for {self.timeout:g} s "
                f"with {pending} task(s) pending (the workers died or left); start workers "
                "with `dask worker ADDRESS`"
            )


def _result(fut: Any, watch: _Watch, pending: int) -> Any:
    """``fut``'s result, gathered in waits of :data:`POLL` seconds: a finished task whose worker
    died before its result was gathered is rescheduled by the client, and waits for a worker
    like a pending one (the watch ends the wait when none is left)."""
    from distributed import KilledWorker

    while True:
        try:
            return fut.result(timeout=POLL)
        except KilledWorker as exc:
            raise SolverError(
                f"scheduler {watch.address}: a task killed the workers that ran it ({exc})"
            ) from None
        except TimeoutError:
            watch.check(pending + 1)


def run_tasks(
    client: Any, fn: Any, tasks: Any, timeout: float, *, address: str = "?", window: int = 64
) -> Any:
    """Run ``fn(*args)`` on the cluster for each ``args`` of ``tasks``; yield results as they finish.

    Claims: at most ``window`` tasks are pending at once (``tasks`` is consumed lazily); a task
    lost with its worker is re-run by the scheduler on another worker (the scheduler's policy); a
    cluster that has had no worker (or no reachable scheduler) for ``timeout`` seconds, or a task
    that killed its workers, ends the run with a :class:`roa.errors.SolverError` within about
    ``timeout + POLL`` seconds, never a silent wait: also while a finished task's result is
    gathered (its worker may die in between). Pending futures are released on the way out
    (closing the client, :func:`close_quietly`, cancels them). The client's own log lines about
    lost results are kept off stderr while this runs.
    """
    import logging

    from distributed import wait

    pending: set[Any] = set()
    it = iter(tasks)
    more = True
    watch = _Watch(client, timeout, address)
    log = logging.getLogger("distributed.client")
    level = log.level
    log.setLevel(logging.ERROR)  # "Couldn't gather 1 keys, rescheduling": handled below
    try:
        while True:
            while more and len(pending) < window:
                try:
                    args = next(it)
                except StopIteration:
                    more = False
                    break
                pending.add(client.submit(fn, *args, pure=False))
            if not pending:
                return
            try:
                with client.as_current():  # wait() looks for the default client
                    done, not_done = wait(pending, timeout=POLL, return_when="FIRST_COMPLETED")
                pending = set(not_done)
            except TimeoutError:
                done = set()
            for fut in done:
                yield _result(fut, watch, len(pending))
            if done:
                watch.ok()
                continue
            watch.check(len(pending))
    finally:
        log.setLevel(level)
        # pending futures are released with this generator; the caller closes the client
        # (close_quietly, bounded), which cancels whatever still runs: no unbounded call here
        pending.clear()
