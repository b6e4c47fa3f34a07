"""Every batch run does bounded work (issue 39, item 4): a run ends as a step failure (undecided,
reported apart) after ``MAX_STEPS`` accepted steps or ``MAX_TINY_STEPS`` steps shorter than
``TINY_STEP_FRACTION * t_final``. A field of scale 1e150 (``basin --param mu=1e150``) asked for
steps of ~1e-150 and never reached ``t_final``; a blow-up, which also takes tiny steps before its
escape time, still reaches ``diverge_bound``.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

import roa
from roa.integration import _dopri as dopri
from roa.integration._integrator import integrate_batch
from roa.status import StopRules
from roa.systems.vanderpol import vanderpol

GRID = np.array([[a, b] for a in np.linspace(-1, 1, 4) for b in np.linspace(-1, 1, 4)])


def _basin(*argv: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-W", "ignore", "-c",
                           "import sys; from roa.cli import main; sys.exit(main(sys.argv[1:]))",
                           "basin", *argv], capture_output=True, text=True,
                          timeout=timeout)  # fmt: skip


def test_basin_with_the_largest_parameter_ends_every_run_undecided_in_bounded_time():
    """mu = 1e150 (the largest value --param allows, roa.model._system.MAX_PARAM): every run is an
    undecided step failure, the JSON counts them, and the command ends (it ran until killed)."""
    out = _basin("--system", "vanderpol", "--param", "mu=1e150", "--slice", "x1,x2", "--grid",
                 "4x4", "--box", "x1=-1:1,x2=-1:1", "--t-final", "20", "--jobs", "1",
                 "--json")  # fmt: skip
    assert out.returncode == 0, out.stderr[-2000:]
    assert "Traceback" not in out.stderr
    res = json.loads(out.stdout)
    assert res["counts"]["undecided"] == 16 and res["undecided_step_size_failures"] == 16
    assert res["counts"]["converged"] == res["counts"]["diverged"] == 0


def test_tiny_steps_end_the_run_as_a_step_failure_on_the_numpy_backend():
    res = integrate_batch(vanderpol(1e150), GRID, rules=StopRules(t_final=20.0), backend="numpy")
    assert set(res.code.tolist()) == {dopri.STEP_FAILURE}
    assert np.all(res.t_end < dopri.MAX_TINY_STEPS * dopri.TINY_STEP_FRACTION * 20.0)
    assert np.all(res.steps <= dopri.MAX_TINY_STEPS)


def test_the_step_cap_ends_long_runs_and_changes_no_run_that_ended_before_it(monkeypatch):
    """With the cap lowered to the median step count of uncapped runs (the numpy backend reads
    it at run time), runs that stopped within the cap keep their status and time; the others end
    as step failures after exactly the cap, earlier than uncapped."""
    X = np.random.default_rng(3).uniform(-3, 3, (60, 2))
    rules = StopRules(t_final=30.0)
    free = integrate_batch(vanderpol(), X, rules=rules, backend="numpy")
    cap = int(np.median(free.steps))
    monkeypatch.setattr(dopri, "MAX_STEPS", cap)
    capped = integrate_batch(vanderpol(), X, rules=rules, backend="numpy")
    short = free.steps <= cap
    assert 0 < short.sum() < X.shape[0]  # both kinds of run are exercised
    np.testing.assert_array_equal(capped.code[short], free.code[short])
    np.testing.assert_array_equal(capped.t_end[short], free.t_end[short])
    assert np.all(capped.code[~short] == dopri.STEP_FAILURE)
    assert np.all(capped.steps[~short] == cap)
    assert np.all(capped.t_end[~short] < free.t_end[~short])


def test_a_blow_up_through_tiny_steps_is_still_diverged():
    """x' = x^3 from x0 blows up at 1 / (2 x0^2); x(t) = x0 / sqrt(1 - 2 x0^2 t) reaches the
    bound B = 1e6 at t = (1 - x0^2 / B^2) / (2 x0^2). Its last steps are far below
    TINY_STEP_FRACTION * t_final (the step near x is ~ x^-2), yet it is diverged at that time."""

    def field(t, x, xp):
        return (x[0] ** 3,)

    s = roa.System("cubic", field, (0.0,), ("x",))
    x0 = np.array([[0.5], [-2.0], [3.0]])
    res = integrate_batch(s, x0, rules=StopRules(t_final=60.0), backend="numpy")
    assert res.code.tolist() == [dopri.DIVERGED] * 3
    expected = [(1 - v * v / 1e12) / (2 * v * v) for v in x0[:, 0]]
    np.testing.assert_allclose(res.t_end, expected, rtol=1e-6)
    assert math.isfinite(res.steps.max()) and res.steps.max() < dopri.MAX_STEPS


@pytest.mark.slow
def test_tiny_steps_end_the_run_on_the_numba_kernel():
    """The generated numba kernel (integrator._one) has the same budget: every run a step
    failure, after MAX_TINY_STEPS tiny steps or at t = 0 (compiles the kernel: slow)."""
    res = integrate_batch(vanderpol(1e150), GRID, rules=StopRules(t_final=20.0), backend="numba")
    assert set(res.code.tolist()) == {dopri.STEP_FAILURE}
    assert np.all(res.steps <= dopri.MAX_TINY_STEPS)
