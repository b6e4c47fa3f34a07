"""The V-s iteration under a time budget (#25): progress lines with an estimate, and a clean stop
with the best round so far, status ``stopped``; ``certify --time-limit`` bounds it too.

The clock is a counter advanced 10 s by each SDP solve (``roa.search._vs_iteration._now``), so no
test depends on speed: round 0 solves gamma, beta, V (t = 10, 20, 30), round 1 gamma, beta, ...
"""

from __future__ import annotations

import pytest

import roa
import roa.search._vs_iteration as VS
from roa import progress
from roa.cli import main
from roa.status import SosStatus
from roa.systems.vanderpol import vanderpol


@pytest.fixture
def sdp_clock(monkeypatch):
    clock = [0.0]
    solve = VS.Program.solve

    def timed_solve(self, *args, **kw):
        clock[0] += 10.0
        return solve(self, *args, **kw)

    monkeypatch.setattr(VS, "_now", lambda: clock[0])
    monkeypatch.setattr(VS.Program, "solve", timed_solve)
    return clock


def test_budget_stops_with_the_rounds_done_and_says_so(sdp_clock, capsys):
    system = vanderpol()
    progress.enable(True)
    try:
        res = VS.vs_search(system, roa.default_lyapunov(system), degree=4, rounds=6, budget=45.0)
    finally:
        progress.enable(False)
    # round 1 starts at t = 30 < 45 (progress line), its beta step ends at t = 50 > 45: stop
    assert res.status is SosStatus.STOPPED
    assert len(res.candidates) == 2 and res.best is not None
    assert "time budget of 45.0 s spent in round 1: kept 2 candidates" in res.message
    err = capsys.readouterr().err
    # 1 round in 30 s: the 6 left would take 180 s, capped by the budget's 15 s left
    assert "V-s: 1 of at most 7 rounds in 30 s" in err
    assert "about 15 s more at this pace, budget 45 s (stops there with the best round)" in err


def test_a_budget_spent_in_round_0_keeps_its_candidate(sdp_clock):
    system = vanderpol()
    res = VS.vs_search(system, roa.default_lyapunov(system), degree=4, rounds=6, budget=15.0)
    # round 0: gamma at t = 10, beta at 20 (> 15): the candidate of round 0 is kept
    assert res.status is SosStatus.STOPPED and len(res.candidates) == 1


def test_certify_time_limit_bounds_the_vs_iteration(sdp_clock, capsys):
    argv = ["certify", "--system", "vanderpol", "--degree", "4", "--time-limit", "25", "--json"]
    main(argv)
    import json

    out = json.loads(capsys.readouterr().out)
    vs = out["vs_search"]
    assert vs["status"] == "stopped" and "time budget of 25.0 s" in vs["message"]


def test_a_budget_spent_while_building_gives_the_solver_a_positive_limit(monkeypatch):
    """The budget can run out between the check before a step and its solve (building a program
    in 10 states takes seconds): the solver then gets 1e-3 s, never a negative limit (SCS refuses
    one with a ValueError)."""
    clock = [0.0]
    seen = []

    def spy(self, *args, **kw):  # a solver stopped at its limit, on any machine
        seen.append(kw["options"]["time_limit"])
        clock[0] += 10.0
        self.solver, self.status = "clarabel", "user_limit"
        return False, None, None

    monkeypatch.setattr(VS, "_now", lambda: clock[0])
    monkeypatch.setattr(VS.Program, "solve", spy)
    real_decrease = VS._Problem.decrease

    def slow_decrease(self, *args, **kw):  # building the gamma step passes the budget
        clock[0] += 100.0
        return real_decrease(self, *args, **kw)

    monkeypatch.setattr(VS._Problem, "decrease", slow_decrease)
    system = vanderpol()
    res = VS.vs_search(system, roa.default_lyapunov(system), degree=4, rounds=2, budget=50.0)
    assert seen and seen[0] == 1e-3
    assert (
        res.status is SosStatus.FAILED and "time budget of 50.0 s spent in round 0" in res.message
    )
    assert len(seen) == 1 and "gamma step: user_limit" in res.message
