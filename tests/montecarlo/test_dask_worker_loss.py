"""A Dask worker that dies mid-run (reliability issue, finding 3 and Deliver 3): the client used to
wait silently for ever; now the run ends with a :class:`roa.errors.SolverError` once the cluster
has had no worker for ``scheduler_timeout`` seconds, the completed chunks are kept, and the run
resumes from them to the result of a local run.

The worker is a real ``dask worker`` process (no nanny, so nothing restarts it), killed with
SIGKILL once the first chunk file is written. A watchdog fails the test instead of hanging.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from roa.errors import SolverError
from roa.montecarlo._engine import run_basin
from roa.montecarlo._sampling import grid_slice
from roa.status import StopRules
from roa.systems.vanderpol import vanderpol

ROOT = Path(__file__).resolve().parents[2]
SYSTEM = vanderpol()
RULES = StopRules(t_final=5.0)

pytest.importorskip("distributed")


def _start_worker(address: str, tmp_path) -> subprocess.Popen:
    """One dask worker process (no nanny: a SIGKILL ends it for good) joining ``address``."""
    env = {**os.environ,
           "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}  # fmt: skip
    return subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_worker", address, "--no-nanny", "--nthreads",
         "1", "--no-dashboard", "--local-directory", str(tmp_path / "worker")],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip


@pytest.mark.slow
def test_a_killed_worker_ends_the_run_within_a_bounded_time_and_it_resumes(tmp_path):
    from dask.distributed import LocalCluster

    smp = grid_slice(SYSTEM, ("x1", "x2"), [(-3, 3), (-3, 3)], (40, 40))
    out = tmp_path / "run"
    with LocalCluster(n_workers=0, processes=False, protocol="tcp://", host="127.0.0.1",
                      dashboard_address=None) as cluster:  # fmt: skip
        worker = _start_worker(cluster.scheduler_address, tmp_path)
        t0 = time.monotonic()  # a loaded machine starts the worker slowly: wait until it joined
        while not cluster.scheduler.workers and time.monotonic() - t0 < 120:
            time.sleep(0.1)
        assert cluster.scheduler.workers, "the dask worker did not join within 120 s"
        killed = threading.Event()

        def kill_after_first_chunk() -> None:
            t0 = time.monotonic()
            while time.monotonic() - t0 < 120 and worker.poll() is None:
                if list((out / "chunks").glob("chunk_*.npz")):
                    worker.send_signal(signal.SIGKILL)
                    killed.set()
                    return
                time.sleep(0.05)

        watcher = threading.Thread(target=kill_after_first_chunk, daemon=True)
        watcher.start()
        try:
            with pytest.raises(SolverError, match="no Dask worker for 2 s") as info:
                run_basin(SYSTEM, smp, rules=RULES, chunk_size=100, out_dir=out,
                          scheduler=cluster.scheduler_address, scheduler_timeout=2.0)  # fmt: skip
        finally:
            if worker.poll() is None:
                worker.kill()
            worker.wait(30)
            watcher.join(5)
    assert killed.is_set(), "the worker finished before it could be killed: enlarge the grid"
    assert "completed chunks are kept" in str(info.value)
    kept = len(list((out / "chunks").glob("chunk_*.npz")))
    assert 1 <= kept < 16
    resumed = run_basin(SYSTEM, smp, rules=RULES, chunk_size=100, out_dir=out, n_jobs=1)
    assert resumed.chunks_resumed == kept and resumed.chunks_computed == 16 - kept
    local = run_basin(SYSTEM, smp, rules=RULES, chunk_size=1600, n_jobs=1)  # same statuses
    np.testing.assert_array_equal(resumed.code, local.code)


@pytest.mark.slow
def test_a_result_lost_with_its_worker_before_it_was_gathered_ends_the_wait(tmp_path):
    """Issue 39, item 4 (every worker killed: the client hung, 5/5 runs): a task had finished
    but its result still sat on the worker when the worker died; ``Future.result()`` then waits
    for ever (the client reschedules the task, no worker takes it). The gather now waits in
    slices and ends with the SolverError of a cluster without workers."""
    from dask.distributed import Client, LocalCluster

    from roa.montecarlo._dask_client import POLL, _result, _Watch

    with LocalCluster(n_workers=0, processes=False, protocol="tcp://", host="127.0.0.1",
                      dashboard_address=None) as cluster:  # fmt: skip
        worker = _start_worker(cluster.scheduler_address, tmp_path)
        client = Client(cluster.scheduler_address, set_as_default=False)
        try:
            client.wait_for_workers(1, timeout=120)
            fut = client.submit(pow, 3.0, 2, pure=False)  # a builtin: no module to import
            t0 = time.monotonic()
            while fut.status != "finished" and time.monotonic() - t0 < 60:
                time.sleep(0.05)
            assert fut.status == "finished"
            worker.send_signal(signal.SIGKILL)
            worker.wait(30)
            t0 = time.monotonic()
            while cluster.scheduler.workers and time.monotonic() - t0 < 30:
                time.sleep(0.05)
            assert not cluster.scheduler.workers
            box: dict[str, BaseException] = {}

            def gather() -> None:
                try:
                    _result(fut, _Watch(client, 2.0, "local"), 0)
                except BaseException as exc:  # noqa: BLE001 - inspected below
                    box["error"] = exc

            t0 = time.monotonic()
            th = threading.Thread(target=gather, daemon=True)
            th.start()
            th.join(30)  # a watchdog: the gather used to wait for ever
            elapsed = time.monotonic() - t0
            assert not th.is_alive(), "the gather of a lost result did not end within 30 s"
            assert isinstance(box.get("error"), SolverError), box
            assert "no Dask worker for 2 s" in str(box["error"])
            assert elapsed < 2.0 + 3 * POLL + 5.0
        finally:
            if worker.poll() is None:
                worker.kill()
            client.close(timeout=5)
