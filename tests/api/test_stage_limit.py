"""``--time-limit`` bounds every long step (issue 38, item 5): a step without a budget of its
own (the SOS program's assembly and solve, a level search, tracing a field) is stopped at the
limit with exit 1 and a message naming the step; and a python-control loop too large to trace is
refused at load time (it traced for minutes: sympy rebuilds a sum at each ``+``)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from roa.errors import TimeLimitReached
from roa.stage_limit import guard, limit

#: A polynomial field of 400 terms up to degree 40: it loads at once, its SOS program takes
#: minutes to assemble.
POLY400 = """from roa import System
C = [((k * 7919) % 1000 - 500) * 1e-7 for k in range(400)]
def field(t, x, xp):
    s = 0.0
    for k in range(400):
        s = s + C[k] * x[0] ** (k % 20 + 2) * x[1] ** (k // 20)
    return (-x[0] + s, -x[1])
SYSTEM = System(name="poly400", field=field, equilibrium=(0.0, 0.0), state_names=("a", "b"))
"""


@pytest.mark.slow
def test_certify_stops_the_sos_program_at_the_time_limit(tmp_path):
    path = tmp_path / "poly400.py"
    path.write_text(POLY400)
    t0 = time.monotonic()
    out = subprocess.run([sys.executable, "-W", "ignore", "-c",
                          "import sys; from roa.cli import main; sys.exit(main(sys.argv[1:]))",
                          "certify", "--system", f"{path}:SYSTEM", "--time-limit", "4"],
                         capture_output=True, text=True, timeout=300)  # fmt: skip
    assert out.returncode == 1, out.stderr[-2000:]
    assert "Traceback" not in out.stderr
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith("roa certify: stopped: the time limit of 4 s ran out during the step")
    assert time.monotonic() - t0 < 150  # without the limit: minutes in the SOS program


def test_a_step_is_stopped_at_the_limit_and_one_with_its_own_budget_is_not():
    limit(0.3)
    try:
        t0 = time.monotonic()
        with pytest.raises(TimeLimitReached, match="'spin'"), guard("spin"):
            while time.monotonic() - t0 < 10:
                pass
        assert time.monotonic() - t0 < 2
        t0 = time.monotonic()
        with guard("outer"), guard("validation", own_budget=True):  # the timer paused
            while time.monotonic() - t0 < 0.6:
                pass
    finally:
        limit(None)
    with guard("no limit set"):
        time.sleep(0.01)


def test_a_callers_alarm_survives_a_limited_step():
    """A test's watchdog (an alarm armed before the step) still fires, through its own handler."""
    fired = []
    old = signal.signal(signal.SIGALRM, lambda s, f: fired.append(time.monotonic()))
    signal.setitimer(signal.ITIMER_REAL, 0.5)
    limit(5.0)
    try:
        t0 = time.monotonic()
        with guard("long"):
            while not fired and time.monotonic() - t0 < 3:
                pass
        assert fired and fired[0] - t0 < 1.5  # the caller's alarm, not TimeLimitReached
    finally:
        limit(None)
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def test_from_control_refuses_a_loop_too_large_to_trace_in_bounded_time():
    """10^4 terms in an updfcn: refused naming the bound (it traced for minutes)."""
    control = pytest.importorskip("control")
    import roa

    rng = np.random.default_rng(0)
    C, ii, jj = (
        rng.uniform(-1e-3, 1e-3, 10**4),
        rng.integers(2, 40, 10**4),
        rng.integers(2, 40, 10**4),
    )

    def upd(t, x, u, params):  # noqa: ANN001
        s = 0
        for c, i, j in zip(C, ii, jj, strict=True):
            s = s + c * x[0] ** int(i) * x[1] ** int(j)
        return np.array([-x[0] + s + u[0], -x[1]])

    plant = control.nlsys(upd, None, inputs=1, outputs=2, states=2)
    t0 = time.monotonic()
    with pytest.raises(roa.RoaInputError, match="more than 20000 operations.*100000 terms"):
        roa.System.from_control(plant, K=np.zeros((1, 2)), equilibrium=(0.0, 0.0))
    assert time.monotonic() - t0 < 60
