"""The Monte Carlo basin engine: chunks of initial conditions, in parallel, resumable, streamed.

Initial conditions come from a sampler (:mod:`roa.montecarlo._sampling`) whose rows depend only on
their index, and each trajectory is integrated on its own (:mod:`roa.integration._integrator`), so the
result for a given seed does not depend on the number of workers or the chunk size. Only statuses and
stop times are kept (1 + 4 bytes per initial condition), never trajectories.

With ``out_dir``, every completed chunk is written atomically to ``out_dir/chunks/`` next to a
``run.json`` fingerprint of the run. Each chunk file carries its own binding: the run fingerprint,
its start index, its length and a SHA-256 of its arrays. On resume a chunk is used only if that
binding matches this run and its contents; any other chunk (rewritten, truncated or corrupt, of
another run, with unknown status codes) is deleted, recomputed and counted (``chunks_rejected`` in
the run's ``meta``, and a :class:`ChunkRejectedWarning`). A directory holding a different run is
refused (:class:`roa.errors.ResultsError`) unless ``fresh=True`` (recompute everything) or
``replace_stale=True``. ``scheduler`` runs the chunks on a Dask cluster as futures
(:func:`roa.montecarlo._dask_client.run_tasks`), with bounded waits for the scheduler and its
workers: a cluster left without workers ends the run with an error, its completed chunks kept.
``time_limit`` bounds the run's wall-clock time (:mod:`roa.integration._budget`).

Bounds, checked before any allocation: at most :data:`roa.montecarlo.MAX_SAMPLES`
initial conditions (and at most half of the physical memory for their statuses), ``chunk_size`` in
``[1, MAX_CHUNK]``, ``n_jobs`` -1 or in ``[1, 4 x cores]``; the workers actually started never
exceed the number of chunks to compute. Chunk start indices are generated lazily.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from roa.errors import ResultsError, RoaInputError, SolverError
from roa.integration import (
    _budget as budget,
    _integrator as I,  # noqa: N812
)
from roa.integration._terminal import TerminalSet
from roa.io import code_hash, to_json
from roa.model._system import System
from roa.montecarlo._chunks import (  # noqa: F401  (re-exported)
    CHUNK_FORMAT,
    VALID_CODES,
    ChunkRejectedWarning,
    chunk_digest,
    chunk_path,
    prepare_out_dir,
    save_chunk,
)
from roa.montecarlo._dask_client import close_quietly, connect, run_tasks
from roa.montecarlo._sampling import MAX_SAMPLES
from roa.status import StopRules

DEFAULT_CHUNK = 4096
#: Largest chunk (initial conditions per task).
MAX_CHUNK = 1_000_000
#: Seconds to wait for a Dask scheduler to answer, and for its first worker.
SCHEDULER_TIMEOUT = 10.0
#: Bytes kept per initial condition (int8 status, float32 stop time).
BYTES_PER_SAMPLE = 5
#: Status codes a chunk may hold.
#: With the default n_jobs=-1, runs with fewer initial conditions than this stay in one process.
SMALL_RUN = 12000
Z95 = 1.959963984540054


def wilson_interval(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion ``k / n`` (95 % by default)."""
    if n <= 0:
        return (0.0, 1.0)
    p = k / n
    den = 1 + z * z / n
    center = (p + z * z / (2 * n)) / den
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return (max(0.0, center - half), min(1.0, center + half))


def converged_interval(k: int, not_run: int, n: int) -> tuple[float, float]:
    """95 % interval of the converged fraction of ``n`` runs, ``k`` converged and ``not_run`` not
    run (cut by the budget): Wilson's lower bound with none of them converging and upper bound
    with all of them converging (conservative; Wilson's interval when every run was run)."""
    lo, _ = wilson_interval(k, n)
    _, hi = wilson_interval(k + not_run, n)
    return lo, hi


#: Status code of an initial condition that was not run (the wall-clock budget ran out first).
NOT_RUN = -1


@dataclass
class BasinRun:
    """Statuses of ``n`` initial conditions (codes of :mod:`roa.integration._integrator`)."""

    code: np.ndarray
    t_end: np.ndarray
    chunks_computed: int = 0
    chunks_resumed: int = 0
    meta: dict[str, Any] = field(default_factory=dict)
    #: Converged runs finished by the terminal set (counted as converged in :meth:`counts`).
    entered_certified_set: int = 0

    @property
    def n(self) -> int:
        return int(self.code.size)

    def counts(self) -> dict[str, int]:
        """Count per status (step-size failures are undecided, also counted on their own).

        Raises :class:`roa.errors.ResultsError` if a code is not a known status: the counts always
        sum to ``n``.
        """
        code = np.asarray(self.code)
        b = {v: int(np.count_nonzero(code == v)) for v in VALID_CODES}  # no int64 copy of code
        not_run = int(self.meta.get("not_run", 0))  # the budget ran out first (code NOT_RUN)
        if not_run and int(np.count_nonzero(code == NOT_RUN)) != not_run:
            raise ResultsError(f"internal error: {not_run} runs recorded as not run, not the "
                               f"{int(np.count_nonzero(code == NOT_RUN))} without a status")  # fmt: skip
        if sum(b.values()) + not_run != self.n:
            bad = np.unique(code[~np.isin(code, VALID_CODES)])
            raise ResultsError(
                f"{self.n - sum(b.values())} of {self.n} initial conditions have an unknown status "
                f"code {[int(v) for v in bad[:5]]} (known: {list(VALID_CODES)}); the counts would "
                "not sum to n"
            )
        counts = {
            "converged": int(b[I.CONVERGED]),
            "left_domain": int(b[I.LEFT_DOMAIN]),
            "diverged": int(b[I.DIVERGED]),
            "undecided": int(b[I.UNDECIDED] + b[I.STEP_FAILURE]),
            "converged_elsewhere": int(b[I.CONVERGED_ELSEWHERE]),
        }
        if not_run:
            counts["not_run"] = not_run
        assert sum(counts.values()) == self.n, f"status counts {counts} do not sum to n = {self.n}"
        return counts

    def summary(self) -> dict[str, Any]:
        counts = self.counts()
        k = counts["converged"]
        lo, hi = converged_interval(k, counts.get("not_run", 0), self.n)
        return {
            "n": self.n,
            "counts": counts,
            "undecided_step_size_failures": int(np.sum(self.code == I.STEP_FAILURE)),
            "fraction_converged": k / self.n if self.n and "not_run" not in counts else None,
            "fraction_converged_ci95": [lo, hi],
            "ci_method": "Wilson score, 95 %",
            "chunks_computed": self.chunks_computed,
            "chunks_resumed": self.chunks_resumed,
            "entered_certified_set": self.entered_certified_set,
            **self.meta,
        }


def _chunk(system: System, sampler: Any, start: int, stop: int, opts: dict[str, Any],
           deadline: float | None = None) -> tuple[int, np.ndarray | None, np.ndarray | None, int]:  # fmt: skip
    """Statuses, stop times and terminal-set entries of rows ``start:stop``; ``None`` arrays when
    the budget ``deadline`` ran out before or during the chunk (nothing of it is kept)."""
    try:
        budget.check(deadline)
        x0 = sampler.points(start, stop)
        res = I.integrate_batch(system, x0, deadline=deadline, **opts)
    except budget.BudgetExhausted:
        return start, None, None, 0
    entered = getattr(res, "entered", None)
    n_in = 0 if entered is None else int(np.count_nonzero(entered))
    return start, res.code, res.t_end.astype(np.float32), n_in


def _fingerprint(system: System, sampler: Any, opts: dict[str, Any], chunk: int) -> str:
    meta = {k: v for k, v in system.meta.items() if not callable(v)}
    blob = to_json(
        {
            "system": system.name,
            "meta": {k: repr(v) for k, v in meta.items()},
            # the parameter values integrated (other values: another run, never resumed)
            **({"params": {k: float(v).hex() for k, v in system.params.items()}}
               if system.params else {}),
            "sampler": {k: np.asarray(v).tolist() if isinstance(v, np.ndarray) else v
                        for k, v in sampler.fingerprint().items()},
            "opts": {k: repr(v) for k, v in opts.items()},
            "chunk": chunk,
            "chunk_format": CHUNK_FORMAT,
            "code": code_hash(),  # chunks of other code are never resumed
        }
    )  # fmt: skip
    return hashlib.sha256(blob.encode()).hexdigest()


def _check_jobs(n_jobs: Any) -> int:
    cores = os.cpu_count() or 1
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, int | np.integer):
        raise RoaInputError(f"n_jobs must be an integer (-1 for all cores), got {n_jobs!r}")
    n_jobs = int(n_jobs)
    if n_jobs == 0 or n_jobs < -1:
        raise RoaInputError(f"n_jobs must be >= 1 or -1 (all cores), got {n_jobs}")
    if n_jobs > 4 * cores:
        raise RoaInputError(
            f"n_jobs must be at most 4 x the {cores} cores of this machine ({4 * cores}), got "
            f"{n_jobs}; use a Dask scheduler for more workers"
        )
    return n_jobs


def _check_size(n: int) -> None:
    if n < 0 or n > MAX_SAMPLES:
        raise RoaInputError(
            f"sampler.n (the number of initial conditions) must be in [0, {MAX_SAMPLES:.0e}], "
            f"got {n}; split the run into several"
        )
    try:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return
    need = BYTES_PER_SAMPLE * n
    if memory > 0 and need > memory // 2:
        raise RoaInputError(
            f"sampler.n = {n} initial conditions need {need / 2**30:.1f} GiB for their statuses, "
            f"more than half of this machine's {memory / 2**30:.1f} GiB; split the run into several"
        )


def _pending(n: int, chunk_size: int, done: set[int]) -> Iterator[int]:
    """Starts of the chunks still to compute, generated lazily (never a list of all of them)."""
    return (s for s in range(0, n, chunk_size) if s not in done)


#: Largest wall-clock budget of a run (seconds; about 31 years).
MAX_TIME_LIMIT = 1e9
#: Seconds an idle worker process waits for work before it exits.
IDLE_WORKERS = 30


def kept(chunk_dir: Path | None, computed: int, resumed: int) -> str:
    """What a basin run that stops early leaves behind, for its message."""
    if chunk_dir is None:
        return "nothing was kept (no --out: the completed chunks were not saved)"
    if computed == 0 and resumed == 0:
        return f"nothing was kept (no chunk completed; {chunk_dir} holds none)"
    return (f"completed chunks are kept in {chunk_dir} ({computed} computed by this run, "
            f"{resumed} resumed; run the same command with the same --out to resume)")  # fmt: skip


def run_basin(system: System, sampler: Any, *, out_dir: str | Path | None = None,
              **kw: Any) -> BasinRun:  # fmt: skip
    """Integrate every initial condition of ``sampler`` (see :func:`_run_basin` for the
    parameters); with ``out_dir`` the folder is locked for the run (one run per folder)."""
    if out_dir is None:
        return _run_basin(system, sampler, **kw)
    from roa.io import folder_lock

    with folder_lock(Path(out_dir) / "chunks", "out_dir"):
        return _run_basin(system, sampler, out_dir=out_dir, **kw)


def _run_basin(
    system: System,
    sampler: Any,
    *,
    rules: StopRules | None = None,
    rtol: float = 1e-6,
    atol: float = 1e-9,
    margin_tol: float = 0.0,
    backend: str = "auto",
    chunk_size: int = DEFAULT_CHUNK,
    n_jobs: int = -1,
    out_dir: str | Path | None = None,
    scheduler: str | None = None,
    progress: bool | None = None,
    replace_stale: bool = False,
    fresh: bool = False,
    scheduler_timeout: float = SCHEDULER_TIMEOUT,
    terminal: TerminalSet | None = None,
    time_limit: float | None = None,
    _stop_after: int | None = None,
) -> BasinRun:
    """Integrate every initial condition of ``sampler`` and return their statuses.

    Parameters
    ----------
    system : System
        Autonomous system with an equilibrium.
    sampler : GridSlice, BoxSample, RegionSample or any object with ``n``, ``points(a, b)``, ``fingerprint()``
        The initial conditions (at most :data:`roa.montecarlo.MAX_SAMPLES`).
    rules, rtol, atol, margin_tol, backend
        Passed to :func:`roa.integration._integrator.integrate_batch`.
    chunk_size : int
        Initial conditions per task, in ``[1, MAX_CHUNK]`` (does not change the result).
    n_jobs : int
        joblib workers: -1 (all cores) or ``1 .. 4 x cores``; never more workers than chunks to
        compute (does not change the result).
    out_dir : path, optional
        Directory for resumable chunk files (``out_dir/chunks``). Each chunk is bound to the run
        (fingerprint, start, length, SHA-256 of its arrays); on resume chunks whose binding or
        contents do not match are deleted and recomputed (``meta["chunks_rejected"]``).
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:port``); runs the chunks there.
    progress : bool, optional
        tqdm progress bar on a terminal (never in logs); default on for runs of more than 50
        chunks.
    replace_stale : bool
        If ``out_dir`` holds chunks of a different run (other inputs or code), delete them instead
        of raising :class:`roa.errors.ResultsError`.
    fresh : bool
        Ignore and delete every existing chunk of ``out_dir`` and recompute all of them.
    scheduler_timeout : float
        Seconds to wait for the scheduler to answer and again for its first worker; then a
        :class:`roa.errors.SolverError` says what is wrong.
    terminal : TerminalSet, optional
        A certified set of the closed loop: runs entering it stop as converged (counted in
        ``entered_certified_set``; :mod:`roa.integration._terminal`). Part of the run fingerprint.
    time_limit : float, optional
        Wall-clock budget in seconds (:mod:`roa.integration._budget`). When it runs out, no new
        chunk starts, a chunk under way is discarded, the completed ones are kept (and saved with
        ``out_dir``, so the same call resumes from them), and the initial conditions without a
        status get :data:`NOT_RUN` (``meta["not_run"]``, ``counts()["not_run"]``). Not part of
        the fingerprint: it never changes a status.
    """
    rules = StopRules() if rules is None else rules
    I.check_tolerances(rtol, atol, margin_tol)
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int | np.integer):
        raise RoaInputError(f"chunk_size must be an integer, got {chunk_size!r}")
    chunk_size = int(chunk_size)
    if not 1 <= chunk_size <= MAX_CHUNK:
        raise RoaInputError(f"chunk_size must be in [1, {MAX_CHUNK}], got {chunk_size}")
    n_jobs = _check_jobs(n_jobs)
    if scheduler is not None:
        if not isinstance(scheduler, str) or not scheduler.strip():
            raise RoaInputError(f"scheduler must be an address tcp://host:port, got {scheduler!r}")
        ok = isinstance(scheduler_timeout, int | float) and not isinstance(scheduler_timeout, bool)
        if not (ok and math.isfinite(scheduler_timeout) and scheduler_timeout > 0):
            raise RoaInputError(
                f"scheduler_timeout must be a finite number of seconds > 0, got {scheduler_timeout!r}"
            )
    opts = {
        "rules": rules,
        "rtol": rtol,
        "atol": atol,
        "margin_tol": margin_tol,
        "backend": backend,
    }
    if terminal is not None:
        if not isinstance(terminal, TerminalSet):
            raise RoaInputError(f"terminal must be a TerminalSet, got {type(terminal).__name__}")
        terminal.bind(system)  # checked before any work
        opts["terminal"] = terminal  # its repr is exact: part of the fingerprint
    if time_limit is not None:
        ok = isinstance(time_limit, int | float) and not isinstance(time_limit, bool)
        if not (ok and math.isfinite(time_limit) and 0 < time_limit <= MAX_TIME_LIMIT):
            raise RoaInputError(
                f"time_limit must be a number of seconds in (0, {MAX_TIME_LIMIT:.0e}], "
                f"got {time_limit!r}"
            )
    deadline = budget.deadline_of(time_limit)
    n = int(sampler.n)
    _check_size(n)
    # the backend is chosen (and a generated kernel compiled) once, here: workers load it
    from roa.integration._kernel_cache import compiled_system

    system, ran, note = compiled_system(system, backend, terminal, n)
    if ran == "numpy":
        opts = {**opts, "backend": "numpy"}  # the workers do not choose again
    warm = getattr(system.numba_fast, "kernel", None)
    if n and warm is not None:
        warm()  # compiled here (a progress line while it compiles); the workers load it
    n_chunks = -(-n // chunk_size)
    code = np.full(n, -1, np.int8)
    t_end = np.full(n, np.nan, np.float32)
    chunk_dir = None
    digest = ""
    done: set[int] = set()
    rejected: dict[str, int] = {}
    entered = [0]
    if out_dir is not None:
        digest = _fingerprint(system, sampler, {**opts, "ran": ran}, chunk_size)
        chunk_dir, done, rejected = prepare_out_dir(
            out_dir, digest, n, chunk_size, code, t_end, fresh=fresh, replace_stale=replace_stale,
            entered=entered,
        )  # fmt: skip
    n_todo = n_chunks - len(done)
    if progress is None:
        progress = n_todo > 50
    computed = 0
    jobs = 0
    if n_todo:
        import joblib

        starts = (s for s in _pending(n, chunk_size, done) if not budget.expired(deadline))
        tasks = (
            joblib.delayed(_chunk)(system, sampler, s, min(s + chunk_size, n), opts, deadline)
            for s in starts
        )
        if scheduler is not None:
            client = connect(scheduler, float(scheduler_timeout))
            ctx = contextlib.nullcontext()
            jobs = -1
        else:
            client = None
            # small runs stay in-process (worker start-up costs seconds); results are the same
            jobs = (os.cpu_count() or 1) if n_jobs == -1 else n_jobs
            if n_jobs == -1 and n_todo * chunk_size < SMALL_RUN:
                jobs = 1
            jobs = max(1, min(jobs, n_todo))  # never more workers than tasks
            # idle workers exit after IDLE_WORKERS s: none outlive a killed parent for long
            ctx = joblib.parallel_config(backend="loky", n_jobs=jobs,
                                         idle_worker_timeout=IDLE_WORKERS)  # fmt: skip
        results = None
        bar = None
        try:
            with ctx:
                if client is not None:  # futures watched for lost workers (bounded waits)
                    args = ((system, sampler, s, min(s + chunk_size, n), opts, deadline)
                            for s in starts)  # fmt: skip
                    results = run_tasks(
                        client, _chunk, args, float(scheduler_timeout), address=str(scheduler)
                    )
                else:
                    results = joblib.Parallel(return_as="generator_unordered")(tasks)
                if progress:  # a bar on a terminal only: logs get no flood of bar updates
                    from roa.progress import bar as progress_bar

                    bar = progress_bar(n_todo, f"basin {system.name}", unit="chunk")
                for s, c, te, k in results:
                    if c is None or te is None:  # cut by the budget: the chunk is not run
                        continue
                    length = min(s + chunk_size, n) - s
                    if c.size != length or te.size != length:
                        raise ResultsError(
                            f"internal error: chunk at {s} returned {c.size} statuses, not {length}"
                        )
                    code[s : s + length], t_end[s : s + length] = c, te
                    if chunk_dir is not None:
                        save_chunk(chunk_path(chunk_dir, s), digest, s, c, te, k)
                    entered[0] += k
                    computed += 1
                    if bar is not None:
                        bar.update(1)
                    if _stop_after is not None and computed >= _stop_after:
                        raise KeyboardInterrupt("stopped on request (test hook)")
        except SolverError as exc:  # a lost cluster: say what this run kept
            raise SolverError(f"{exc}; {kept(chunk_dir, computed, len(done))}") from None
        except KeyboardInterrupt as exc:
            exc.add_note(kept(chunk_dir, computed, len(done)))
            raise
        finally:
            if bar is not None:
                bar.close()
            if client is not None:
                close_quietly(client, results)
    missing = int(np.count_nonzero(code < 0))
    if missing and deadline is None:
        raise ResultsError(f"internal error: {missing} of {n} initial conditions have no status")
    # n_jobs_used: local worker processes actually started (1: in-process), -1 on a Dask cluster
    meta: dict[str, Any] = {"chunks_rejected": int(sum(rejected.values())), "n_jobs_used": jobs,
                            "backend": ran}  # fmt: skip
    if note is not None:
        meta["backend_note"] = note
    if missing:
        meta["not_run"] = missing
        meta["time_limit"] = float(time_limit)  # type: ignore[arg-type]
    if rejected:
        meta["chunks_rejected_reasons"] = dict(rejected)
    return BasinRun(code, t_end, chunks_computed=computed, chunks_resumed=len(done), meta=meta,
                    entered_certified_set=entered[0])  # fmt: skip
