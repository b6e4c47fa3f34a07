"""No traceback for any input (reliability issue, item 7, the inputs this module covers): each bad
input exits 2 with a message naming it; a Hypothesis fuzz of the certificate reader asserts
"valid result or RoaInputError" for any JSON-like object.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import roa
import roa.io
from roa.certification import Certificate
from roa.cli import main
from roa.errors import RoaInputError
from roa.systems.vanderpol import vanderpol

ROOT = Path(__file__).resolve().parents[2]


def _files(tmp_path):
    files = {
        "badcoef.json": json.dumps({"monomials": [[2, 0], [0, 2]], "coefficients": ["a", 1]}),
        "nested.json": "[" * 100_000 + "]" * 100_000,
        "nonutf.json": b"\xff\xfe{",
        "truncated.npy": b"X",
    }
    for name, data in files.items():
        path = tmp_path / name
        path.write_bytes(data if isinstance(data, bytes) else data.encode())
    (tmp_path / "npsin.py").write_text(
        "import numpy as np\nfrom roa import System\n"
        "def field(t, x, xp):\n    return (-x[1], np.sin(x[0]) + (x[0] ** 2 - 1) * x[1])\n"
        "SYSTEM = System(name='npsin', field=field, equilibrium=(0.0, 0.0), state_names=('x1', 'x2'))\n"
    )
    (tmp_path / "raiser.py").write_text(
        "import numpy as np\nfrom roa import System\n"
        "def field(t, x, xp):\n"
        "    if np.any(np.abs(np.asarray(x[0], dtype=float)) > 1.0):\n"
        "        raise ValueError('boom')\n"
        "    return (-x[1], x[0] + (x[0] ** 2 - 1) * x[1])\n"
        "SYSTEM = System(name='raiser', field=field, equilibrium=(0.0, 0.0), state_names=('x1', 'x2'))\n"
    )
    for name, runner in (
        ("missing", "ipc_paper.nonexistent:run"),
        ("dots", "ipc_paper..figures:run_figure1"),
    ):
        (tmp_path / f"{name}.toml").write_text(f'runner = "{runner}"\n')
    (tmp_path / "bigbound.toml").write_text(  # n_points = 2^63 - 1: numpy's "array is too big"
        'runner = "ipc_paper.lyapunov_report:run_bound"\n[params]\nn_points = 9223372036854775807\n'
    )
    (tmp_path / "bigseed.toml").write_text(
        'runner = "ipc_paper.basins:run_box"\n[params]\nsamples = 10\nseed = 18446744073709551616\n'
    )
    (tmp_path / "empty.npy").write_bytes(b"")
    (tmp_path / "tv.py").write_text(  # declared time-varying: no equilibrium analysis applies
        "from roa import System\n"
        "def field(t, x, xp):\n    return (-x[1] + 0.1 * t * x[0], x[0] - x[1])\n"
        "SYSTEM = System(name='tv', field=field, equilibrium=(0.0, 0.0), state_names=('x1', 'x2'),"
        " time_varying=True)\n"
    )
    np.save(tmp_path / "str.npy", np.array(["a", "b"]))
    np.save(tmp_path / "obj.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    return tmp_path


CASES = [
    (["certify", "--system", "vanderpol", "--lyapunov", "{d}/badcoef.json", "--level", "1"], "--lyapunov"),
    (["certify", "--system", "vanderpol", "--lyapunov", "{d}/nested.json", "--level", "1"], "--lyapunov"),
    (["certify", "--system", "vanderpol", "--lyapunov", "{d}/nonutf.json", "--level", "1"], "--lyapunov"),
    (["certify", "--system", "vanderpol", "--lyapunov", "{d}/str.npy", "--level", "1"], "--lyapunov"),
    (["certify", "--system", "vanderpol", "--lyapunov", "{d}/obj.npy", "--level", "1"], "--lyapunov"),
    (["certify", "--system", "vanderpol", "--lyapunov", "{d}/truncated.npy", "--level", "1"], "--lyapunov"),
    (["basin", "--system", "vanderpol", "--samples", "10", "--box", "x1=-1:1,x2=-1:1", "--seed", "-1"], "seed"),
    (["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "4x4", "--plot", "{d}"], "--plot"),
    (["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "4x4", "--plot", "{d}/a.xyz"], "--plot"),
    (["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "4x4", "--terminal-set", "{d}/nested.json"], "--terminal-set"),
    (["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "4x4", "--terminal-set", "{d}/nonutf.json"], "--terminal-set"),
    (["simulate", "--system", "vanderpol", "--x0", "0.1,0.1", "--plot", "{d}/dir.png"], "--plot"),
    (["certify", "--system", "{d}/npsin.py:SYSTEM", "--level", "1"], "npsin.py:4"),
    (["simulate", "--system", "{d}/raiser.py:SYSTEM", "--x0", "2,0"], "raiser.py:5"),
    (["basin", "--system", "{d}/raiser.py:SYSTEM", "--slice", "x1,x2", "--grid", "4x4", "--box", "x1=-3:3,x2=-3:3", "--jobs", "1"], "raiser.py:5"),
    (["run", "{d}/missing.toml"], "ipc_paper.nonexistent"),
    (["run", "{d}/dots.toml"], "runner must be"),
    (["khalil", "--system", "{d}/tv.py:SYSTEM"], "time-varying"),
    (["certify", "--system", "{d}/tv.py:SYSTEM", "--level", "1"], "autonomous"),
    (["basin", "--system", "{d}/tv.py:SYSTEM", "--slice", "x1,x2", "--grid", "3x3"], "autonomous"),
    (["run", "{d}/bigbound.toml"], "n_points must be an integer in [1, 10000000]"),
    (["run", "{d}/bigseed.toml"], "seed must be an integer in [0, 9223372036854775807]"),
    (["certify", "--system", "vanderpol", "--lyapunov", "{d}/empty.npy", "--level", "1"], "--lyapunov"),
]  # fmt: skip


@pytest.mark.parametrize("argv, names", CASES, ids=[" ".join(c[0][:1] + c[0][-2:]) for c in CASES])
def test_bad_input_exits_2_naming_it(tmp_path, capsys, argv, names):
    d = _files(tmp_path)
    (d / "dir.png").mkdir()
    assert main([a.format(d=d) for a in argv]) == 2
    err = capsys.readouterr().err
    assert names in err and "Traceback" not in err


def test_a_plot_never_replaces_a_non_regular_file(tmp_path):
    target = tmp_path / "fifo.png"
    import os

    os.mkfifo(target)
    with pytest.raises(RoaInputError, match="not a regular file"):
        roa.io.check_figure_path(target)
    assert target.exists() and not target.is_file()


JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=True) | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=12), inner, max_size=5),
    max_leaves=20,
)  # fmt: skip
KEYS = st.fixed_dictionaries(
    {},
    optional={"status": st.sampled_from(["certified", "refuted", "x"]) | JSON,
              "level": st.floats(allow_nan=True, allow_infinity=True) | JSON,
              "system": st.just("vanderpol") | JSON,
              "P": st.just([[1.5, -0.5], [-0.5, 1.0]]) | JSON,
              "candidate_kind": JSON, "system_fingerprint": JSON, "lyapunov": JSON},
)  # fmt: skip


@settings(
    derandomize=True, max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
@given(KEYS)
def test_certificate_reader_gives_a_claim_or_an_input_error(data):
    try:
        claim = Certificate.from_dict(data, vanderpol())
    except RoaInputError:
        return
    assert claim.level is not None and np.isfinite(claim.level) and claim.level > 0
    assert claim.V is not None and claim.V.n == 2


def test_an_order_that_is_no_integer_names_itself(tmp_path, capsys):
    cfg = tmp_path / "ord.toml"
    runner = next(
        line.split('"')[1]
        for line in (ROOT / "experiments" / "bound.toml").read_text().splitlines()
        if line.startswith("runner")
    )
    cfg.write_text(f'runner = "{runner}"\norder = "abc"\n')
    assert main(["run", str(cfg), "--results", str(tmp_path / "r")]) == 2
    assert "order must be an integer" in capsys.readouterr().err


@pytest.mark.parametrize("content", [b"\xff", b"[]", b"[" * 50_000])
def test_a_broken_manifest_is_named_not_a_traceback(tmp_path, capsys, content):
    import shutil

    results = tmp_path / "r"
    shutil.copytree(ROOT / "results", results)
    (results / "bound" / "manifest.json").write_bytes(content)
    assert main(["report", "--results", str(results), "--out", str(tmp_path / "x.md")]) == 1
    err = capsys.readouterr().err
    assert "bound/manifest.json" in err and "Traceback" not in err


@pytest.mark.parametrize("value", ["x", None, "missing"])
def test_a_stored_reference_value_that_is_no_number_is_named(tmp_path, capsys, value):
    data = json.loads((ROOT / "results" / "reference.json").read_text())
    key = "vanderpol.level.casadi"
    if value == "missing":
        del data[key]["value"]
    else:
        data[key]["value"] = value
    ref = tmp_path / "reference.json"
    ref.write_text(json.dumps(data))
    assert main(["check", "--only", key, "--reference", str(ref)]) == 1
    out = capsys.readouterr()
    assert key in out.out + out.err and "Traceback" not in out.err


def test_out_is_refused_inside_or_above_experiment_results(tmp_path, capsys):
    import shutil

    results = tmp_path / "results"
    shutil.copytree(ROOT / "results" / "bound", results / "bound")
    base = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "3x3", "--jobs", "1"]
    for out in (results / "bound" / "sub", results / "bound" / "chunks" / "x", results):
        assert main([*base, "--out", str(out)]) == 2
        assert "--out" in capsys.readouterr().err
        assert not (results / "bound" / "sub").exists()


def test_one_run_per_out_folder(tmp_path):
    from roa.io import folder_lock

    system = vanderpol()
    grid = roa.grid_slice(system, ("x1", "x2"), [(-1, 1), (-1, 1)], (3, 3))
    out = tmp_path / "run"
    with folder_lock(out / "chunks", "out_dir"):  # another run holds the folder
        with pytest.raises(RoaInputError, match="in use by another run"):
            roa.basin(system, grid, run=roa.RunOptions(n_jobs=1, out_dir=str(out)))
    res = roa.basin(system, grid, run=roa.RunOptions(n_jobs=1, out_dir=str(out)))
    assert res.n == 9  # free again once the other run ends


def test_a_failed_experiment_leaves_no_empty_results_folder(tmp_path):
    from roa.studies._experiment import run_experiment

    cfg = tmp_path / "bound.toml"
    text = (ROOT / "experiments" / "bound.toml").read_text()
    cfg.write_text(text.replace("[params]", "[params]\nbogus_param = 1", 1))
    with pytest.raises(RoaInputError):
        run_experiment(cfg, results=tmp_path / "r", quick=True)
    assert not (tmp_path / "r" / "bound").exists()


V_KEYS = st.fixed_dictionaries(
    {},
    optional={"P": JSON | st.just([[2.0, 0.5], [0.5, 1.0]]),
              "monomials": JSON | st.just([[2, 0], [0, 2], [4, 0]]),
              "coefficients": JSON | st.just([1.0, 1.0, 0.5]),
              "center": JSON, "lyapunov": JSON, "kind": JSON},
)  # fmt: skip


@settings(
    derandomize=True, max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
@given(JSON | V_KEYS | V_KEYS.map(lambda d: {"candidate_kind": d}) | V_KEYS.map(lambda d: {"V": d}))
def test_lyapunov_json_reader_gives_a_candidate_or_an_input_error(data):
    from roa.lyapunov import from_json

    try:
        V = from_json(data, [0.0, 0.0])
    except RoaInputError:
        return
    assert V.n >= 1 and np.all(np.isfinite(V.center))


@settings(
    derandomize=True, max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
@given(st.binary(max_size=300) | st.text(max_size=300).map(str.encode))
def test_config_reader_gives_a_config_or_an_input_error(tmp_path_factory, content):
    from roa.studies._experiment import load_config

    path = tmp_path_factory.mktemp("cfg") / "x.toml"
    path.write_bytes(content)
    try:
        cfg = load_config(path)
    except RoaInputError:
        return
    assert isinstance(cfg["runner"], str) and ":" in cfg["runner"]


@settings(
    derandomize=True, max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
@given(JSON.map(json.dumps).map(str.encode) | st.binary(max_size=200))
def test_reference_reader_gives_values_or_a_results_error(tmp_path_factory, content):
    from roa.errors import ResultsError
    from roa.studies._reference import load

    path = tmp_path_factory.mktemp("ref") / "reference.json"
    path.write_bytes(content)
    try:
        data = load(path)
    except ResultsError:
        return
    assert isinstance(data, dict)


@settings(
    derandomize=True, max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
@given(st.binary(max_size=400))
def test_npy_reader_gives_numbers_or_an_input_error(tmp_path_factory, content):
    from roa.commands._common import read_matrix

    path = tmp_path_factory.mktemp("npy") / "P.npy"
    path.write_bytes(b"\x93NUMPY" + content if content[:1] == b"\x01" else content)
    try:
        arr = read_matrix(str(path), what="--lyapunov")
    except RoaInputError:
        return
    assert arr.dtype.kind in "iuf"


def _huge_files(d: Path) -> Path:
    """Inputs of issue 38, items 6 and 7: huge numbers in every input format."""
    (d / "bigP.json").write_text(json.dumps([[int("9" * 4000), 0], [0, 1]]))
    (d / "bigcoef.json").write_text(
        '{"monomials": [[2, 0], [0, 2]], "coefficients": [' + "9" * 5000 + ", 1]}"
    )
    (d / "denP.json").write_text(json.dumps([[1e-320, 0], [0, 1e-320]]))
    (d / "hugeP.json").write_text(json.dumps([[1e300, 0], [0, 1e300]]))
    np.save(d / "denP.npy", np.diag([1e-320, 1e-320]))
    (d / "big.toml").write_text(
        'runner = "ipc_paper.basins:run_box"\n[params]\nsamples = ' + "1" * 5001 + "\n"
    )
    (d / "bigfloat.toml").write_text(
        'runner = "ipc_paper.basins:run_box"\n[params]\nsamples = 10\nseed = 1\nx = 1e999\n'
    )
    (d / "bigbound4000.toml").write_text(
        'runner = "ipc_paper.lyapunov_report:run_bound"\n[params]\nn_points = ' + "9" * 4000 + "\n"
    )
    return d


GRID = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--jobs", "1"]
HUGE = [
    (["basin", "--system", "vanderpol", "--param", "mu=1e308..1.7e308..1.79e308", "--samples", "4",
      "--box", "x1=-1:1,x2=-1:1", "--jobs", "1"], "System.parameters['mu']"),
    (["certify", "--system", "vanderpol", "--param", "mu=1e308..1.7e308..1.79e308", "--level", "1"],
     "--param mu=1e308..1.7e308..1.79e308"),
    (["khalil", "--system", "vanderpol", "--param", "mu=1e308..1.7e308..1.79e308"], "'mu'"),
    (["khalil", "--system", "vanderpol", "--param", "mu=1e200"], "'mu'"),
    (["certify", "--system", "vanderpol", "--param", "mu= 1 .. 2 ", "--level", "1"], "--param mu= 1 .. 2"),
    (["certify", "--system", "vanderpol", "--param", "mu=1_0..2", "--level", "1"], "--param mu=1_0..2"),
    (["khalil", "--system", "vanderpol", "--lyapunov", "{d}/bigP.json"], "--lyapunov"),
    (["certify", "--system", "vanderpol", "--lyapunov", "{d}/bigP.json", "--level", "1"], "--lyapunov"),
    (["certify", "--system", "vanderpol", "--lyapunov", "{d}/bigcoef.json", "--level", "1"], "--lyapunov"),
    (["certify", "--system", "vanderpol", "--lyapunov", "{d}/denP.json", "--method", "sos"], "subnormal"),
    (["certify", "--system", "vanderpol", "--lyapunov", "{d}/denP.npy", "--method", "sos"], "subnormal"),
    (["certify", "--system", "vanderpol", "--lyapunov", "{d}/hugeP.json", "--method", "sos"], "--lyapunov"),
    (["run", "{d}/big.toml"], "big.toml"),
    (["run", "{d}/bigfloat.toml"], "bigfloat.toml"),
    (["run", "{d}/bigbound4000.toml"], "n_points"),
    (GRID + ["--grid", "1" * 5000 + "x4"], "--grid"),
    (GRID + ["--grid", "\u0664x4"], "--grid"),  # an Arabic-Indic digit: not ASCII
    (["certify", "--system", "vanderpol", "--level", "1.7976931348623157e308"], "--level"),
    (["certify", "--system", "vanderpol", "--level", "1" * 5000], "--level"),
    (GRID + ["--grid", "4x4", "--lyapunov-level", "1e308", "--plot", "{d}/a.png"], "--lyapunov-level"),
]  # fmt: skip


@pytest.mark.parametrize("argv, names", HUGE, ids=[" ".join(c[0][-2:])[:60] for c in HUGE])
def test_huge_numbers_exit_2_naming_the_input(tmp_path, capsys, argv, names):
    import signal

    def hang(signum, frame):  # noqa: ANN001
        raise TimeoutError("a bad input ran for more than 60 s")

    d = _huge_files(tmp_path)
    old = signal.signal(signal.SIGALRM, hang)
    signal.alarm(60)
    try:
        rc = main([a.format(d=d) for a in argv])
    except SystemExit as exc:  # argparse's usage errors
        rc = exc.code
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    err = capsys.readouterr().err
    assert rc == 2, err
    assert names in err and "Traceback" not in err, err
    assert len(err.strip().splitlines()[-1]) < 400, err  # one line, the huge value shortened


def _field_files(d: Path) -> Path:
    """Fields of issue 38, items 4 and 5: numpy functions on the states, huge degrees and sizes."""
    head = "import numpy as np\nfrom roa import System\n"
    tail = (
        "SYSTEM = System(name='f', field=field, equilibrium=(0.0, 0.0), state_names=('x1', 'x2'))\n"
    )
    bodies = {
        "atan2": "    return (-x[1], np.arctan2(x[0], 1.0 + x[1]) + (x[0] ** 2 - 1) * x[1])\n",
        "hypot": "    return (-x[1], -x[0] + 0.1 * np.hypot(x[0], x[1]))\n",
        "objarr": "    return (-x[1], -np.tanh(np.array([x[0]]))[0] - x[1])\n",
        "bigpow": "    return (-x[1], x[0] - x[1] + x[0] ** 1000000001)\n",
        "hugepow": "    return (-x[1], x[0] - x[1] + x[0] ** (2 ** 70))\n",
        "manyops": "    e = 0.0\n    for k in range(10 ** 4):\n        e = e + 1e-9 * x[0] ** 3 * x[1]\n"
                   "    return (-x[1], x[0] - x[1] + e)\n",
    }  # fmt: skip
    for name, body in bodies.items():
        (d / f"{name}.py").write_text(head + "def field(t, x, xp):\n" + body + tail)
    sym = ("import sympy as sp\nfrom roa import System\nx1, x2 = sp.symbols('x1 x2')\n"
           "SYSTEM = System.from_sympy([-x2, x1 - x2 + {}], [x1, x2], name='s')\n")  # fmt: skip
    (d / "sympow9.py").write_text(sym.format("x1**(10**9)"))
    (d / "sympow70.py").write_text(sym.format("x1**(2**70)"))
    (d / "symterms.py").write_text(
        sym.format(
            "sp.Add(*[sp.Rational(k + 1, 10**6) * x1**(k % 100) * x2**(k // 100) "
            "for k in range(10**4)])"
        )  # fmt: skip
    )
    return d


FIELDS = [
    (["certify", "--system", "{d}/atan2.py:SYSTEM"], "atan2.py:4", "np.arctan2"),
    (["certify", "--system", "{d}/atan2.py:SYSTEM", "--validator", "sos"], "atan2.py:4", "np.arctan2"),
    (["certify", "--system", "{d}/hypot.py:SYSTEM"], "hypot.py:4", "np.hypot"),
    (["certify", "--system", "{d}/hypot.py:SYSTEM", "--validator", "sos"], "hypot.py:4", "np.hypot"),
    (["khalil", "--system", "{d}/hypot.py:SYSTEM"], "hypot.py:4", "np.hypot"),
    (["certify", "--system", "{d}/objarr.py:SYSTEM", "--level", "0.5"], "objarr.py:4", "tanh"),
    (["certify", "--system", "{d}/bigpow.py:SYSTEM", "--time-limit", "5"], "bigpow.py:4", "exponent 1000000001"),
    (["simulate", "--system", "{d}/bigpow.py:SYSTEM", "--x0", "0.1,0"], "bigpow.py:4", "up to 100"),
    (["certify", "--system", "{d}/hugepow.py:SYSTEM"], "hugepow.py:4", "exponent 1180591620717411303424"),
    (["certify", "--system", "{d}/manyops.py:SYSTEM"], "manyops.py", "operations"),
    (["certify", "--system", "{d}/sympow9.py:SYSTEM", "--time-limit", "5"], "sympow9.py", "exponent 1000000000"),
    (["certify", "--system", "{d}/sympow70.py:SYSTEM"], "sympow70.py", "up to 100"),
    (["certify", "--system", "{d}/symterms.py:SYSTEM"], "symterms.py", "more than 5000"),
]  # fmt: skip


@pytest.mark.parametrize("argv, where, what", FIELDS, ids=[c[0][2].split("/")[-1] + " " + c[0][0]
                                                          + " " + c[0][-1] for c in FIELDS])  # fmt: skip
def test_unsupported_or_huge_fields_exit_2_naming_file_line_and_term(tmp_path, capsys, argv,
                                                                     where, what):  # fmt: skip
    import signal
    import time

    def hang(signum, frame):  # noqa: ANN001
        raise TimeoutError("a bad field ran for more than 60 s")

    d = _field_files(tmp_path)
    old = signal.signal(signal.SIGALRM, hang)
    signal.alarm(60)
    t0 = time.monotonic()
    try:
        rc = main([a.format(d=d) for a in argv])
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    err = capsys.readouterr().err
    assert rc == 2 and time.monotonic() - t0 < 30, err
    assert where in err and what in err and "Traceback" not in err, err


def test_a_numpy_function_on_the_states_is_refused_for_proofs_only():
    """The numpy-only analyses keep a field written with numpy (a fallback kernel, no proof)."""
    from roa.model._checks import check_functions, check_system

    system = roa.System(name="np-hypot", field=lambda t, x, xp: (-x[0] + 0.1 * np.hypot(x[0], x[1]), -x[1]),
                        equilibrium=(0.0, 0.0), state_names=("a", "b"))  # fmt: skip
    check_system(system)  # the load-time check: numpy's functions are fine for simulation
    with pytest.raises(roa.SystemDefinitionError, match=r"np-hypot.*np\.hypot.*xp\.sin"):
        check_functions(system)
    with pytest.raises(roa.SystemDefinitionError, match=r"np\.hypot"):
        roa.certify(system, level=0.1)
    fine = roa.System(name="xp-only", field=lambda t, x, xp: (-x[0] + 0.1 * xp.sqrt(1 + x[1] ** 2), -x[1] ** 3 - x[1]),
                      equilibrium=(0.1, 0.0), state_names=("a", "b"))  # fmt: skip
    check_functions(fine)  # xp's functions, operators and powers up to MAX_POWER pass


def test_a_nonfinite_jacobian_is_named():
    from roa.model._linearisation import linearise

    system = roa.System(name="kink", field=lambda t, x, xp: (-x[0] + 0.1 * xp.sqrt(x[0] ** 2 + x[1] ** 2), -x[1]),
                        equilibrium=(0.0, 0.0), state_names=("a", "b"))  # fmt: skip
    with pytest.raises(RoaInputError, match=r"kink.*Jacobian.*not finite"):
        linearise(system)
