"""The benchmarks run, at small sizes, and their own checks hold (they exit non-zero otherwise):

* bench_rk_interface.py: the array-interface and the scalar Runge-Kutta loops take the same steps
  and end on the same bits;
* bench_entry_steps.py: scipy's solve_ivp (RK45) enters the certified degree-4 set at the same
  accepted step as the engine, run for run;
* bench_montecarlo.py: the engine's statuses, plain and with each terminal set, equal the
  solve_ivp baseline's;
* bench_scale.py (two rungs of its ladder): each level certified at >= 0.99 x the optimum found
  independently (multistart SLSQP), below a point refuting it (V' >= 0 at 50 digits, V at most
  1.001 x the optimum), and the branch and bound agrees on the same level;
* bench_robust.py --quick: no robust level above the independent worst case, Van der Pol's within
  1 % of it (the same target is in the fast suite, tests/certification/test_robust.py).
Their speed figures are for an idle machine and are not asserted. All five are slow (15-40 s
each, numba compilation included): ``pytest -m slow``; the default run covers the engine against
solve_ivp in ipc_paper/tests/test_montecarlo.py.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "benchmarks"


def _run(script: str, *args: str) -> str:
    out = subprocess.run([sys.executable, str(BENCH / script), *args], cwd=BENCH,
                         capture_output=True, text=True, timeout=600)  # fmt: skip
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    return out.stdout


@pytest.mark.slow
def test_rk_interface_loops_agree_bit_for_bit():
    out = _run("bench_rk_interface.py", "--n", "30", "--t-final", "1")
    assert "scalars / arrays" in out


@pytest.mark.slow
def test_entry_steps_match_the_engine():
    out = _run("bench_entry_steps.py", "--n", "200", "--outside", "25")
    assert "certified V4 <= c" in out and "not certified" in out


@pytest.mark.slow
def test_montecarlo_statuses_agree_with_solve_ivp():
    out = _run("bench_montecarlo.py", "--n", "40", "--n-engine", "400")
    assert out.count("40/40") >= 3  # plain and both terminal sets


@pytest.mark.slow
def test_scale_ladder_quick_rungs_hold():
    out = _run("bench_scale.py", "--only", "vanderpol", "poly3d")
    assert "all ladder checks hold" in out
    assert out.count("certified, ") == 2  # the branch and bound's column, one per rung


@pytest.mark.slow
def test_robust_benchmark_checks_hold():
    """bench_robust.py --quick: no robust level above the independent worst case, Van der Pol's
    within 1 %, the naive grid's minimum of the poly case (vertices only) refuted for the box."""
    out = _run("bench_robust.py", "--quick")
    lines = [ln for ln in out.splitlines() if ln.startswith(("vdp", "poly"))]
    assert len(lines) == 2 and "FAILED" not in out
    assert lines[1].split()[-1] == "refuted"


@pytest.mark.slow
def test_peer_benchmark_statuses_agree_with_diffrax():
    if importlib.util.find_spec("diffrax") is None or importlib.util.find_spec("jax") is None:
        pytest.skip("jax and diffrax (the optional extra 'bench') are not installed")
    out = _run("bench_peers.py", "--n", "400", "--reps", "1", "--systems", "vdp",
               "--setups", "vmap")  # fmt: skip
    assert "peer vdp vmap" in out and "statuses=400/400" in out


@pytest.mark.slow
def test_discrete_benchmark_certifies_refutes_and_matches_the_numpy_iteration():
    """bench_discrete.py: each map certified at 0.99 x its independent optimum (closed form,
    SLSQP), refuted at 1.01 x, and roa.basin's statuses equal to a plain numpy iteration."""
    out = _run("bench_discrete.py", "--samples", "2000")
    assert (
        "all checks passed" in out and out.count("statuses equal to the numpy baseline: True") == 2
    )
