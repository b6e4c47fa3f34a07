"""Divergence by growth and --diverge-bound (#25): a blow-up at t_final is ``diverged``.

The cases are linear or logistic 1-D growths whose solutions are closed-form, so which rule of
:func:`roa.integration._divergence.blows_up` holds is derived, with margins far above the integrators' error.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import roa
from roa.cli import main
from roa.errors import RoaInputError

#: a' = 0.2 a: a(60) = a0 e^12 (1.63e5 a0), a(30) = a0 e^6, rate 0.2 throughout; b' = -b.
UNSTABLE = """from roa import System

def field(t, x, xp):
    return (0.2 * x[0], -x[1])

SYSTEM = System(name="unstable-linear", field=field, equilibrium=(0.0, 0.0), state_names=("a", "b"))
"""

#: logistic r' = 0.4 r (1 - r/5e4) from 1e-4: r(30) = 16.3, r(60) = 4.9e4 (levelled off: the
#: rate at the end 0.4 (1 - 0.98) = 0.0076, under half the mean rate ln(3000)/30 / 2 = 0.13).
LOGISTIC = """from roa import System

def field(t, x, xp):
    return (0.4 * x[0] * (1 - x[0] / 5e4),)

SYSTEM = System(name="logistic", field=field, equilibrium=(0.0,), state_names=("r",))
"""

#: polynomial growth r' = 4 sqrt(r) from 1: r(t) = (1 + 2t)^2, r(60) = 14641 >= 1e6/100, but
#: r(30) = 3721 (grown by 3.9, not by 100).
POLYNOMIAL = """from roa import System

def field(t, x, xp):
    return (4 * (x[0] * x[0]) ** 0.25,)

SYSTEM = System(name="polynomial", field=field, equilibrium=(0.0,), state_names=("r",))
"""


@pytest.fixture
def spec(tmp_path):
    def write(text: str) -> str:
        path = tmp_path / f"sys{abs(hash(text))}.py"
        path.write_text(text)
        return f"{path}:SYSTEM"

    return write


def test_exponential_blow_up_is_diverged(spec, capsys):
    assert main(["simulate", "--system", spec(UNSTABLE), "--x0", "1,1"]) == 1
    out = capsys.readouterr().out
    assert "status: diverged (diverged by growth" in out and "1.63e+05" in out
    # without the growth rule the same run is undecided at t_final
    assert (
        main(["simulate", "--system", spec(UNSTABLE), "--x0", "1,1", "--diverge-growth", "0"]) == 0
    )
    assert "status: undecided" in capsys.readouterr().out


def test_diverge_bound_is_reached(spec, capsys):
    # a(t) = e^{0.2 t} reaches 100 at t = 5 ln 100 = 23.03
    argv = ["simulate", "--system", spec(UNSTABLE), "--x0", "1,0", "--diverge-bound", "100"]
    assert main([*argv, "--json"]) == 1
    out = capsys.readouterr().out
    assert '"status": "diverged"' in out
    t_end = json.loads(out)["t_end"]
    assert t_end == pytest.approx(5 * math.log(100), rel=1e-6)


@pytest.mark.parametrize("text", [LOGISTIC, POLYNOMIAL])
def test_levelling_off_or_polynomial_growth_stays_undecided(spec, capsys, text):
    argv = ["simulate", "--system", spec(text), "--x0", "1e-4" if text is LOGISTIC else "1",
            "--converge-tol", "1e-5", "--json"]  # fmt: skip
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert '"status": "undecided"' in out
    r_end = json.loads(out)["final_state"][0]
    assert r_end == pytest.approx(4.9e4 if text is LOGISTIC else 14641, rel=0.01)


@pytest.mark.parametrize(
    ("flag", "value", "expected"),
    [
        ("--diverge-bound", "0", "--diverge-bound must be a finite number > 0"),
        ("--diverge-bound", "inf", "argument --diverge-bound: 'inf' is not a number"),
        ("--diverge-bound", "1e-4", "--diverge-bound (0.0001) must be larger than --converge-tol"),
        ("--diverge-growth", "1", "--diverge-growth must be a finite factor > 1, or 0"),
        ("--diverge-growth", "-5", "--diverge-growth must be a finite factor > 1, or 0"),
        ("--diverge-growth", "nan", "argument --diverge-growth: 'nan' is not a number"),
    ],
)
@pytest.mark.parametrize("command", ["simulate", "basin"])
def test_bad_divergence_flags_exit_2(capsys, command, flag, value, expected):
    tail = ["--x0", "0.5,0.5"] if command == "simulate" else ["--samples", "4", "--jobs", "1"]
    try:  # a value outside the number grammar is argparse's usage error (SystemExit 2)
        code = main([command, "--system", "vanderpol", *tail, flag, value])
    except SystemExit as exc:
        code = exc.code
    assert code == 2
    assert expected in capsys.readouterr().err


def test_stop_rules_checks_the_growth_factor():
    for bad in (1.0, 0.5, math.inf, True, "100"):
        with pytest.raises(RoaInputError, match="rules.diverge_growth must be a finite factor > 1"):
            roa.StopRules(diverge_growth=bad)
    assert roa.StopRules(diverge_growth=None).diverge_growth is None


def test_basin_counts_blow_ups_as_diverged(spec):
    """Grid a in {-0.1, -0.05, 0, 0.05, 0.1} x b in {-1, 0, 1}: a(60) = 1.63e5 a0, so |a0| = 0.1
    ends at 1.63e4 >= 1e6/100 (diverged by growth), |a0| = 0.05 at 8.1e3 < 1e4 (undecided), a0 = 0
    converges with b (b(60) = e^-60)."""
    from roa.montecarlo._sampling import grid_slice

    system = roa.load_system(spec(UNSTABLE))
    g = grid_slice(system, ["a", "b"], [(-0.1, 0.1), (-1.0, 1.0)], (5, 3))
    res = roa.basin(system, g, run=roa.RunOptions(n_jobs=1))
    assert res.counts["diverged"] == 6 and res.counts["undecided"] == 6
    assert res.counts["converged"] == 3
    off = roa.basin(system, g, rules=roa.StopRules(diverge_growth=None),
                    run=roa.RunOptions(n_jobs=1))  # fmt: skip
    assert off.counts["diverged"] == 0 and off.counts["undecided"] == 12
    assert res.to_dict()["diverge_growth"] == 100.0 and off.to_dict()["diverge_growth"] is None
    X = g.points(0, g.n)
    assert np.array_equal(np.asarray(res.code) == 2, np.abs(X[:, 0]) > 0.075)
