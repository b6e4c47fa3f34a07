"""Certified early exit: runs that enter a certified level set stop as converged (issue 14, item 1).

IPC: simulated in physical coordinates, the paper's V (3.11) certified at 2.2806 in flat
coordinates (roa certify; level 2.28 used here). Van der Pol: the benchmark P, certified level 2.30
(below the published 2.3045), on the numpy back end.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import roa
from ipc_paper import system as ipc
from roa.errors import RoaInputError
from roa.integration import _integrator as I  # noqa: N812
from roa.integration._terminal import REASON, TerminalSet
from roa.montecarlo._certified_set import terminal_from_certificate
from roa.montecarlo._engine import run_basin
from roa.montecarlo._sampling import box_sample, grid_slice
from roa.status import StopRules
from roa.systems.vanderpol import P_BENCHMARK, vanderpol

RULES = StopRules(t_final=30.0)
PAPER_LEVEL = 2.28  # certified: 2.2806 (results/certify/certified.json)


def _ipc_terminal() -> TerminalSet:
    return TerminalSet(ipc.transformed().lyapunov, np.zeros(4), PAPER_LEVEL, coords="flat")


def _certificate(**over) -> dict:
    cert = {"system": "ipc_flat", "lyapunov": "paper V", "P": np.asarray(ipc.transformed().lyapunov).tolist(),
            "level": PAPER_LEVEL, "status": "certified"}  # fmt: skip
    cert.update(over)
    return cert


def _agree(plain, term) -> int:
    """Statuses agree, except runs undecided at t_final that entered the certified set: they are
    converged (the certificate proves it); returns their number."""
    ent = term.entered
    changed = plain.code != term.code
    assert (plain.code[changed] == I.UNDECIDED).all() and ent[changed].all()
    assert (term.code[changed] == I.CONVERGED).all()
    assert not (ent & (plain.code != I.CONVERGED) & ~changed).any()
    # runs that enter stop no later, and with no more steps; the others are unchanged
    assert (term.t_end[ent] <= plain.t_end[ent]).all()
    assert (term.steps <= plain.steps).all()
    np.testing.assert_array_equal(term.t_end[~ent], plain.t_end[~ent])
    return int(changed.sum())


@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_ipc_statuses_agree_with_and_without_terminal_set(backend):
    system = ipc.closed_loop()
    grid = grid_slice(system, ("theta", "theta_dot"), [(-1.55, 1.55), (-10, 10)], (20, 15),
                      fixed={"q": 0.5, "q_dot": -0.5})  # fmt: skip
    X = grid.points(0, grid.n)
    if backend == "numpy":
        X = X[::3]
    plain = I.integrate_batch(system, X, rules=RULES, backend=backend)
    term = I.integrate_batch(system, X, rules=RULES, backend=backend, terminal=_ipc_terminal())
    # near |theta| = pi/2 with large theta' some runs are still on their way at T = 30
    # (undecided); they enter the certified set, which proves convergence
    changed = _agree(plain, term)
    assert term.entered.sum() > X.shape[0] // 5
    assert set(plain.code.tolist()) == {I.CONVERGED, I.UNDECIDED} and 0 < changed
    inner = np.abs(X[:, 3]) <= 6  # there every run converges by T = 30: identical statuses
    np.testing.assert_array_equal(plain.code[inner], term.code[inner])
    assert term.steps.sum() < 0.7 * plain.steps.sum()
    reasons = term.reasons()
    assert reasons.count(REASON) == term.entered.sum()
    # entry states are inside the set (with the margin); the stored x_end is the entry state
    flat = ipc.to_flat(term.x_end[term.entered])
    P = ipc.transformed().lyapunov
    assert (np.einsum("ri,ij,rj->r", flat, P, flat) <= PAPER_LEVEL).all()


def test_ipc_numba_and_numpy_agree_on_entries():
    system = ipc.closed_loop()
    X = box_sample(system, [(-2, 2), (-2, 2), (-1.4, 1.4), (-2, 2)], 60, seed=4).points(0, 60)
    a = I.integrate_batch(system, X, rules=RULES, terminal=_ipc_terminal())
    b = I.integrate_batch(system, X, rules=RULES, terminal=_ipc_terminal(), backend="numpy")
    np.testing.assert_array_equal(a.code, b.code)
    np.testing.assert_array_equal(a.entered, b.entered)
    np.testing.assert_allclose(a.t_end, b.t_end, rtol=1e-6, atol=1e-6)


def test_vanderpol_terminal_set():
    system = vanderpol()
    term = TerminalSet(P_BENCHMARK, np.zeros(2), 2.30)
    X = np.array([[0.5, 0.3], [1.4, 0.0], [2.0, 1.0], [3.0, 3.0], [-1.8, -1.2], [0.0, 0.0]])
    plain = I.integrate_batch(system, X, rules=RULES)
    res = I.integrate_batch(system, X, rules=RULES, terminal=term)
    assert _agree(plain, res) == 0
    # a point inside starts converged at t = 0 after one evaluation of V
    assert res.entered[0] and res.t_end[0] == 0.0 and res.steps[0] == 0
    np.testing.assert_array_equal(res.x_end[0], X[0])
    # the origin is in the converge ball: converged by the usual event, not by the set
    assert res.code[5] == I.CONVERGED and not res.entered[5]
    # runs from outside that enter stop earlier than the 1e-3 ball
    later = res.entered & (plain.t_end > 0)
    assert later[1:].any() and (res.t_end[1:][later[1:]] < plain.t_end[1:][later[1:]]).all()
    assert res.code[3] == I.DIVERGED and not res.entered[3]


@pytest.mark.slow
def test_basin_api_and_determinism_across_jobs(tmp_path):
    system = ipc.closed_loop()
    smp = box_sample(system, [(-1, 1), (-1, 1), (-1.2, 1.2), (-1, 1)], 400, seed=7)
    term = _ipc_terminal()
    runs = [
        run_basin(system, smp, rules=RULES, terminal=term, n_jobs=j, chunk_size=c, progress=False)
        for j, c in ((1, 400), (2, 64), (2, 33))
    ]
    for r in runs[1:]:
        np.testing.assert_array_equal(r.code, runs[0].code)
        np.testing.assert_array_equal(r.t_end, runs[0].t_end)
        assert r.entered_certified_set == runs[0].entered_certified_set > 0
    plain = run_basin(system, smp, rules=RULES, n_jobs=1, progress=False)
    assert plain.counts() == runs[0].counts() and plain.entered_certified_set == 0
    # the public API, from the certificate's dict; the JSON reports the count
    res = roa.basin(system, smp, rules=RULES, run=roa.RunOptions(n_jobs=1), terminal=_certificate())
    assert res.counts == plain.counts()
    d = res.to_dict()
    assert d["entered_certified_set"] == runs[0].entered_certified_set
    assert d["terminal_set"]["coords"] == "flat"
    # resumed chunks keep their count
    opts = {"rules": RULES, "terminal": term, "n_jobs": 1, "chunk_size": 100, "out_dir": tmp_path}
    first = run_basin(system, smp, **opts)
    again = run_basin(system, smp, **opts)
    assert again.chunks_resumed == 4 and again.chunks_computed == 0
    assert (
        again.entered_certified_set == first.entered_certified_set == runs[0].entered_certified_set
    )


def test_uncertified_or_foreign_certificates_are_refused(tmp_path):
    system = ipc.closed_loop()
    for status in ("refuted", "inconclusive"):
        with pytest.raises(RoaInputError, match="not 'certified'"):
            terminal_from_certificate(_certificate(status=status), system)
    with pytest.raises(RoaInputError, match="for system 'vanderpol'"):
        terminal_from_certificate(_certificate(system="vanderpol"), system)
    with pytest.raises(RoaInputError, match="missing level"):
        terminal_from_certificate({"P": [[1]], "status": "certified", "system": "ipc"}, system)
    # the flat closed loop is the physical one only without saturation
    with pytest.raises(RoaInputError, match="not 'ipc'|for system"):
        terminal_from_certificate(_certificate(), ipc.closed_loop(saturation=2.0))
    with pytest.raises(RoaInputError, match="no analysis coordinates"):
        I.integrate_batch(
            ipc.closed_loop(saturation=2.0), np.zeros((1, 4)), terminal=_ipc_terminal()
        )
    with pytest.raises(RoaInputError, match="positive definite"):
        TerminalSet(-np.eye(2), np.zeros(2), 1.0)
    ok = terminal_from_certificate(_certificate(), system)
    assert ok.coords == "flat" and ok.level == PAPER_LEVEL
    # Van der Pol's own certificate applies as is
    vdp = terminal_from_certificate(
        {"system": "vanderpol", "P": P_BENCHMARK.tolist(), "level": 2.3, "status": "certified"},
        vanderpol(),
    )
    assert vdp.coords is None


def test_cli_terminal_set(tmp_path, capsys):
    from roa.cli import main

    good, bad = tmp_path / "cert.json", tmp_path / "bad.json"
    good.write_text(json.dumps(_certificate()))
    bad.write_text(json.dumps(_certificate(status="inconclusive")))
    argv = ["basin", "--system", "ipc", "--slice", "theta,theta_dot", "--grid", "8x6",
            "--box", "theta=-1.2:1.2,theta_dot=-2:2", "--t-final", "30", "--jobs", "1", "--json"]  # fmt: skip
    assert main(argv) == 0
    plain = json.loads(capsys.readouterr().out)
    assert main([*argv, "--terminal-set", str(good)]) == 0
    term = json.loads(capsys.readouterr().out)
    assert term["counts"] == plain["counts"]
    assert term["entered_certified_set"] > 0 and plain["entered_certified_set"] == 0
    assert main([*argv, "--terminal-set", str(bad)]) == 2
    assert "--terminal-set" in capsys.readouterr().err
