"""The Monte Carlo basin engine: chunks of initial conditions, in parallel, resumable, streamed.

Initial conditions come from a sampler (:mod:`roa.montecarlo.sampling`) whose rows depend only on
their index, and each trajectory is integrated on its own (:mod:`roa.montecarlo.integrator`), so the
result for a given seed does not depend on the number of workers or the chunk size. Only statuses and
stop times are kept (1 + 4 bytes per initial condition), never trajectories.

With ``out_dir``, every completed chunk is written atomically to ``out_dir/chunks/`` next to a
``run.json`` fingerprint of the run; a run interrupted (Ctrl-C or killed) is resumed from its completed
chunks, and a directory holding a different run is refused. ``scheduler`` runs the chunks on a Dask
cluster through joblib's dask backend.
"""

from __future__ import annotations

import hashlib
import io
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from roa.io import atomic_write_bytes, atomic_write_json, code_hash, to_json
from roa.montecarlo import integrator as I  # noqa: N812
from roa.status import StopRules
from roa.system import System

DEFAULT_CHUNK = 4096
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


@dataclass
class BasinRun:
    """Statuses of ``n`` initial conditions (codes of :mod:`roa.montecarlo.integrator`)."""

    code: np.ndarray
    t_end: np.ndarray
    chunks_computed: int = 0
    chunks_resumed: int = 0
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def n(self) -> int:
        return int(self.code.size)

    def counts(self) -> dict[str, int]:
        """Count per status (step-size failures are undecided, also counted on their own)."""
        b = np.bincount(self.code.astype(np.int64), minlength=5)
        return {
            "converged": int(b[I.CONVERGED]),
            "left_domain": int(b[I.LEFT_DOMAIN]),
            "diverged": int(b[I.DIVERGED]),
            "undecided": int(b[I.UNDECIDED] + b[I.STEP_FAILURE]),
        }

    def summary(self) -> dict[str, Any]:
        counts = self.counts()
        k = counts["converged"]
        lo, hi = wilson_interval(k, self.n)
        return {
            "n": self.n,
            "counts": counts,
            "undecided_step_size_failures": int(np.sum(self.code == I.STEP_FAILURE)),
            "fraction_converged": k / self.n if self.n else None,
            "fraction_converged_ci95": [lo, hi],
            "ci_method": "Wilson score, 95 %",
            "chunks_computed": self.chunks_computed,
            "chunks_resumed": self.chunks_resumed,
            **self.meta,
        }


def _chunk(
    system: System, sampler: Any, start: int, stop: int, opts: dict[str, Any]
) -> tuple[int, np.ndarray, np.ndarray]:
    x0 = sampler.points(start, stop)
    res = I.integrate_batch(system, x0, **opts)
    return start, res.code, res.t_end.astype(np.float32)


def _fingerprint(system: System, sampler: Any, opts: dict[str, Any], chunk: int) -> str:
    meta = {k: v for k, v in system.meta.items() if not callable(v)}
    blob = to_json(
        {
            "system": system.name,
            "meta": {k: repr(v) for k, v in meta.items()},
            "sampler": {k: np.asarray(v).tolist() if isinstance(v, np.ndarray) else v
                        for k, v in sampler.fingerprint().items()},
            "opts": {k: repr(v) for k, v in opts.items()},
            "chunk": chunk,
            "code": code_hash(),  # chunks of other code are never resumed
        }
    )  # fmt: skip
    return hashlib.sha256(blob.encode()).hexdigest()


def _chunk_path(d: Path, start: int) -> Path:
    return d / f"chunk_{start:012d}.npz"


def _save_chunk(path: Path, code: np.ndarray, t_end: np.ndarray) -> None:
    buf = io.BytesIO()
    np.savez(buf, code=code, t_end=t_end)
    atomic_write_bytes(path, buf.getvalue())


def run_basin(
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
    _stop_after: int | None = None,
) -> BasinRun:
    """Integrate every initial condition of ``sampler`` and return their statuses.

    Parameters
    ----------
    system : System
        Autonomous system with an equilibrium.
    sampler : GridSlice, BoxSample, RegionSample or any object with ``n``, ``points(a, b)``, ``fingerprint()``
        The initial conditions.
    rules, rtol, atol, margin_tol, backend
        Passed to :func:`roa.montecarlo.integrator.integrate_batch`.
    chunk_size : int
        Initial conditions per task (does not change the result).
    n_jobs : int
        joblib workers (default -1: all cores; does not change the result).
    out_dir : path, optional
        Directory for resumable chunk files (``out_dir/chunks``).
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:port``); runs the chunks there.
    progress : bool, optional
        tqdm progress bar; default on for runs of more than 50 chunks.
    replace_stale : bool
        If ``out_dir`` holds chunks of a different run (other inputs or code), delete them instead
        of raising ``ValueError``.
    """
    rules = StopRules() if rules is None else rules
    I.check_tolerances(rtol, atol, margin_tol)
    if int(chunk_size) < 1:
        raise ValueError(f"chunk_size must be >= 1, got {chunk_size}")
    if n_jobs == 0 or n_jobs < -1:
        raise ValueError(f"--jobs must be >= 1 or -1 (all cores), got {n_jobs}")
    opts = {
        "rules": rules,
        "rtol": rtol,
        "atol": atol,
        "margin_tol": margin_tol,
        "backend": backend,
    }
    n = int(sampler.n)
    starts = list(range(0, n, int(chunk_size)))
    code = np.full(n, -1, np.int8)
    t_end = np.full(n, np.nan, np.float32)
    chunk_dir = None
    resumed = 0
    if out_dir is not None:
        chunk_dir = Path(out_dir) / "chunks"
        digest = _fingerprint(system, sampler, opts, int(chunk_size))
        run_file = chunk_dir / "run.json"
        if run_file.is_file():
            old = json.loads(run_file.read_text()).get("fingerprint")
            if old != digest and replace_stale:
                for stale in chunk_dir.glob("chunk_*.npz"):
                    stale.unlink()
                atomic_write_json(
                    run_file, {"fingerprint": digest, "n": n, "chunk_size": int(chunk_size)}
                )
            elif old != digest:
                raise ValueError(
                    f"{chunk_dir} holds chunks of a different run (other system, samples, tolerances "
                    "or chunk size); use another --out directory or delete it"
                )
        else:
            atomic_write_json(
                run_file, {"fingerprint": digest, "n": n, "chunk_size": int(chunk_size)}
            )
        todo = []
        for s in starts:
            p = _chunk_path(chunk_dir, s)
            if p.is_file():
                with np.load(p) as z:
                    c, te = z["code"], z["t_end"]
                if c.size == min(s + chunk_size, n) - s:
                    code[s : s + c.size], t_end[s : s + c.size] = c, te
                    resumed += 1
                    continue
            todo.append(s)
    else:
        todo = starts
    if progress is None:
        progress = len(todo) > 50
    computed = 0
    if todo:
        import joblib

        tasks = (
            joblib.delayed(_chunk)(system, sampler, s, min(s + chunk_size, n), opts) for s in todo
        )
        if scheduler is not None:
            from dask.distributed import Client

            try:
                client = Client(scheduler, timeout=15)
            except (OSError, TimeoutError) as exc:
                raise ValueError(
                    f"--scheduler {scheduler}: cannot connect to a Dask scheduler ({exc})"
                ) from exc
            ctx = joblib.parallel_config(backend="dask", n_jobs=-1, wait_for_workers_timeout=60)
        else:
            client = None
            # small runs stay in-process (worker start-up costs seconds); results are the same
            jobs = 1 if n_jobs == -1 and len(todo) * chunk_size < SMALL_RUN else n_jobs
            ctx = joblib.parallel_config(n_jobs=jobs)
        try:
            with ctx:
                results = joblib.Parallel(return_as="generator_unordered")(tasks)
                bar = None
                if progress:
                    from tqdm import tqdm

                    bar = tqdm(total=len(todo), unit="chunk", desc=f"basin {system.name}")
                for s, c, te in results:
                    code[s : s + c.size], t_end[s : s + c.size] = c, te
                    if chunk_dir is not None:
                        _save_chunk(_chunk_path(chunk_dir, s), c, te)
                    computed += 1
                    if bar is not None:
                        bar.update(1)
                    if _stop_after is not None and computed >= _stop_after:
                        raise KeyboardInterrupt("stopped on request (test hook)")
                if bar is not None:
                    bar.close()
        finally:
            if client is not None:
                client.close()
    assert (code >= 0).all()
    return BasinRun(code, t_end, chunks_computed=computed, chunks_resumed=resumed)
