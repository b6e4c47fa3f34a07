"""A wall-clock budget for ``roa basin`` (reliability issue, Deliver 3: ``--time-limit`` with a clean
``inconclusive``): the run stops between chunks (inside a chunk between kernel slices or field
evaluations), keeps only completed chunks, is resumed from them, and says what was not run.

The clock is replaced by a counter (``roa.integration._budget.now``), so no test depends on speed.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

import roa
import roa.io
from roa.cli import main
from roa.errors import RoaInputError
from roa.integration import _budget as budget
from roa.montecarlo._engine import NOT_RUN, run_basin
from roa.montecarlo._sampling import grid_slice
from roa.status import StopRules
from roa.systems.vanderpol import vanderpol

SYSTEM = vanderpol()
RULES = StopRules(t_final=20.0)


@pytest.fixture
def ticking_clock(monkeypatch):
    """A clock that advances one second at every reading."""
    t = [0.0]

    def now() -> float:
        t[0] += 1.0
        return t[0]

    monkeypatch.setattr(budget, "now", now)
    return t


@pytest.fixture
def chunk_clock(monkeypatch):
    """A clock that advances one second at the start of every chunk (and not otherwise)."""
    from roa.montecarlo import _engine as engine

    t = [0.0]
    original = engine._chunk

    def chunk(*args, **kw):
        t[0] += 1.0
        return original(*args, **kw)

    monkeypatch.setattr(budget, "now", lambda: t[0])
    monkeypatch.setattr(engine, "_chunk", chunk)
    return t


def _grid():
    return grid_slice(SYSTEM, ("x1", "x2"), [(-3, 3), (-3, 3)], (20, 20))


def test_a_run_cut_by_its_budget_keeps_whole_chunks_and_resumes_to_the_full_result(
    tmp_path, chunk_clock
):
    smp = _grid()
    full = run_basin(SYSTEM, smp, rules=RULES, n_jobs=1, chunk_size=50)
    chunk_clock[0] = 0.0
    cut = run_basin(SYSTEM, smp, rules=RULES, n_jobs=1, chunk_size=50, out_dir=tmp_path,
                    time_limit=3.5)  # fmt: skip
    assert cut.chunks_computed == 3  # chunks started at 1, 2, 3 s; the 4th at 4 s is not run
    not_run = cut.meta["not_run"]
    assert not_run == 400 - 50 * cut.chunks_computed
    assert cut.counts()["not_run"] == not_run and sum(cut.counts().values()) == 400
    assert np.count_nonzero(cut.code == NOT_RUN) == not_run
    done = cut.code != NOT_RUN
    np.testing.assert_array_equal(cut.code[done], full.code[done])  # a budget changes no status
    saved = sorted(p.name for p in (tmp_path / "chunks").glob("chunk_*.npz"))
    assert len(saved) == cut.chunks_computed
    again = run_basin(SYSTEM, smp, rules=RULES, n_jobs=1, chunk_size=50, out_dir=tmp_path)
    assert again.chunks_resumed == cut.chunks_computed and "not_run" not in again.meta
    np.testing.assert_array_equal(again.code, full.code)
    assert again.counts() == full.counts()


def test_a_chunk_cut_inside_the_numpy_integrator_is_discarded(tmp_path, ticking_clock):
    smp = _grid()
    res = run_basin(SYSTEM, smp, rules=RULES, n_jobs=1, chunk_size=400, backend="numpy",
                    out_dir=tmp_path, time_limit=30.0)  # fmt: skip
    assert res.chunks_computed == 0 and res.meta["not_run"] == 400
    assert not list((tmp_path / "chunks").glob("chunk_*"))  # nothing half-written
    assert not list((tmp_path / "chunks").glob("*.tmp"))  # nor a temporary file


def test_the_numba_kernel_stops_between_slices_and_slicing_changes_nothing(ticking_clock):
    from roa.integration import _integrator as I  # noqa: N812

    ipc = roa.load_system("ipc")
    x0 = np.zeros((3 * budget.SLICE + 5, 4))
    x0[:, 2] = np.linspace(-0.6, 0.6, x0.shape[0])
    whole = I.integrate_batch(ipc, x0, backend="numba")
    sliced = I.integrate_batch(ipc, x0, backend="numba", deadline=1e18)
    np.testing.assert_array_equal(whole.code, sliced.code)
    np.testing.assert_array_equal(whole.t_end, sliced.t_end)
    np.testing.assert_array_equal(whole.x_end, sliced.x_end)
    ticking_clock[0] = 0.0
    with pytest.raises(budget.BudgetExhausted):  # readings 1, 2 pass; 3 >= 2.5 stops slice 3
        I.integrate_batch(ipc, x0, backend="numba", deadline=2.5)
    assert ticking_clock[0] == 3.0


def test_the_api_reports_an_inconclusive_basin(chunk_clock):
    res = roa.basin(SYSTEM, _grid(), rules=RULES,
                    run=roa.RunOptions(n_jobs=1, chunk_size=50, time_limit=2.5))  # fmt: skip
    assert res.status is roa.BasinStatus.INCONCLUSIVE
    assert res.fraction_converged is None and 0 < res.counts["not_run"] < 400
    lo, hi = res.ci95
    k, m = res.counts["converged"], res.counts["not_run"]
    assert lo <= k / 400 and (k + m) / 400 <= hi
    out = json.loads(roa.io.to_json(res.to_dict()))
    assert out["status"] == "inconclusive" and out["fraction_converged"] is None


@pytest.mark.parametrize("value", [0, -1.0, float("nan"), float("inf"), 1e10, True, "1"])
def test_a_bad_time_limit_is_an_input_error(value):
    with pytest.raises(RoaInputError, match="time_limit"):
        roa.RunOptions(time_limit=value)
    with pytest.raises(RoaInputError, match="time_limit"):
        run_basin(SYSTEM, _grid(), rules=RULES, n_jobs=1, time_limit=value)


def test_roa_basin_time_limit_ends_inconclusive_without_a_plot(tmp_path, capsys):
    """A field that sleeps (Python, numpy integrator) would hold the run for minutes: the real
    budget of 0.3 s ends it, exit 1, with the JSON saying inconclusive and no plot written."""
    src = tmp_path / "slow.py"
    src.write_text(
        "import time\nfrom roa import System\n"
        "def field(t, x, xp):\n"
        "    if getattr(xp, 'name', '') == 'numpy' and getattr(x[0], 'size', 1) > 1:\n"
        "        time.sleep(0.05)\n"
        "    return (-x[1], x[0] + (x[0] ** 2 - 1) * x[1])\n"
        "SYSTEM = System(name='slow', field=field, equilibrium=(0.0, 0.0), state_names=('x1', 'x2'))\n"
    )
    png, out = tmp_path / "map.png", tmp_path / "run"
    argv = ["basin", "--system", f"{src}:SYSTEM", "--slice", "x1,x2", "--grid", "4x4", "--jobs",
            "1", "--chunk-size", "4", "--plot", str(png), "--out", str(out), "--json"]  # fmt: skip
    assert main([*argv, "--time-limit", "0.3"]) == 1
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    assert data["status"] == "inconclusive" and data["counts"]["not_run"] >= 4
    assert "wall-clock budget" in captured.err and "resume" in captured.err
    assert not png.exists()
    assert json.loads((out / "summary.json").read_text())["status"] == "inconclusive"
    for bad in ("-1", "nan", "inf", "0"):
        try:  # nan and inf are outside the number grammar: argparse's usage error
            code = main([*argv[:-1], "--time-limit", bad])
        except SystemExit as exc:
            code = exc.code
        assert code == 2
        err = capsys.readouterr().err
        assert "--time-limit" in err and "Traceback" not in err
        assert ("(0, 1e+09]" in err) or (f"'{bad}' is not a number" in err)
    assert os.listdir(out)  # the run's folder was kept for resuming
