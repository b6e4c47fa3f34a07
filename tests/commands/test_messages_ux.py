"""Messages that say what to do (#25): each mistake of a new user exits 2 naming the input.

* a --box that leaves out a sampled state is an error naming it (it was silently eq +- 1);
* ``--grid -10x10`` reaches --grid's own check (allowed range), not argparse's "expected one
  argument"; a negative first component is a value for any option (``--x0 -0.5,0.5``);
* ``certify --help`` speaks of any V, ``basin --help`` has a description;
* a simulation plot claims no time unit unless the system declares one.
"""

from __future__ import annotations

import dataclasses

import pytest

from roa.cli import main
from roa.commands._common import join_negative_values

SLICE = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "4x4", "--jobs", "1"]


@pytest.mark.parametrize(
    ("argv", "missing"),
    [
        (SLICE + ["--box", "x1=-3:3"], "x2"),
        (["basin", "--system", "vanderpol", "--samples", "10", "--box", "x2=-3:3"], "x1"),
    ],
)
def test_box_leaving_out_a_state_names_it(capsys, argv, missing):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"--box gives no range for {missing}" in err and "x1, x2" in err


@pytest.mark.parametrize("grid", ["-10x10", "-3x-3", "-1e3x4"])
def test_negative_grid_reaches_the_grid_check(capsys, grid):
    argv = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", grid]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "expected one argument" not in err
    assert "--grid" in err and ">= 2" in err and repr(grid) in err


def test_negative_values_are_joined_to_their_option_only():
    assert join_negative_values(["--grid", "-10x10"]) == ["--grid=-10x10"]
    assert join_negative_values(["--x0", "-0.5,0.5"]) == ["--x0=-0.5,0.5"]
    assert join_negative_values(["--tol", "-1e-3"]) == ["--tol=-1e-3"]
    # argparse already takes these as values; flags and options are left alone
    assert join_negative_values(["--level", "-5"]) == ["--level", "-5"]
    assert join_negative_values(["--json", "--box", "x=-1:1"]) == ["--json", "--box", "x=-1:1"]
    assert join_negative_values(["-h"]) == ["-h"]


def test_simulate_accepts_a_negative_first_component(capsys):
    argv = ["simulate", "--system", "vanderpol", "--x0", "-0.5,0.5", "--json"]
    assert main(argv) == 0
    assert '"status": "converged"' in capsys.readouterr().out


def test_help_texts(capsys):
    with pytest.raises(SystemExit):
        main(["certify", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "quadratic Lyapunov candidate lies" not in out and "any V" in out
    with pytest.raises(SystemExit):
        main(["basin", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "Simulate many initial conditions" in out and "--box ranges every sampled state" in out


def test_simulate_plot_time_label():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import roa

    system = roa.load_system("vanderpol")
    ax = roa.simulate(system, [0.5, 0.5]).plot()
    assert ax.get_xlabel() == "time t"
    timed = dataclasses.replace(system, meta={"time_unit": "s"})
    ax2 = roa.simulate(timed, [0.5, 0.5]).plot()
    assert ax2.get_xlabel() == "time t [s]"
    plt.close("all")


def test_basin_plot_title_names_the_system_not_the_file(tmp_path, monkeypatch):
    import roa.plotting._basin as pb

    seen = {}
    monkeypatch.setattr(pb, "plot_slice", lambda *a, **kw: seen.update(kw))
    path = tmp_path / "mine.py"
    path.write_text(
        "from roa import System\n\n"
        "def field(t, x, xp):\n    return (-x[0], -x[1])\n\n"
        'SYSTEM = System(name="my-linear", field=field, equilibrium=(0.0, 0.0), '
        'state_names=("a", "b"))\n'
    )
    argv = ["basin", "--system", f"{path}:SYSTEM", "--slice", "a,b", "--grid", "3x3",
            "--jobs", "1", "--t-final", "5", "--plot", str(tmp_path / "m.png")]  # fmt: skip
    assert main(argv) == 0
    assert seen["title"] == "basin of my-linear"


def test_khalil_says_which_shape_it_used(capsys):
    base = ["khalil", "--system", "vanderpol", "--method", "sampled", "--directions", "64"]
    main(base)
    out = capsys.readouterr().out
    assert "shape ball" in out and "--shape level work on levels of V" in out
    main([*base, "--shape", "level"])
    assert "shape ball" not in capsys.readouterr().out


def test_sos_seconds_cover_the_whole_step(monkeypatch):
    """The SOS time printed by ``certify`` is the step's (stderr's "SOS program: ... s"), importing
    cvxpy included: a fake clock advanced by 10 whenever the program (:mod:`roa.search._sdp`)
    imports cvxpy shows up in ``seconds``, which span the whole step."""
    import builtins
    import sys

    import roa
    import roa.search._sos as S
    from roa.systems.vanderpol import vanderpol

    system = vanderpol()
    V = roa.default_lyapunov(system)
    clock = [0.0]
    real_import = builtins.__import__

    def fake_import(name, *args, **kw):
        if name == "cvxpy" and sys._getframe(1).f_globals.get("__name__") == "roa.search._sdp":
            clock[0] += 10.0
        return real_import(name, *args, **kw)

    monkeypatch.setattr(S.time, "perf_counter", lambda: clock[0])
    monkeypatch.setattr(builtins, "__import__", fake_import)
    res = S.sos_level(system, V)
    assert res.status.value == "solved" and res.seconds == clock[0] >= 10.0


def test_box_budget_message_says_how_far_and_what_next(capsys):
    """An exhausted box budget reports the share of the cover's volume decided and an estimate of
    the boxes needed; on Van der Pol near its largest level (2.30425, certified with 295 boxes
    since the branch and bound contracts each box to the part that can meet the level set) the
    estimate from 200 boxes is enough."""
    import re

    argv = ["certify", "--system", "vanderpol", "--level", "2.3042", "--validator", "interval"]
    assert main([*argv, "--max-boxes", "200"]) == 1
    out = " ".join(capsys.readouterr().out.split())
    m = re.search(r"box budget 200 exhausted .*; (0\.\d+) of the cover's volume decided; "
                  r"--max-boxes ~(\d+) would likely suffice", out)  # fmt: skip
    assert m, out
    assert 0 < float(m[1]) < 1 and 200 < int(m[2]) < 3000
    assert main([*argv, "--max-boxes", m[2], "--json"]) == 0
    assert '"status": "certified"' in capsys.readouterr().out


def test_khalil_names_the_system_not_the_file(tmp_path, capsys):
    path = tmp_path / "mine.py"
    path.write_text(
        "from roa import System\n\n"
        "def field(t, x, xp):\n    return (-x[0] + x[1] * x[1], -x[1])\n\n"
        'SYSTEM = System(name="my-system", field=field, equilibrium=(0.0, 0.0), '
        'state_names=("a", "b"))\n'
    )
    main(["khalil", "--system", f"{path}:SYSTEM", "--method", "sampled", "--directions", "64"])
    out = capsys.readouterr().out
    assert out.startswith("my-system: largest ball level") and str(path) not in out


def test_progress_of_a_cover_beyond_double_precision_says_so():
    """A cover whose volume overflows (level 1e308: widths ~1e154 in 3 states) gets depths in
    log space and no share of volume (not a share computed from inf / inf)."""
    import numpy as np

    from roa.proof._validate import _Progress

    lo, hi = np.full(3, -1e154), np.full(3, 1e154)
    p = _Progress(lo, hi)
    assert p.total == np.inf and np.isfinite(p.log_total)
    half = np.array([[-1e154, -1e154, -1e154]]), np.array([[0.0, 1e154, 1e154]])
    p.batch(*half, undecided=np.array([True]))
    assert p.depths == {1: [1, 1]}  # half the cover: depth 1, by log2 of the widths
    out = p.reach(*half, [], [], boxes=1)
    assert out["volume_decided"] is None
    assert "not representable" in out["message"]
