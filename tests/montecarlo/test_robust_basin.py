"""Robust basins: a basin over a box of uncertain parameters (roa/montecarlo/_robust_basin.py).

Reference numbers come from closed forms. The test system ``x1' = -a x1 + x1^3, x2' = -x2``
(``a`` uncertain in [0.5, 2]) has the basin ``|x1| < sqrt(a)`` at each ``a`` (x1 = +-sqrt(a) are
the other equilibria, beyond them x1 blows up), so the converged share at ``x1`` is the share of
sampled ``a`` with ``a > x1^2``, and the worst case over samples that include the vertex
``a = 0.5`` is ``|x1| < sqrt(0.5)``. Grid points within 0.02 of a basin boundary are left out of
the comparisons (slow near the unstable equilibria; the tolerance is the only one used).
"""

from __future__ import annotations

import dataclasses
import json

import numba
import numpy as np
import pytest

import roa
from roa.cli import main
from roa.errors import ResultsError
from roa.integration import _integrator as I  # noqa: N812
from roa.integration._integrator import FIELD_SIGNATURE, MARGIN_SIGNATURE
from roa.model._system import System
from roa.montecarlo._basin import robust_basin
from roa.montecarlo._robust_basin import (
    MAX_PARAM_SAMPLES,
    RobustBasinResult,
    parameter_samples,
)
from roa.status import BasinStatus

P_VDP = [[1.5, -0.5], [-0.5, 1.0]]


def cubic(t, x, xp, p):
    return (-p.a * x[0] + x[0] ** 3, -x[1])


def cubic_box() -> System:
    return System("cubic", cubic, (0.0, 0.0), ("x1", "x2"), ("m", "m/s"),
                  parameters={"a": (0.5, 1.0, 2.0)})  # fmt: skip


def cubic_grid(system: System) -> roa.montecarlo._sampling.GridSlice:
    return roa.grid_slice(system, ("x1", "x2"), [(-1.9, 1.9), (-0.5, 0.5)], (39, 3))


def one_job(**kw) -> roa.RunOptions:
    return roa.RunOptions(n_jobs=1, **kw)


# -- parameter samples ----------------------------------------------------------------------------
def test_parameter_samples_nominal_vertices_then_seeded_uniform():
    s = System("two", lambda t, x, xp, p: (-p.a * x[0], -p.b * x[1]), (0.0, 0.0), ("u", "v"),
               parameters={"a": (1.0, 1.5, 2.0), "b": (0.5, 1.0, 3.0)})  # fmt: skip
    pts = parameter_samples(s, 5, seed=3)
    assert [p.kind for p in pts] == ["nominal"] + ["vertex"] * 4 + ["random"] * 5
    assert pts[0].values == {"a": 1.5, "b": 1.0}
    assert {tuple(p.values.values()) for p in pts[1:5]} == {(1.0, 0.5), (1.0, 3.0), (2.0, 0.5),
                                                            (2.0, 3.0)}  # fmt: skip
    assert [p.index for p in pts] == list(range(10))
    for p in pts[5:]:
        assert 1.0 <= p.values["a"] <= 2.0 and 0.5 <= p.values["b"] <= 3.0
    # deterministic, prefix-stable, and the seed matters
    assert parameter_samples(s, 5, seed=3) == pts
    assert parameter_samples(s, 9, seed=3)[:10] == pts
    assert parameter_samples(s, 5, seed=4)[5:] != pts[5:]
    assert parameter_samples(s, 5, seed=4)[:5] == pts[:5]
    # a nominal value at a vertex is listed once
    corner = System("c", cubic, (0.0, 0.0), ("x1", "x2"), parameters={"a": (0.5, 0.5, 2.0)})
    assert [p.kind for p in parameter_samples(corner, 0)] == ["nominal", "vertex"]


@pytest.mark.parametrize("bad", [-1, MAX_PARAM_SAMPLES + 1, 2.5, True])
def test_bad_param_samples_name_the_option_and_range(bad):
    with pytest.raises(roa.RoaInputError, match=rf"param_samples must be an integer in \[0, "
                       rf"{MAX_PARAM_SAMPLES}\]"):  # fmt: skip
        parameter_samples(cubic_box(), bad)
    with pytest.raises(roa.RoaInputError, match=r"param_seed must be an integer in \[0, "):
        parameter_samples(cubic_box(), 1, seed=-1)
    with pytest.raises(roa.RoaInputError, match="no uncertain parameters"):
        robust_basin(cubic_box().nominal(), cubic_grid(cubic_box()))


# -- the maps against the closed form -------------------------------------------------------------
@pytest.fixture(scope="module")
def cubic_run() -> RobustBasinResult:
    s = cubic_box()
    res = roa.basin(s, cubic_grid(s), param_samples=4, param_seed=1, run=one_job())
    assert isinstance(res, RobustBasinResult)
    return res


def test_share_and_worst_case_match_the_closed_form(cubic_run):
    res = cubic_run
    a = np.array([s.values["a"] for s in res.samples])
    assert len(a) == 7 and a.min() == 0.5 and a.max() == 2.0
    x1 = res.sampler.points(0, res.n)[:, 0]
    clear = np.all(np.abs(np.abs(x1)[:, None] - np.sqrt(a)[None, :]) > 0.02, axis=1)
    assert clear.sum() > 0.8 * res.n
    expected_share = np.mean(a[None, :] > x1[:, None] ** 2, axis=1)
    assert np.array_equal(res.share[clear], expected_share[clear])
    assert np.array_equal(res.worst_case[clear], (np.abs(x1) < np.sqrt(0.5))[clear])
    assert res.status is BasinStatus.PARTLY_CONVERGED
    # statuses per sample, never merged: each run is the plain basin at that parameter value
    for sample, run in zip(res.samples, res.runs, strict=True):
        alone = roa.basin(res.system.at(**sample.values), res.sampler, run=one_job())
        assert np.array_equal(run.code, alone.code)
        expected = np.where(x1**2 < sample.values["a"], I.CONVERGED, I.DIVERGED)
        assert np.array_equal(run.code[clear], expected[clear])


def test_json_keeps_every_sample_and_derives_the_maps(cubic_run):
    d = json.loads(json.dumps(cubic_run.to_dict()))
    n = d["n"]
    assert "counts" not in d  # no count merged over parameter values
    assert d["parameters"] == {"a": {"low": 0.5, "nominal": 1.0, "high": 2.0}}
    assert d["parameter_samples"] == {"count": 7, "nominal": 1, "vertices": 2, "random": 4,
                                      "seed": 1}  # fmt: skip
    assert len(d["per_parameter"]) == 7
    for entry, run in zip(d["per_parameter"], cubic_run.runs, strict=True):
        assert sum(entry["counts"].values()) == n
        assert entry["counts"]["converged"] == int(np.sum(run.code == I.CONVERGED))
        assert set(entry["parameters"]) == {"a"}
    hist = d["converged_share"]["histogram"]
    assert len(hist) == 8 and sum(hist) == n
    assert d["worst_case"]["converged"] == hist[-1] == int(cubic_run.worst_case.sum())
    # converged share's mean: the mean over samples of each sample's fraction converged
    fractions = [e["fraction_converged"] for e in d["per_parameter"]]
    assert d["converged_share"]["mean"] == pytest.approx(np.mean(fractions), abs=1e-12)
    assert d["mode"] == "slice" and d["grid"] == [39, 3]


@pytest.mark.slow
def test_same_result_whatever_the_workers_and_chunk_size(cubic_run):
    s = cubic_box()
    other = roa.basin(s, cubic_grid(s), param_samples=4, param_seed=1,
                      run=roa.RunOptions(n_jobs=2, chunk_size=7))  # fmt: skip
    assert np.array_equal(other.codes, cubic_run.codes)
    for a, b in zip(other.runs, cubic_run.runs, strict=True):
        assert np.array_equal(a.t_end, b.t_end)
    skip = {"seconds"}
    da, db = other.to_dict(), cubic_run.to_dict()
    for d in (da, db):
        for e in d["per_parameter"]:
            del e["chunks_computed"], e["chunks_resumed"]
    assert {k: v for k, v in da.items() if k not in skip} == {
        k: v for k, v in db.items() if k not in skip
    }


def test_resumes_per_sample_and_never_reuses_other_parameter_values(tmp_path, cubic_run):
    s = cubic_box()
    grid = cubic_grid(s)
    first = roa.basin(s, grid, param_samples=2, param_seed=1, run=one_job(out_dir=str(tmp_path)))
    assert all(r.chunks_resumed == 0 for r in first.runs)
    assert json.loads((tmp_path / "parameter_samples.json").read_text())["samples"][0] == {
        "index": 0, "kind": "nominal", "parameters": {"a": 1.0}}  # fmt: skip
    again = roa.basin(s, grid, param_samples=4, param_seed=1, run=one_job(out_dir=str(tmp_path)))
    # the first 2 random samples are the same for 4: their folders resume, the new ones run
    assert [r.chunks_resumed for r in again.runs] == [1, 1, 1, 1, 1, 0, 0]
    assert np.array_equal(again.codes, cubic_run.codes)
    # another box: other parameter values in the same folders are refused, not resumed
    wider = System("cubic", cubic, (0.0, 0.0), ("x1", "x2"), ("m", "m/s"),
                   parameters={"a": (0.4, 1.0, 2.0)})  # fmt: skip
    with pytest.raises(ResultsError, match="different run"):
        roa.basin(wider, grid, param_samples=2, param_seed=1, run=one_job(out_dir=str(tmp_path)))


# -- compiled kernels are for the parameter values they were built for ---------------------------
@numba.cfunc(FIELD_SIGNATURE)
def _vdp_field(t, x, p, out):
    out[0] = -x[1]
    out[1] = x[0] + p[0] * (x[0] * x[0] - 1.0) * x[1]


@numba.cfunc(MARGIN_SIGNATURE)
def _no_margin(x, p):
    return 1.0


class VdpKernels:
    """A ``System.numba`` factory built for one value of mu (no way to rebuild it)."""

    def __init__(self, mu: float) -> None:
        self.params = np.array([float(mu)])

    def __call__(self):
        return _vdp_field, _no_margin, self.params


class RebuildableVdpKernels(VdpKernels):
    def with_params(self, values):
        return RebuildableVdpKernels(values["mu"])


def vdp(t, x, xp, p):
    return (-x[1], x[0] + p.mu * (x[0] * x[0] - 1) * x[1])


@pytest.mark.slow
def test_kernels_never_integrate_other_parameter_values():
    fixed = System("vdpk", vdp, (0.0, 0.0), ("x1", "x2"), params={"mu": 1.0},
                   numba=VdpKernels(1.0))  # fmt: skip
    box = fixed.with_ranges(mu=(0.8, 1.2))
    assert box.numba is fixed.numba  # same values (nominal 1.0): the same kernel
    assert box.at(mu=1.0).numba is fixed.numba
    assert box.at(mu=0.8).numba is None and fixed.with_params(mu=0.8).numba is None
    rebuilt = System("vdpk", vdp, (0.0, 0.0), ("x1", "x2"), params={"mu": 1.0},
                     numba=RebuildableVdpKernels(1.0)).with_ranges(mu=(0.8, 1.2))  # fmt: skip
    assert rebuilt.at(mu=0.8).numba.params.tolist() == [0.8]
    # a grid where the statuses differ between mu = 0.8 and 1.2 (top of the Van der Pol basin)
    grid = roa.grid_slice(box, ("x1", "x2"), [(-0.2, 1.0), (2.2, 3.0)], (7, 5))
    x0 = grid.points(0, grid.n)
    numpy_at = {mu: I.integrate_batch(fixed.with_params(mu=mu), x0, backend="numpy").code
                for mu in (0.8, 1.2)}  # fmt: skip
    assert not np.array_equal(numpy_at[0.8], numpy_at[1.2])  # the check below can fail
    stale_system = dataclasses.replace(box.at(mu=0.8), numba=VdpKernels(1.2))
    stale = I.integrate_batch(stale_system, x0, backend="numba").code
    assert np.array_equal(stale, numpy_at[1.2])  # what a kept kernel of mu = 1.2 would give
    for system in (box, rebuilt):
        res = roa.basin(system, grid, param_samples=0, run=one_job())
        for sample, run in zip(res.samples, res.runs, strict=True):
            if sample.values["mu"] in numpy_at:
                assert np.array_equal(run.code, numpy_at[sample.values["mu"]])
    assert I.integrate_batch(rebuilt.at(mu=0.8), x0, backend="numba").code.tolist() == (
        numpy_at[0.8].tolist()
    )


# -- the robust certified set ---------------------------------------------------------------------
def test_terminal_set_from_a_robust_certificate_finishes_runs_at_every_sample(tmp_path):
    box = roa.load_system("vanderpol").with_ranges(mu=(0.8, 1.2))
    cert = roa.certify(box, roa.default_lyapunov(box.nominal()), level=2.0)
    assert cert.status is roa.Verdict.CERTIFIED
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(cert.to_dict()))
    grid = roa.grid_slice(box, ("x1", "x2"), [(-2.5, 2.5), (-2.5, 2.5)], (9, 9))
    plain = roa.basin(box, grid, param_samples=1, run=one_job())
    finished = roa.basin(box, grid, param_samples=1, run=one_job(), terminal=str(path))
    assert np.array_equal(plain.codes, finished.codes)  # entering the set changes no status
    assert all(r.entered_certified_set > 0 for r in finished.runs)
    d = finished.to_dict()
    assert d["terminal_set"]["level"] == 2.0
    # a certificate for the nominal value only is not one for the box
    nominal = roa.certify(box.nominal(), roa.default_lyapunov(box.nominal()), level=2.0)
    with pytest.raises(roa.RoaInputError, match="another system"):
        roa.basin(box, grid, param_samples=1, run=one_job(), terminal=nominal.to_dict())


def test_cli_robust_basin_json_plot_and_bad_input(tmp_path, capsys):
    png = tmp_path / "robust.png"
    args = ["basin", "--system", "vanderpol", "--param", "mu=0.8..1.2", "--param-samples", "1",
            "--slice", "x1,x2", "--grid", "8x8", "--box", "x1=-3:3,x2=-3:3", "--jobs", "1",
            "--lyapunov-level", "2.0", "--plot", str(png), "--json"]  # fmt: skip
    assert main(args) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["parameter_samples"]["count"] == 4 and len(d["per_parameter"]) == 4
    assert d["regions"][0]["status"] == "certified"
    assert d["regions"][0]["slice"]["all_converged"] is True
    assert png.stat().st_size > 20_000
    assert main(args[:5] + ["--nominal"] + args[7:]) == 0
    nominal = json.loads(capsys.readouterr().out)
    assert "per_parameter" not in nominal and sum(nominal["counts"].values()) == 64
    assert main(args[:5] + ["--param-samples", "-1"] + args[7:]) == 2
    err = capsys.readouterr().err
    assert "--param-samples must be an integer in [0, 1000]" in err
    assert main(args[:5] + ["--seed", "-3"] + args[5:]) == 2
    assert "--seed must be an integer in [0, 2^63)" in capsys.readouterr().err
    assert main(args[:3] + args[5:]) == 2  # vanderpol with mu fixed: no parameter box
    assert "--param-samples applies to a system with uncertain parameters" in (
        capsys.readouterr().err
    )
