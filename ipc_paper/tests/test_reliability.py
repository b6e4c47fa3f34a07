"""Issue 12 (reliability): items 1 (no code from data), 3 (chunks), 6 (bounded resources), 7 (Dask).

Small grids of the time-reversed Van der Pol system, ``n_jobs=1``; the Dask tests bound their waits
with ``scheduler_timeout`` so each takes a few seconds.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import threading
import time
import tracemalloc
import warnings

import numpy as np
import pytest

from ipc_paper import system as ipc
from ipc_paper.system.controller import ExpressionReference, SineReference, make_reference
from roa.errors import ResultsError, RoaInputError, SolverError
from roa.montecarlo import _engine as engine
from roa.montecarlo._engine import BasinRun, ChunkRejectedWarning, run_basin
from roa.montecarlo._sampling import MAX_SAMPLES, box_sample, grid_slice
from roa.status import StopRules
from roa.systems.vanderpol import vanderpol

RULES = StopRules(t_final=15.0, diverge_bound=1e3)
SYSTEM = vanderpol()
CHUNK = 5


def _grid(shape=(6, 5), lo=-3.0):
    return grid_slice(SYSTEM, ("x1", "x2"), [(lo, 3.0), (-3.0, 3.0)], shape)


def _run(sampler, out_dir=None, **kw):
    kw.setdefault("chunk_size", CHUNK)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ChunkRejectedWarning)  # unexpected rejections fail loudly
        if kw.pop("expect_rejections", False):
            warnings.simplefilter("ignore", ChunkRejectedWarning)
        res = run_basin(SYSTEM, sampler, rules=RULES, n_jobs=1, out_dir=out_dir, **kw)
    assert sum(res.counts().values()) == res.n  # counts always sum to n
    return res


@pytest.fixture(scope="module")
def reference_run():
    smp = _grid()
    return smp, _run(smp)


def _complete_dir(tmp_path, smp):
    res = _run(smp, tmp_path)
    assert (res.chunks_computed, res.chunks_resumed) == (6, 0)
    return tmp_path / "chunks"


# ---------------------------------------------------------------------------------------------
# Item 1: references are parsed by a whitelist, never evaluated


MALICIOUS = [
    '__import__("os").system("touch {marker}")',
    '__import__("os").system("touch {marker}") or t',
    "exec(\"open('{marker}', 'w')\")",
    "eval(\"__import__('os').system('touch {marker}')\")",
    "(lambda: __import__('os').system('touch {marker}'))()",
    "t.__class__.__mro__",
    "sin.__globals__",
    "[c for c in ().__class__.__base__.__subclasses__()]",
    "Symbol('x')",
    "sympy.sin(t)",
    "open('{marker}', 'w')",
]


@pytest.mark.parametrize("template", MALICIOUS)
def test_reference_never_executes(template, tmp_path):
    marker = tmp_path / "F"
    text = template.format(marker=marker)
    with pytest.raises(RoaInputError, match=r"^reference: .*allowed: numbers, t"):
        make_reference(text)
    with pytest.raises(RoaInputError, match="reference"):
        ipc.closed_loop(reference=text)  # the path of an experiment TOML's reference
    assert not marker.exists()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("sin(x)", "unknown symbols"),
        ("t.real", "attribute access"),
        ("f(t)", "not an allowed function"),
        ("sin(t, 2)", "exactly one argument"),
        ("t if t else 1", "if-else"),
        ("9**9**9", "exponent"),
        ("(10**100)**100*((10**100)**100)**5", "above 1e300"),
        ("1/0", "not a real, finite"),
        ("sqrt(-1)", "not a real, finite"),
        ("1e400*t", "not finite"),
        ("log(t)", "not a finite real number at t = 0"),
        ("sqrt(t)", "derivative of order 1"),
        ("t;1", "not an expression"),
        ("-" * 2000 + "t", "longer than"),
        ("sin:a,b", "two numbers"),
        ("sin:1", "amplitude and a frequency"),
    ],
)
def test_reference_rejections_name_the_argument(text, message):
    t0 = time.perf_counter()
    with pytest.raises(RoaInputError, match="reference") as info:
        make_reference(text)
    assert message in str(info.value)
    assert time.perf_counter() - t0 < 5  # no runaway exact arithmetic


def test_reference_valid_expressions_keep_exact_derivatives():
    t = np.linspace(0, 10, 17)
    for expr in ("2*sin(t/2)", "2*sin(t / 2)", "2 * sin(0.5*t)"):
        got = ExpressionReference(expr).derivatives(t)
        for a, b in zip(got, SineReference(2.0, 0.5).derivatives(t), strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-14)
    sine = make_reference("sin:0.5,1.3")
    assert isinstance(sine, SineReference) and (sine.amplitude, sine.omega) == (0.5, 1.3)
    # the whole whitelist, ^ as a power with the precedence of **, constants pi and E
    ref = make_reference(
        "t^2/(1+t**2) + exp(-t)*cos(pi*t) + E*sin(t) - tan(t/9) + log(1+t) + sqrt(1+t) "
        "+ atan(t) + sinh(t/3) + cosh(t/3) + tanh(t) + abs(t-1)"
    )
    x = 0.3
    d = [float(np.asarray(v)) for v in ref.derivatives(x)]
    f = (x**2 / (1 + x**2) + np.exp(-x) * np.cos(np.pi * x) + np.e * np.sin(x) - np.tan(x / 9)
         + np.log(1 + x) + np.sqrt(1 + x) + np.arctan(x) + np.sinh(x / 3) + np.cosh(x / 3)
         + np.tanh(x) + abs(x - 1))  # fmt: skip
    assert d[0] == pytest.approx(f, rel=1e-13)
    h = 1e-5  # the first derivative against a central difference
    fd = float(np.asarray(ref.derivatives(x + h)[0])) - float(np.asarray(ref.derivatives(x - h)[0]))
    assert d[1] == pytest.approx(fd / (2 * h), rel=1e-7)
    # |t - 1|: derivatives almost everywhere (sign, then 0)
    assert [float(np.asarray(v)) for v in make_reference("abs(t-1)").derivatives(2.0)] == [
        1.0, 1.0, 0.0, 0.0, 0.0
    ]  # fmt: skip


def test_cli_reference_is_an_input_error(tmp_path, capsys):
    from roa.cli import main

    marker = tmp_path / "F"
    assert main(["study", "ipc", "simulate", "--ic", "0,0,1,0", "--reference",
                 f'__import__("os").system("touch {marker}")']) == 2  # fmt: skip
    assert "reference: cannot use" in capsys.readouterr().err
    assert not marker.exists()
    assert main(["study", "ipc", "simulate", "--ic", "0,0,1,0", "--reference", "1/0"]) == 2


# ---------------------------------------------------------------------------------------------
# Item 3: each chunk is bound to its run, its rows and its contents


def test_chunk_files_carry_a_binding(tmp_path, reference_run):
    smp, ref = reference_run
    chunks = _complete_dir(tmp_path, smp)
    with np.load(chunks / "chunk_000000000005.npz") as z:
        binding = json.loads(str(z["binding"].item()))
        code, t_end = z["code"], z["t_end"]
    run = json.loads((chunks / "run.json").read_text())["fingerprint"]
    assert binding["run"] == run and (binding["start"], binding["length"]) == (5, 5)
    assert binding["sha256"] == engine.chunk_digest(run, 5, code, t_end)
    np.testing.assert_array_equal(code, ref.code[5:10])
    again = _run(smp, tmp_path)
    assert (again.chunks_resumed, again.chunks_computed, again.meta["chunks_rejected"]) == (6, 0, 0)
    np.testing.assert_array_equal(again.code, ref.code)


def test_rewritten_chunk_is_recomputed(tmp_path, reference_run):
    smp, ref = reference_run
    chunks = _complete_dir(tmp_path, smp)
    # a plain rewrite (no binding), as in the issue: every run "converged"
    np.savez(chunks / "chunk_000000000000.npz", code=np.zeros(5, np.int8),
             t_end=np.zeros(5, np.float32))  # fmt: skip
    # a rewrite that keeps the old binding but changes one status
    p = chunks / "chunk_000000000010.npz"
    with np.load(p) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["code"] = arrays["code"].copy()
    arrays["code"][0] = (arrays["code"][0] + 1) % 4
    np.savez(p, **arrays)
    with pytest.warns(ChunkRejectedWarning, match="2 chunk file"):
        res = run_basin(SYSTEM, smp, rules=RULES, n_jobs=1, chunk_size=CHUNK, out_dir=tmp_path)
    assert (res.chunks_resumed, res.chunks_computed, res.meta["chunks_rejected"]) == (4, 2, 2)
    assert set(res.meta["chunks_rejected_reasons"]) == {
        "no binding (older format or written by hand)",
        "checksum mismatch (contents changed)",
    }
    np.testing.assert_array_equal(res.code, ref.code)
    np.testing.assert_array_equal(res.t_end, ref.t_end)
    assert _run(smp, tmp_path).chunks_resumed == 6  # the recomputed chunks are bound again


def test_unknown_codes_never_counted(tmp_path, reference_run):
    smp, ref = reference_run
    chunks = _complete_dir(tmp_path, smp)
    run = json.loads((chunks / "run.json").read_text())["fingerprint"]
    # even with a correctly recomputed checksum, codes outside the known statuses are refused
    engine.save_chunk(chunks / "chunk_000000000015.npz", run, 15, np.full(5, 7, np.int8),
                       np.ones(5, np.float32))  # fmt: skip
    res = _run(smp, tmp_path, expect_rejections=True)
    assert res.meta["chunks_rejected_reasons"] == {"unknown status codes": 1}
    np.testing.assert_array_equal(res.code, ref.code)
    assert sum(res.counts().values()) == res.n == 30
    bad = BasinRun(np.array([0, 1, 7], np.int8), np.zeros(3, np.float32))
    with pytest.raises(ResultsError, match="unknown status code"):
        bad.counts()


@pytest.mark.parametrize("keep", [0, 10, 200])
def test_truncated_or_corrupt_chunk_is_recomputed(tmp_path, reference_run, keep):
    smp, ref = reference_run
    chunks = _complete_dir(tmp_path, smp)
    p = chunks / "chunk_000000000020.npz"
    p.write_bytes(p.read_bytes()[:keep])  # no BadZipFile traceback
    res = _run(smp, tmp_path, expect_rejections=True)
    assert res.meta["chunks_rejected_reasons"] == {"unreadable (truncated or corrupt)": 1}
    assert (res.chunks_resumed, res.chunks_computed) == (5, 1)
    np.testing.assert_array_equal(res.code, ref.code)


def test_chunk_of_another_run_or_place_is_recomputed(tmp_path, reference_run):
    smp, ref = reference_run
    other = _grid(lo=-2.0)
    chunks = _complete_dir(tmp_path / "a", smp)
    other_chunks = _complete_dir(tmp_path / "b", other)
    shutil.copy(other_chunks / "chunk_000000000005.npz", chunks / "chunk_000000000005.npz")
    shutil.copy(chunks / "chunk_000000000000.npz", chunks / "chunk_000000000025.npz")
    shutil.copy(chunks / "chunk_000000000000.npz", chunks / "chunk_000000000003.npz")
    res = _run(smp, tmp_path / "a", expect_rejections=True)
    assert res.meta["chunks_rejected"] == 3
    assert res.meta["chunks_rejected_reasons"]["bound to another run"] == 1
    assert (res.chunks_resumed, res.chunks_computed) == (4, 2)
    np.testing.assert_array_equal(res.code, ref.code)
    assert not (chunks / "chunk_000000000003.npz").exists()  # a stray file is removed


def test_deleted_run_json_does_not_let_another_run_reuse_chunks(tmp_path, reference_run):
    smp, _ = reference_run
    chunks = _complete_dir(tmp_path, smp)
    (chunks / "run.json").unlink()
    other = _grid(lo=-2.0)  # same size and chunking, other samples
    with pytest.raises(ResultsError, match="another run") as info:
        _run(other, tmp_path)
    assert str(chunks) in str(info.value) and "fresh=True" in str(info.value)
    assert len(list(chunks.glob("chunk_*.npz"))) == 6  # refused: nothing was touched
    # the same run resumes from the chunks' own bindings; a corrupt run.json is no different
    assert _run(smp, tmp_path).chunks_resumed == 6
    (chunks / "run.json").write_text("{not json")
    assert _run(smp, tmp_path).chunks_resumed == 6


def test_fresh_recomputes_everything(tmp_path, reference_run):
    smp, ref = reference_run
    chunks = _complete_dir(tmp_path, smp)
    other = _grid(lo=-2.0)
    with pytest.raises(ResultsError, match="different run"):
        _run(other, tmp_path)
    forced = _run(other, tmp_path, fresh=True)
    assert (forced.chunks_resumed, forced.chunks_computed) == (0, 6)
    np.testing.assert_array_equal(forced.code, _run(other).code)
    again = _run(smp, tmp_path, fresh=True)  # also for the directory's own run
    assert (again.chunks_resumed, again.chunks_computed) == (0, 6)
    np.testing.assert_array_equal(again.code, ref.code)
    assert len(list(chunks.glob("chunk_*.npz"))) == 6


def test_unwritable_out_dir_is_an_input_error(tmp_path, reference_run):
    smp, _ = reference_run
    (tmp_path / "file").write_text("x")
    with pytest.raises(RoaInputError, match="out_dir: cannot create"):
        _run(smp, tmp_path / "file")


# ---------------------------------------------------------------------------------------------
# Item 6: bounded resources


def test_jobs_bounded_and_capped_to_tasks():
    cores = os.cpu_count() or 1
    smp = grid_slice(SYSTEM, ("x1", "x2"), [(-1, 1), (-1, 1)], (3, 3))
    with pytest.raises(RoaInputError, match=r"n_jobs must be at most 4 x"):
        run_basin(SYSTEM, smp, rules=RULES, n_jobs=4 * cores + 1)
    with pytest.raises(RoaInputError, match="n_jobs"):
        run_basin(SYSTEM, smp, rules=RULES, n_jobs=0)
    with pytest.raises(RoaInputError, match="chunk_size"):
        run_basin(SYSTEM, smp, rules=RULES, chunk_size=0)
    before = _children()
    res = run_basin(SYSTEM, smp, rules=RULES, n_jobs=4 * cores)  # one task: stays in-process
    assert res.meta["n_jobs_used"] == 1
    assert _children() <= before


def _children() -> int:
    try:
        import psutil
    except ImportError:  # pragma: no cover
        return 0
    return len(psutil.Process().children(recursive=True))


def test_huge_sample_counts_fail_fast_without_allocation(capsys):
    tracemalloc.start()
    t0 = time.perf_counter()
    with pytest.raises(RoaInputError, match=r"samples \(n\) must be in \[1, 1e\+09\]"):
        box_sample(SYSTEM, [(-1, 1), (-1, 1)], 10**12, seed=0)
    with pytest.raises(RoaInputError, match="1e\\+09"):
        box_sample(SYSTEM, [(-1, 1), (-1, 1)], 1e12, seed=0)

    class Huge:  # a custom sampler: the engine checks n itself, before allocating anything
        n = 10**12

        def points(self, a, b):  # pragma: no cover
            raise AssertionError

        def fingerprint(self):  # pragma: no cover
            return {}

    with pytest.raises(RoaInputError, match=r"sampler.n .* must be in \[0, 1e\+09\]"):
        run_basin(SYSTEM, Huge(), rules=RULES, n_jobs=1)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert time.perf_counter() - t0 < 2 and peak < 50 * 2**20
    assert MAX_SAMPLES == 10**9
    from roa.cli import main

    box = "x1=-1:1,x2=-1:1"
    assert main(["basin", "--system", "vanderpol", "--samples", str(10**12), "--box", box]) == 2
    assert "1e+09" in capsys.readouterr().err


def test_chunk_starts_are_lazy():
    pending = engine._pending(10**15, 4096, {0, 4096})
    assert iter(pending) is pending  # a generator, not a list of 2.4e11 starts
    assert [next(pending) for _ in range(2)] == [8192, 12288]


# ---------------------------------------------------------------------------------------------
# Item 7: Dask connections are bounded and end with a roa error or quietly


@pytest.fixture
def mute_scheduler():
    """A TCP port that accepts connections and never answers."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    conns: list[socket.socket] = []
    stop = threading.Event()

    def accept() -> None:
        srv.settimeout(0.2)
        while not stop.is_set():
            try:
                conns.append(srv.accept()[0])
            except OSError:
                continue

    th = threading.Thread(target=accept, daemon=True)
    th.start()
    yield f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    stop.set()
    th.join(2)
    for c in conns:
        c.close()
    srv.close()


def test_dask_mute_scheduler_times_out(mute_scheduler):
    smp = grid_slice(SYSTEM, ("x1", "x2"), [(-1, 1), (-1, 1)], (3, 3))
    t0 = time.perf_counter()
    with pytest.raises(SolverError, match="no answer from a Dask scheduler") as info:
        run_basin(SYSTEM, smp, rules=RULES, scheduler=mute_scheduler, scheduler_timeout=1.0)
    assert mute_scheduler in str(info.value)
    assert time.perf_counter() - t0 < 8


def test_dask_refused_and_malformed_addresses():
    smp = grid_slice(SYSTEM, ("x1", "x2"), [(-1, 1), (-1, 1)], (3, 3))
    s = socket.socket()
    s.bind(("127.0.0.1", 0))  # bound, not listening: connections are refused
    addr = f"tcp://127.0.0.1:{s.getsockname()[1]}"
    try:
        t0 = time.perf_counter()
        with pytest.raises(SolverError, match="cannot connect to a Dask scheduler"):
            run_basin(SYSTEM, smp, rules=RULES, scheduler=addr, scheduler_timeout=1.0)
        assert time.perf_counter() - t0 < 8
    finally:
        s.close()
    with pytest.raises(RoaInputError, match="scheduler"):
        run_basin(SYSTEM, smp, rules=RULES, scheduler="nonsense://x", scheduler_timeout=1.0)
    with pytest.raises(RoaInputError, match="scheduler_timeout"):
        run_basin(SYSTEM, smp, rules=RULES, scheduler=addr, scheduler_timeout=0)


def test_dask_without_workers_and_interrupted(capfd):
    from dask.distributed import LocalCluster

    smp = grid_slice(SYSTEM, ("x1", "x2"), [(-1, 1), (-1, 1)], (4, 4))
    with LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        t0 = time.perf_counter()
        with pytest.raises(SolverError, match="no worker joined within 1 s") as info:
            run_basin(SYSTEM, smp, rules=RULES, scheduler=cluster.scheduler_address,
                      scheduler_timeout=1.0)  # fmt: skip
        assert f"dask worker {cluster.scheduler_address}" in str(info.value)
        assert time.perf_counter() - t0 < 8
    ref = run_basin(SYSTEM, smp, rules=RULES, n_jobs=1)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster:  # fmt: skip
        capfd.readouterr()
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # e.g. joblib's "tasks ... have been cancelled"
            with pytest.raises(KeyboardInterrupt):  # Ctrl-C while connected
                run_basin(SYSTEM, smp, rules=RULES, chunk_size=2, scheduler=cluster.scheduler_address,
                          scheduler_timeout=5.0, _stop_after=1)  # fmt: skip
        time.sleep(0.5)
        err = capfd.readouterr().err
        assert "CommClosedError" not in err and "Traceback" not in err
        got = run_basin(SYSTEM, smp, rules=RULES, chunk_size=3,
                        scheduler=cluster.scheduler_address, scheduler_timeout=5.0)  # fmt: skip
    np.testing.assert_array_equal(got.code, ref.code)
    assert got.counts() == ref.counts()


def test_basin_out_never_overwrites_an_experiments_results(tmp_path, capsys):
    """Issue 12 item 2: `roa basin --out results/NAME` must not replace committed results."""
    from roa.cli import main

    exp = tmp_path / "basin_theta_thetadot"
    exp.mkdir()
    (exp / "manifest.json").write_text('{"experiment": "basin_theta_thetadot"}')
    (exp / "summary.json").write_text('{"experiment": "basin_theta_thetadot"}')
    argv = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "3x3", "--jobs", "1",
            "--out", str(exp)]  # fmt: skip
    assert main(argv) == 2
    assert "holds the results of an experiment" in capsys.readouterr().err
    assert (exp / "summary.json").read_text() == '{"experiment": "basin_theta_thetadot"}'
    other = tmp_path / "notes"
    other.mkdir()
    (other / "paper.txt").write_text("x")
    assert main([*argv[:-1], str(other)]) == 2
    fresh = tmp_path / "run"
    assert main([*argv[:-1], str(fresh)]) == 0 and (fresh / "summary.json").is_file()
    assert main([*argv[:-1], str(fresh), "--force"]) == 0  # a previous basin run may be reused


def test_search_cache_rejects_an_edited_entry(tmp_path):
    """Issue 12 item 4: a replaced P in the search cache is recomputed, never used silently."""
    import json

    from roa.search._cache import SearchCache

    path = tmp_path / "cache.json"
    cache = SearchCache(path)
    key = {"system": "toy", "objective": "box"}
    result, hit = cache.get(key, lambda: {"P": [[1.0, 0.0], [0.0, 1.0]]})
    assert not hit
    cache.save()
    again = SearchCache(path)
    assert again.get(key, lambda: 1 / 0) == ({"P": [[1.0, 0.0], [0.0, 1.0]]}, True)
    data = json.loads(path.read_text())
    (entry,) = data.values()
    entry["result"]["P"] = [[9.0, 0.0], [0.0, 9.0]]  # tampered candidate
    path.write_text(json.dumps(data))
    edited = SearchCache(path)
    result, hit = edited.get(key, lambda: {"P": [[2.0, 0.0], [0.0, 2.0]]})
    assert not hit and result == {"P": [[2.0, 0.0], [0.0, 2.0]]} and edited.rejected == 1
