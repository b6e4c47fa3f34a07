"""The kernel's fast path and the certified early exit in the reproduction (issue 14).

* ``System.numba_fast`` (njit functions compiled into a kernel of their own, the field
  fused with the map to the terminal set's coordinates) gives the same trajectories bit for bit
  as the public ``System.numba`` protocol (cfuncs) that user systems follow;
* the fused field writes exactly what the field and the coordinate map give on their own,
  inside, outside and on the edge of the maps' domain;
* the basin experiments of the loop without saturation stop runs in the certified set of
  ``results/certify/certified.json`` by default (a params flag switches it off), with the same
  statuses and ``entered_certified_set`` reported; the saturated loop and the region runs keep it
  off.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import pickle
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from ipc_paper import basins, system as ipc
from ipc_paper.system import fast
from roa.errors import RoaInputError
from roa.integration import _integrator as I  # noqa: N812
from roa.integration._terminal import TerminalSet
from roa.montecarlo._sampling import box_sample, grid_slice
from roa.status import StopRules

ROOT = Path(__file__).resolve().parents[2]
RULES = StopRules(t_final=30.0)
PAPER_LEVEL = 2.28  # certified: 2.2806 (results/certify/certified.json)


def _public(system):
    """The same system without its fast path: the kernel takes the public meta protocol."""
    return dataclasses.replace(system, numba_fast=None)


def _states(system, m=400, seed=5):
    rng = np.random.default_rng(seed)
    X = box_sample(system, [(-3, 3), (-3, 3), (-1.5, 1.5), (-3, 3)], m, seed=seed).points(0, m)
    # some states near the domain's edge and far out: left_domain, undecided, diverged
    X[:20, 2] = np.sign(X[:20, 2]) * rng.uniform(1.5690, 1.57075, 20)
    X[20:40] *= [4, 4, 1, 6]
    return X


def _same(a, b):
    for name in ("code", "t_end", "x_end", "steps"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    np.testing.assert_array_equal(a.entered, b.entered)


@pytest.mark.parametrize(
    "terminal",
    [
        None,
        TerminalSet(ipc.transformed().lyapunov, np.zeros(4), PAPER_LEVEL, coords="flat"),
        TerminalSet(np.diag([0.3, 1.0, 2.0, 1.0]), np.zeros(4), 1.5, coords="hybrid"),
    ],
    ids=["plain", "flat", "hybrid"],
)
def test_fast_path_is_bit_identical_to_the_public_protocol(terminal):
    system = ipc.closed_loop()
    assert system.numba_fast is not None
    X = _states(system)
    fast_run = I.integrate_batch(system, X, rules=RULES, terminal=terminal)
    public = I.integrate_batch(_public(system), X, rules=RULES, terminal=terminal)
    _same(fast_run, public)
    if terminal is not None:
        assert 0 < fast_run.entered.sum() < X.shape[0]
    assert len(set(fast_run.code.tolist())) >= 2  # not a trivial batch


def test_fast_path_of_the_saturated_and_flat_loops():
    for system in (ipc.closed_loop(saturation=1.0, delta=1.3), ipc.transformed()):
        X = _states(ipc.closed_loop(), m=150, seed=8)
        _same(
            I.integrate_batch(system, X, rules=RULES),
            I.integrate_batch(_public(system), X, rules=RULES),
        )


def test_the_fast_path_is_chosen_compiled_once_and_the_public_one_kept():
    system = ipc.closed_loop()
    term = TerminalSet(np.eye(4), np.zeros(4), 1.0, coords="flat")
    run, _ = I._numba_kernel(system, term)
    assert run is I.compile_kernel(
        fast.physical_field_njit,
        fast.physical_margin_njit,
        fast.physical_to_flat_njit,
        fast.physical_field_flat_njit,
    )
    assert I._numba_kernel(system, None)[0] is I.compile_kernel(
        fast.physical_field_njit, fast.physical_margin_njit
    )
    # a set in the simulated coordinates: the kernel without a map
    own = TerminalSet(np.eye(4), np.zeros(4), 0.5)
    assert I._numba_kernel(system, own)[0] is I._numba_kernel(system, None)[0]
    public, _ = I._numba_kernel(_public(system), term)
    assert public not in I._COMPILED.values()


def test_inlined_functions_key_the_disk_cache_by_their_source():
    a = I.Inlined(fast.physical_field_njit)
    b = pickle.loads(pickle.dumps(a))
    assert pickle.dumps(a) == pickle.dumps(b) and b.fn is a.fn
    module, qualname, digest = a.key
    assert (module, qualname) == ("ipc_paper.system.fast", "physical_field_njit")
    assert digest == hashlib.sha256(Path(fast.__file__).read_bytes()).hexdigest()


@pytest.mark.parametrize("coords", ["flat", "hybrid"])
def test_fused_field_writes_what_the_field_and_the_map_give(coords):
    params = ipc.closed_loop(delta=1.7).numba()[2]
    rng = np.random.default_rng(2)
    X = rng.uniform(-1, 1, (300, 4)) * [5, 5, 1.5707, 9]
    X[:8, 2] = [np.pi / 2, -np.pi / 2, 1.5707963267948966, 2.0, np.inf, np.nan, 1e-310, -0.0]
    X[8:12, [0, 1, 3, 0]] = [np.inf, -np.inf, np.nan, 1.7e308]
    cmap, fused = fast.FAST_COORDS[coords]
    public_map = fast.compiled_coords(coords)
    for x in X:
        x = np.ascontiguousarray(x)
        out_a, w_a = np.empty(4), np.empty(4)
        out_b, w_b, w_c, out_c = np.empty(4), np.empty(4), np.empty(4), np.empty(4)
        fast.physical_field(0.0, x, params, out_a)
        public_map(x, params, w_a)
        fused(0.0, x, params, out_b, w_b)
        cmap(x, params, w_c)
        fast.physical_field_njit(0.0, x, params, out_c)
        np.testing.assert_array_equal(out_b, out_a, err_msg=str(x))
        np.testing.assert_array_equal(out_c, out_a, err_msg=str(x))
        np.testing.assert_array_equal(w_b, w_a, err_msg=str(x))
        np.testing.assert_array_equal(w_c, w_a, err_msg=str(x))


# ----------------------------------------------------------------- the reproduction's basin runs


def _certified_results(tmp_path: Path) -> Path:
    src = ROOT / "results" / "certify" / "certified.json"
    if not src.is_file():
        pytest.skip("results/certify/certified.json missing: run experiments/certify.toml first")
    (tmp_path / "certify").mkdir()
    shutil.copy(src, tmp_path / "certify" / "certified.json")
    return tmp_path


def test_terminal_set_on_by_default_for_the_loop_without_saturation():
    base = {"samples": 10}
    assert basins.BoxParams(**base).terminal_set is True
    assert basins.SliceParams(axes=("q", "theta"), grid=(4, 4),
                              ranges=((-1.0, 1.0), (-1.0, 1.0))).terminal_set is True  # fmt: skip
    assert basins.RegionParams(**base).terminal_set is False  # circular for the certified sets
    with pytest.raises(RoaInputError, match="terminal_set must be true or false"):
        basins.BoxParams(**base, terminal_set="yes")
    for name in ("basin_q_theta", "basin_theta_thetadot", "basin_box"):
        cfg = tomllib.loads((ROOT / "experiments" / f"{name}.toml").read_text())
        assert "certify" in cfg["depends"], name  # a new certificate re-runs the basin
        assert cfg["params"].get("terminal_set", True) is True, name


def test_the_certified_terminal_set_of_the_reproduction(tmp_path):
    results = _certified_results(tmp_path)
    system = ipc.closed_loop()
    term, info = basins.terminal_set(system, results, True)
    data = json.loads((results / "certify" / "certified.json").read_text())
    best = max((e for e in data["regions"] if e["status"] == "certified"),
               key=lambda e: e["box_fraction"])  # fmt: skip
    assert term is not None and info["used"] and info["name"] == best["name"] == term.name
    assert term.level == best["level"] and term.coords == best.get("coords", "flat")
    np.testing.assert_array_equal(term.P, np.asarray(best["P"]))
    assert len(info["source_sha256"]) == 64
    # off: by the flag, for the saturated loop, without a certificate
    assert basins.terminal_set(system, results, False)[0] is None
    none, why = basins.terminal_set(ipc.closed_loop(saturation=1.0), results, True)
    assert none is None and "saturated" in why["reason"]
    assert basins.terminal_set(system, tmp_path / "nowhere", True)[0] is None
    # a changed certificate is a different terminal set (and a different run fingerprint)
    best["level"] = 0.5 * best["level"]
    (results / "certify" / "certified.json").write_text(json.dumps(data))
    term2, info2 = basins.terminal_set(system, results, True)
    assert term2 is not None and term2.level == 0.5 * term.level
    assert info2["source_sha256"] != info["source_sha256"] and repr(term2) != repr(term)


def test_basin_runs_with_the_certified_set_keep_their_statuses(tmp_path):
    results = _certified_results(tmp_path)
    system = ipc.closed_loop()
    term, _ = basins.terminal_set(system, results, True)
    params = basins.SliceParams(axes=("q", "theta"), grid=(14, 12), t_final=60.0,
                                ranges=((-10.0, 10.0), (-1.57, 1.57)),
                                fixed={"q_dot": 0.0, "theta_dot": 0.0}, jobs=1).to_dict()  # fmt: skip
    opts = basins._options(params)
    g = grid_slice(system, ["q", "theta"], [(-10.0, 10.0), (-1.57, 1.57)], (14, 12))
    plain = basins._basin(system, g, opts)
    with_set = basins._basin(system, g, opts, terminal=term)
    np.testing.assert_array_equal(with_set.code, plain.code)
    assert with_set.counts == plain.counts
    assert 0 < with_set.entered_certified_set <= with_set.counts["converged"]
    assert plain.entered_certified_set == 0
    summary = basins._run_summary(with_set)
    assert summary["entered_certified_set"] == with_set.entered_certified_set
    # stop times are entry times: never later than the time to converge
    assert (with_set.t_end <= plain.t_end).all() and (with_set.t_end < plain.t_end).any()
