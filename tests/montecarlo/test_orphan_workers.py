"""Worker processes exit with their parent (reliability issue, finding 5 and Deliver 4): after the
``roa basin`` process is killed with SIGKILL, its loky workers used to linger 4-5 minutes (loky's
default idle timeout); they now exit after :data:`roa.montecarlo._engine.IDLE_WORKERS` seconds
without work. Slow (it waits for that timeout), so in ``pytest -m slow``.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from roa.montecarlo._engine import IDLE_WORKERS

psutil = pytest.importorskip("psutil")
ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_loky_workers_exit_after_their_parent_is_killed(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    code = "import sys; from roa.cli import main; sys.exit(main())"
    argv = [sys.executable, "-c", code, "basin", "--system", "vanderpol", "--samples", "200000",
            "--box", "x1=-3:3,x2=-3:3", "--jobs", "2", "--chunk-size", "500",
            "--out", str(tmp_path / "run")]  # fmt: skip
    parent = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        workers: list = []
        t0 = time.monotonic()
        while time.monotonic() - t0 < 120 and not workers:  # wait until chunks are being written
            if list((tmp_path / "run" / "chunks").glob("chunk_*.npz")):
                workers = psutil.Process(parent.pid).children(recursive=True)
            time.sleep(0.2)
        assert workers, "no worker process started"
    finally:
        parent.send_signal(signal.SIGKILL)
        parent.wait(30)
    gone, alive = psutil.wait_procs(workers, timeout=IDLE_WORKERS + 60)
    for p in alive:
        p.kill()
    assert not alive, f"{len(alive)} worker(s) outlived their parent by {IDLE_WORKERS + 60} s"
