"""Hypothesis fuzz of every numeric CLI option (reliability issue, Deliver 5: "CLI numbers"): any
text given to a numeric option gives a result (exit 0 or 1 with its message) or exit 2 with a
message naming the option, never a traceback and never an exception out of ``main``.

Each command runs on a cheap base (a 3 x 3 grid, a wall-clock budget, a small box budget), so a
valid value ends quickly; a watchdog alarm turns a hang into a failure. Derandomized and bounded
(a fixed number of examples per command), part of the default suite.
"""

from __future__ import annotations

import os
import signal

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from roa.cli import main

#: Texts that broke parsers before (overflow, NaN, huge integers, underscores, hex, empty).
SPECIAL = st.sampled_from(
    ["nan", "-nan", "inf", "-inf", "1e308", "-1e308", "1e309", "0", "-0", "-1", "1e-320", "5e-324",
     "abc", "", " ", "1_000", "0x10", "9223372036854775808", "-9223372036854775809", "1e20", "2",
     "0.5", "3", "1e-9", "2**63", "1,2"]
)  # fmt: skip
NUMBER = (
    SPECIAL
    | st.integers(-(2**70), 2**70).map(str)
    | st.floats(allow_nan=True, allow_infinity=True).map(repr)
)

SIM = ["simulate", "--system", "vanderpol", "--x0", "0.5,0.5", "--time-limit", "2"]
GRID = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "3x3",
        "--box", "x1=-1:1,x2=-1:1", "--jobs", "1", "--t-final", "5", "--time-limit", "2"]  # fmt: skip
SAMPLES = ["basin", "--system", "vanderpol", "--box", "x1=-1:1,x2=-1:1", "--jobs", "1",
           "--t-final", "5", "--time-limit", "2"]  # fmt: skip
CERT = ["certify", "--system", "vanderpol", "--max-boxes", "3000"]
IPC = ["study", "ipc", "simulate", "--ic", "0.1,0,0.1,0", "--time-limit", "5"]
KHALIL = ["khalil", "--system", "vanderpol", "--method", "sampled", "--directions", "64"]

#: (base argv, option, how the fuzzed text is put into the option's value)
OPTIONS = [
    (SIM, "--t-final", "{}"), (SIM, "--converge-tol", "{}"), (SIM, "--time-limit", "{}"),
    (SIM, "--x0", "{},0.5"),
    (GRID, "--t-final", "{}"), (GRID, "--converge-tol", "{}"), (GRID, "--rtol", "{}"),
    (GRID, "--atol", "{}"), (GRID, "--chunk-size", "{}"), (GRID, "--jobs", "{}"),
    (GRID, "--time-limit", "{}"), (GRID, "--grid", "{}x3"), (GRID, "--box", "x1={}:1"),
    (SAMPLES + ["--seed", "1"], "--samples", "{}"), (SAMPLES + ["--samples", "5"], "--seed", "{}"),
    (CERT + ["--check-above", "1.01"], "--level", "{}"), (CERT + ["--level", "1"], "--max-boxes", "{}"),
    (CERT + ["--level", "1"], "--check-above", "{}"),
    (CERT + ["--level", "1"], "--param", "mu={}..2"), (KHALIL, "--param", "mu=0.5..{}..1e308"),
    (GRID, "--lyapunov-level", "{}"),
    (KHALIL, "--directions", "{}"), (KHALIL, "--seed", "{}"),
    (IPC, "--t-final", "{}"), (IPC, "--delta", "{}"), (IPC, "--saturation", "{}"),
    (IPC, "--ic", "0,0,{},0"), (IPC, "--poles", "{},-1,-1,-1"), (IPC, "--time-limit", "{}"),
    (IPC, "--coefficients", "{},4,6,4"),
]  # fmt: skip


class Hang(Exception):
    pass


def _alarm(signum, frame):  # noqa: ANN001
    raise Hang("a CLI call ran for more than 60 s")


def _run(argv: list[str], capsys) -> tuple[int, str]:
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(60)
    try:
        rc = main(argv)
    except SystemExit as exc:  # argparse's own errors exit 2
        rc = exc.code if isinstance(exc.code, int) else 2
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    return rc, capsys.readouterr().err


@pytest.mark.parametrize("base, option, fmt", OPTIONS, ids=[f"{b[0]} {o}" for b, o, _ in OPTIONS])
@settings(max_examples=int(os.environ.get('FUZZ_N', 12)), derandomize=True, deadline=None, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])  # fmt: skip
@given(text=NUMBER)
def test_a_numeric_option_gives_a_result_or_exit_2_naming_it(base, option, fmt, text, capsys):
    argv = list(base)
    value = fmt.format(text)
    if option in argv:  # replace the base's value
        i = argv.index(option)
        argv[i + 1] = value
    else:
        argv += [option, value]
    # "--opt=value" keeps a value that starts with "-" from being read as an option
    i = argv.index(option)
    argv[i : i + 2] = [f"{option}={argv[i + 1]}"]
    rc, err = _run(argv, capsys)
    assert "Traceback" not in err, err
    assert rc in (0, 1, 2), (rc, err)
    if rc == 2:
        field = option.lstrip("-").replace("-", "_")
        assert option in err or field in err, err  # the message names the option


FOUND = [
    ("--poles=abc,-1,-1,-1", "--poles"),  # a ValueError traceback from complex()
    ("--poles=nan,-1,-1,-1", "--poles"),  # named "coefficients", not the option given
    ("--poles=-9432,-1,-1,-1", "--poles"),  # a loop too stiff to integrate: ran for hours
    ("--coefficients=1e300,4,6,4", "--coefficients"),
    ("--ic=0,0,nan,0", "--ic"),  # "IPC state must be finite", no option named
    ("--delta=1e-320", "delta"),  # a subnormal mass ratio: "field not finite at the equilibrium"
]


@pytest.mark.parametrize("arg, named", FOUND, ids=[a for a, _ in FOUND])
def test_numbers_the_fuzz_found_exit_2_naming_the_option(arg, named, capsys):
    rc, err = _run(["study", "ipc", "simulate", "--ic", "0.1,0,0.1,0", arg], capsys)
    assert rc == 2 and named in err and "Traceback" not in err, err
