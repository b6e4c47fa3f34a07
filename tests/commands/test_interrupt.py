"""Ctrl-C ends a run with exit 130 and says what was kept (issue 37, item 5): a basin with
``--out`` keeps its completed chunks (and the same command resumes from them, saying how many it
reused), one without ``--out`` keeps nothing; an SDP interrupted inside SCS (which catches SIGINT
itself and reports a status cvxpy takes for a solver error) is an interruption, not a failed
program that the run goes on from."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from roa.shares import interval

ROOT = Path(__file__).resolve().parents[2]
CLI = "import sys; from roa.cli import main; sys.exit(main(sys.argv[1:]))"
#: 1500 samples (numpy backend: nothing to compile) in 60 chunks of 25: long enough to interrupt.
BASIN = ["basin", "--system", "vanderpol", "--box", "x1=-3:3,x2=-3:3", "--samples", "1500",
         "--chunk-size", "25", "--jobs", "1", "--t-final", "60", "--json"]  # fmt: skip


def _env() -> dict[str, str]:
    return {**os.environ,
            "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}  # fmt: skip


def _start(argv: list[str]) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-W", "ignore", "-c", CLI, *argv], env=_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip


def _interrupt(proc: subprocess.Popen[str], ready: object) -> tuple[int, str]:
    t0 = time.monotonic()
    while not ready() and proc.poll() is None and time.monotonic() - t0 < 120:  # type: ignore[operator]
        time.sleep(0.05)
    assert proc.poll() is None, "the run ended before it could be interrupted"
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    return proc.returncode, err


@pytest.mark.slow
def test_an_interrupted_basin_with_out_keeps_its_chunks_and_resumes_from_them(tmp_path):
    out = tmp_path / "run"
    code, err = _interrupt(_start([*BASIN, "--out", str(out)]),
                           lambda: len(list((out / "chunks").glob("chunk_*.npz"))) >= 2)  # fmt: skip
    assert code == 130, err
    assert "Traceback" not in err
    line = err.strip().splitlines()[-1]
    assert line.startswith("roa basin: interrupted; completed chunks are kept in"), line
    kept = len(list((out / "chunks").glob("chunk_*.npz")))
    assert f"{kept} computed by this run" in line and 2 <= kept < 60
    again = subprocess.run([sys.executable, "-W", "ignore", "-c", CLI, *BASIN, "--out", str(out)],
                           env=_env(), capture_output=True, text=True, timeout=600)  # fmt: skip
    assert again.returncode == 0, again.stderr[-2000:]
    assert f"roa basin: resumed {kept} completed chunk(s) from {out}, computed {60 - kept}" in (
        again.stderr
    )


@pytest.mark.slow
def test_an_interrupted_basin_without_out_says_nothing_was_kept():
    proc = _start(BASIN)
    t0 = time.monotonic()
    code, err = _interrupt(proc, lambda: time.monotonic() - t0 > 6)
    assert code == 130, err
    assert "Traceback" not in err
    assert "interrupted; nothing was kept" in err.strip().splitlines()[-1]


SDP = """
import sys
import numpy as np
import cvxpy as cp
from roa.search._sdp import interruptible_scs

n = 120
rng = np.random.default_rng(0)
X = cp.Variable((n, n), PSD=True)
cons = [cp.trace(rng.standard_normal((n, n)) @ X) == rng.standard_normal() for _ in range(40)]
prob = cp.Problem(cp.Minimize(cp.trace(X)), cons)
try:
    prob.solve(solver=interruptible_scs(), verbose=True, eps_abs=1e-14, eps_rel=1e-14,
               max_iters=10**8)
except KeyboardInterrupt as exc:
    print("KeyboardInterrupt:", exc, flush=True)
    sys.exit(130)
print("finished with status", prob.status, flush=True)
"""


@pytest.mark.skipif(shutil.which("stdbuf") is None, reason="needs coreutils' stdbuf to see SCS's "
                    "iteration lines as they are printed")  # fmt: skip
def test_sigint_inside_scs_is_an_interruption_not_a_solver_error():
    """SCS prints its iteration table (line-buffered through stdbuf); SIGINT is sent once the
    table started, i.e. inside SCS's own SIGINT handler. Before, cvxpy raised SolverError
    ("Solver 'SCS' failed") and the V-s iteration took it for an infeasible step and went on."""
    proc = subprocess.Popen(["stdbuf", "-oL", sys.executable, "-c", SDP], env=_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)  # fmt: skip
    lines: list[str] = []
    assert proc.stdout is not None
    t0 = time.monotonic()
    for line in proc.stdout:
        lines.append(line)
        if line.strip().startswith("0|") or time.monotonic() - t0 > 240:
            break
    assert any(ln.strip().startswith("0|") for ln in lines), "".join(lines[-20:])
    proc.send_signal(signal.SIGINT)
    rest, _ = proc.communicate(timeout=120)
    assert proc.returncode == 130, rest
    assert "KeyboardInterrupt: the SDP solver SCS was interrupted (SIGINT)" in rest


def test_confidence_intervals_print_outward_rounded():
    """The Wilson upper bound of an all-converged run is 1 up to rounding (0.9999999999999999):
    printed outward at 4 decimals it is 1.0000; a lower bound rounds down."""
    assert interval(0.99851, 0.9999999999999999, 4) == "0.9985-1.0000"
    assert interval(0.12345, 0.5, 4) == "0.1234-0.5000"
    assert interval(0.00012, 0.0042, 2, scale=100, unit=" %") == "0.01-0.42 %"
    lo, hi = 0.2, 0.7  # on the grid already (float noise does not move them a step outward)
    assert interval(lo, hi, 1) == "0.2-0.7"
