"""Monte Carlo engine: agreement with solve_ivp, determinism, resume, dask, bad inputs.

Reference problem: the IPC closed loop (ipc_paper.system.closed_loop, physical coordinates) and the
time-reversed Van der Pol benchmark; the reference integrator is scipy's solve_ivp (method RK45,
the same Dormand-Prince 5(4) pair, same tolerances and events) through roa.integration.simulate.
"""

from __future__ import annotations

import numpy as np
import pytest

from ipc_paper import system as ipc
from roa.errors import ResultsError
from roa.integration import _integrator as I  # noqa: N812
from roa.integration._simulation import simulate
from roa.lyapunov._regions import Region
from roa.montecarlo._engine import run_basin, wilson_interval
from roa.montecarlo._sampling import box_sample, grid_slice, region_sample
from roa.status import StopRules
from roa.systems.vanderpol import P_BENCHMARK, vanderpol

RULES = StopRules(t_final=30.0)


def _reference_status(system, x0, rules, rtol=1e-6, atol=1e-9):
    return simulate(system, x0, rules=rules, rtol=rtol, atol=atol, method="RK45")


def test_numba_field_matches_system_f():
    rng = np.random.default_rng(3)
    for sat in (None, 0.7):
        system = ipc.closed_loop(delta=1.7, saturation=sat)
        field, margin, params = system.numba()
        X = rng.uniform(-1, 1, (200, 4)) * [3, 3, 1.5, 4]
        out = np.empty(4)
        ref = system.f(X)
        for x, r in zip(X, ref, strict=True):
            field(0.0, x, params, out)
            np.testing.assert_allclose(out, r, rtol=1e-12, atol=1e-12)
            assert margin(x, params) == pytest.approx(np.pi / 2 - abs(x[2]))
    flat = ipc.transformed()
    field, _, params = flat.numba()
    for x in rng.normal(size=(50, 4)) * 5:
        field(0.0, x, params, out)
        np.testing.assert_allclose(out, flat.f(x), rtol=1e-12, atol=1e-12)


@pytest.mark.slow
def test_classifications_agree_with_solve_ivp_ipc():
    """Random states over the whole domain, including the edges where runs leave or diverge."""
    system = ipc.closed_loop()
    rng = np.random.default_rng(11)
    X = rng.uniform(-1, 1, (60, 4)) * [4, 4, 1.5707, 8]
    X[:10, 2] = np.sign(X[:10, 2]) * rng.uniform(1.5690, 1.57075, 10)  # near the boundary
    res = I.integrate_batch(system, X, rules=RULES)
    statuses = set()
    for x, c, te in zip(X, res.code, res.t_end, strict=True):
        ref = _reference_status(system, x, RULES)
        assert I.CODE_STATUS[int(c)] == ref.status, (x, c, ref.status, ref.message)
        statuses.add(ref.status)
        if ref.status.value != "undecided":
            assert te == pytest.approx(ref.t_end, rel=1e-6, abs=1e-8)
    assert len(statuses) >= 2  # the sample really exercises more than one status


def test_left_domain_and_numpy_backend_agree_with_solve_ivp_saturated():
    """With |u| <= 0.5 many runs fall over (left_domain); the numpy back end must agree too."""
    system = ipc.closed_loop(saturation=0.5)
    rng = np.random.default_rng(5)
    X = rng.uniform(-1, 1, (40, 4)) * [2, 1, 0.8, 1]
    a = I.integrate_batch(system, X, rules=RULES, backend="numba")
    b = I.integrate_batch(system, X, rules=RULES, backend="numpy")
    np.testing.assert_array_equal(a.code, b.code)
    np.testing.assert_allclose(a.t_end, b.t_end, rtol=1e-9, atol=1e-9)
    ref = [_reference_status(system, x, RULES).status for x in X]
    assert [I.CODE_STATUS[int(c)] for c in a.code] == ref
    assert (a.code == I.LEFT_DOMAIN).any() and (a.code == I.CONVERGED).any()


def test_numpy_backend_generic_system_vanderpol():
    """A system without a numba field (time-reversed Van der Pol): inside/outside its true ROA."""
    system = vanderpol()
    rules = StopRules(t_final=40.0, diverge_bound=1e3)
    rng = np.random.default_rng(2)
    X = rng.uniform(-3, 3, (40, 2))
    res = I.integrate_batch(system, X, rules=rules)
    ref = [_reference_status(system, x, rules).status for x in X]
    assert [I.CODE_STATUS[int(c)] for c in res.code] == ref
    assert (res.code == I.DIVERGED).any() and (res.code == I.CONVERGED).any()


def test_status_counts_nothing_merged():
    """Each initial state engineered for one status; counts are per status, step failures apart."""
    system = ipc.closed_loop(saturation=0.3)
    X = np.array(
        [
            [0.0, 0.0, 0.0, 0.0],  # at the equilibrium: converged at t = 0
            [0.0, 0.0, 0.05, 0.0],  # small: converged
            [0.0, 0.0, 1.2, 0.0],  # saturated force cannot hold it: left_domain
            [0.0, 0.0, 1.5707, -6.0],  # unsaturated loop runs the cart off (checked below)
        ]
    )
    res = I.integrate_batch(system, X[:3], rules=RULES)
    assert list(res.code) == [I.CONVERGED, I.CONVERGED, I.LEFT_DOMAIN]
    free = I.integrate_batch(ipc.closed_loop(), X[3:], rules=StopRules(t_final=30.0))
    assert list(free.code) == [I.DIVERGED]
    slow = I.integrate_batch(ipc.closed_loop(), X[1:2], rules=StopRules(t_final=0.5))
    assert list(slow.code) == [I.UNDECIDED]
    from roa.montecarlo._engine import BasinRun

    run = BasinRun(np.concatenate([res.code, free.code, slow.code]), np.zeros(5, np.float32))
    assert run.counts() == {"converged": 2, "left_domain": 1, "diverged": 1, "undecided": 1,
                            "converged_elsewhere": 0}  # fmt: skip


def test_determinism_across_workers_and_chunks():
    system = ipc.closed_loop(saturation=1.0)
    smp = box_sample(system, [(-3, 3), (-1, 1), (-1.2, 1.2), (-1, 1)], 3000, seed=9)
    a = run_basin(system, smp, rules=RULES, n_jobs=1, chunk_size=3000)
    b = run_basin(system, smp, rules=RULES, n_jobs=2, chunk_size=211)
    np.testing.assert_array_equal(a.code, b.code)
    np.testing.assert_array_equal(a.t_end, b.t_end)
    # the samples themselves do not depend on the chunking
    np.testing.assert_array_equal(smp.points(100, 5000 - 4000), smp.points(0, 3000)[100:1000])
    assert 0 < a.counts()["converged"] < a.n


def test_resume_after_interruption(tmp_path):
    system = ipc.closed_loop(saturation=1.0)
    smp = box_sample(system, [(-3, 3), (-1, 1), (-1.2, 1.2), (-1, 1)], 1000, seed=4)
    full = run_basin(system, smp, rules=RULES, n_jobs=1, chunk_size=100)
    with pytest.raises(KeyboardInterrupt):
        run_basin(
            system, smp, rules=RULES, n_jobs=1, chunk_size=100, out_dir=tmp_path, _stop_after=4
        )
    files = sorted((tmp_path / "chunks").glob("chunk_*.npz"))
    assert len(files) == 4
    assert not list(tmp_path.rglob("*.tmp"))  # no half-written file
    again = run_basin(system, smp, rules=RULES, n_jobs=1, chunk_size=100, out_dir=tmp_path)
    assert (again.chunks_resumed, again.chunks_computed) == (4, 6)
    np.testing.assert_array_equal(again.code, full.code)
    other = box_sample(system, [(-3, 3), (-1, 1), (-1.2, 1.2), (-1, 1)], 1000, seed=5)
    with pytest.raises(ResultsError, match="different run"):  # a roa error, no longer ValueError
        run_basin(system, other, rules=RULES, n_jobs=1, chunk_size=100, out_dir=tmp_path)
    replaced = run_basin(system, other, rules=RULES, n_jobs=1, chunk_size=100, out_dir=tmp_path,
                         replace_stale=True)  # fmt: skip
    assert (replaced.chunks_resumed, replaced.chunks_computed) == (0, 10)
    np.testing.assert_array_equal(
        replaced.code, run_basin(system, other, rules=RULES, n_jobs=1).code
    )


@pytest.mark.slow
def test_dask_local_cluster_identical():
    from dask.distributed import LocalCluster

    system = ipc.closed_loop(saturation=1.0)
    smp = box_sample(system, [(-3, 3), (-1, 1), (-1.2, 1.2), (-1, 1)], 2000, seed=1)
    ref = run_basin(system, smp, rules=RULES, n_jobs=1)
    with LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1", processes=True,
                      dashboard_address=None) as cluster:  # fmt: skip
        got = run_basin(
            system, smp, rules=RULES, chunk_size=300, scheduler=cluster.scheduler_address
        )
    np.testing.assert_array_equal(got.code, ref.code)
    np.testing.assert_array_equal(got.t_end, ref.t_end)


def test_region_sampling_inside_and_on():
    T = np.array([[1, 3, 3, 1], [0, 1, 2, 1], [0, 0, 1, 1], [0, 0, 0, 1]], float)
    region = Region("paper", T.T @ T, 4.89, "claimed", ipc.physical_to_flat_or_inf)
    on = region_sample(region, 500, seed=1, mode="surface", inverse=ipc.from_flat)
    inside = region_sample(region, 4000, seed=1, inverse=ipc.from_flat)
    np.testing.assert_allclose(region.form(on.points(0, 500)), 4.89, rtol=1e-9)
    f = region.form(inside.points(0, 4000)) / 4.89
    assert f.max() <= 1 + 1e-9
    # uniform in a 4-ball: P(r^2 <= 1/2) = (1/2)^2 = 1/4; binomial sd ~ 0.007
    assert abs(np.mean(f <= 0.5) - 0.25) < 0.03
    with pytest.raises(ValueError, match="inverse"):
        region_sample(region, 10, seed=0)


def test_wilson_interval_known_values():
    # Wilson 95 % for 0/10: (0, z^2 / (n + z^2)) = (0, 0.2775); for 5/10: 0.2366-0.7634 (closed form)
    assert wilson_interval(0, 10)[1] == pytest.approx(0.27753, abs=1e-4)
    lo, hi = wilson_interval(5, 10)
    assert (lo, hi) == (pytest.approx(0.23659, abs=1e-4), pytest.approx(0.76341, abs=1e-4))


def test_bad_inputs():
    system = ipc.closed_loop()
    with pytest.raises(ValueError, match="unknown state axis 'phi'"):
        grid_slice(system, ["phi", "q"], [(-1, 1), (-1, 1)], (3, 3))
    with pytest.raises(ValueError, match="outside the domain"):
        grid_slice(system, ["q", "q_dot"], [(-1, 1), (-1, 1)], (3, 3), fixed={"theta": 1.6})
    with pytest.raises(ValueError, match="at least 2x2"):
        grid_slice(system, ["q", "theta"], [(-1, 1), (-1, 1)], (1, 3))
    with pytest.raises(ValueError, match="rtol"):
        I.integrate_batch(system, np.zeros((1, 4)), rtol=0.0)
    with pytest.raises(ValueError, match="shape"):
        I.integrate_batch(system, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="jobs"):
        run_basin(system, box_sample(system, [(-1, 1)] * 4, 5, seed=0), n_jobs=0)
    with pytest.raises(ValueError, match="P"):
        Region("bad", -np.eye(2), 1.0, "claimed")
    assert P_BENCHMARK.shape == (2, 2)


def test_cli_basin_json(capsys):
    import json

    from roa.cli import main

    argv = ["basin", "--system", "ipc:saturation=1", "--slice", "theta,theta_dot", "--grid", "6x5",
            "--box", "theta=-1.5:1.5,theta_dot=-3:3", "--jobs", "1", "--json"]  # fmt: skip
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n"] == 30 and sum(out["counts"].values()) == 30
    assert set(out["counts"]) == {"converged", "left_domain", "diverged", "undecided",
                                  "converged_elsewhere"}  # fmt: skip
    assert out["fraction_converged"] == pytest.approx(out["counts"]["converged"] / 30)
    # the same grid through the library gives the same counts
    system = ipc.closed_loop(saturation=1.0)
    g = grid_slice(system, ["theta", "theta_dot"], [(-1.5, 1.5), (-3, 3)], (6, 5))
    assert run_basin(system, g, rules=StopRules(t_final=60.0), n_jobs=1).counts() == out["counts"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--slice", "theta,phi", "--grid", "3x3"], "unknown state 'phi'"),
        (["--slice", "theta,q", "--grid", "3by3"], "--grid: expected NxM"),
        (["--slice", "theta,q", "--grid", "1x3"], "--grid: N and M must be >= 2"),
        (["--slice", "q,q_dot", "--grid", "3x3", "--fix", "theta=1.6"], "outside the domain"),
        (["--slice", "q,q_dot", "--grid", "3x3", "--fix", "omega=1"], "--fix: unknown state"),
        (["--slice", "q,theta", "--grid", "3x3", "--box", "theta=1:-1"], "need finite LO < HI"),
        (["--slice", "q,theta", "--grid", "3x3", "--samples", "10"], "either --slice"),
        (["--system", "ipc:saturation=-1", "--samples", "10"], "saturation must be"),
        (["--system", "ipc:saturation=x", "--samples", "10"], "NAME=NUMBER"),
        (["--samples", "0"], "--samples must be >= 1"),
        (["--samples", "10", "--jobs", "0"], "--jobs must be"),
        (["--samples", "10", "--plot", "x.png"], "--plot draws a slice"),
    ],
)
def test_cli_bad_inputs(args, message, capsys):
    from roa.cli import main

    argv = ["basin", *args] if "--system" in args else ["basin", "--system", "ipc", *args]
    assert main(argv) == 2
    assert message in capsys.readouterr().err


@pytest.mark.slow
def test_cli_killed_run_resumes(tmp_path):
    """SIGKILL a real `roa basin --out` run mid-way; the rerun resumes and matches a fresh run."""
    import json
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "run"
    argv = [sys.executable, "-m", "roa.cli", "basin", "--system", "ipc:saturation=1", "--samples", "40000",
            "--box", "q=-3:3,q_dot=-1:1,theta=-1.2:1.2,theta_dot=-1:1", "--seed", "3",
            "--chunk-size", "1000", "--jobs", "1", "--out", str(out)]  # fmt: skip
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while time.time() < deadline and len(list((out / "chunks").glob("chunk_*.npz"))) < 3:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    done = sorted((out / "chunks").glob("chunk_*.npz"))
    assert 3 <= len(done) < 40
    for f in done:  # every chunk file on disk is whole
        with np.load(f) as z:
            assert z["code"].size == 1000
    res = subprocess.run([*argv, "--json"], capture_output=True, text=True, check=True)
    resumed = json.loads(res.stdout)
    assert resumed["chunks_resumed"] >= len(done)
    system = ipc.closed_loop(saturation=1.0)
    smp = box_sample(system, [(-3, 3), (-1, 1), (-1.2, 1.2), (-1, 1)], 40000, seed=3)
    fresh = run_basin(system, smp, rules=StopRules(t_final=60.0), n_jobs=2)
    assert resumed["counts"] == fresh.counts()
