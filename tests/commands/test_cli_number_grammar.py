"""Every numeric command-line option is read by the bounded grammar of :mod:`roa.numparse`
(issue 38, items 6-7): ASCII digits with an optional sign, point and exponent, no spaces,
underscores, non-ASCII digits, inf or nan, at most 64 characters (18 digits for an integer).
Python's ``float``/``int`` accepted ``1_000``, `` 1 `` and ``\\u0661``; a 5000-digit integer hit
Python's int-string limit. Each refusal is exit 2 with a one-line message naming the option,
before any work."""

from __future__ import annotations

import pytest

from roa.cli import main

SIM = ["simulate", "--system", "vanderpol", "--x0", "0.5,0.5"]
BASIN = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "3x3",
         "--box", "x1=-1:1,x2=-1:1", "--jobs", "1"]  # fmt: skip
SAMPLES = ["basin", "--system", "vanderpol", "--box", "x1=-1:1,x2=-1:1", "--jobs", "1"]
CERT = ["certify", "--system", "vanderpol", "--level", "1"]
KHALIL = ["khalil", "--system", "vanderpol"]
IPC = ["study", "ipc", "simulate", "--ic", "0.1,0,0.1,0"]

#: (base argv, option, template of its value)
OPTIONS = [
    (SIM, "--t-final", "{}"), (SIM, "--converge-tol", "{}"), (SIM, "--diverge-bound", "{}"),
    (SIM, "--diverge-growth", "{}"), (SIM, "--time-limit", "{}"), (SIM, "--x0", "{},0.5"),
    (BASIN, "--rtol", "{}"), (BASIN, "--atol", "{}"), (BASIN, "--chunk-size", "{}"),
    (BASIN, "--jobs", "{}"), (BASIN, "--time-limit", "{}"), (BASIN, "--box", "x1={}:1"),
    (BASIN, "--fix", "x1={}"), (SAMPLES, "--samples", "{}"), (SAMPLES + ["--samples", "4"], "--seed", "{}"),
    (SAMPLES + ["--samples", "4", "--param", "mu=0.5..1.5"], "--param-samples", "{}"),
    (CERT, "--max-boxes", "{}"), (CERT, "--check-above", "{}"), (CERT, "--time-limit", "{}"),
    (["certify", "--system", "vanderpol"], "--degree", "{}"), (CERT, "--rounds", "{}"),
    (CERT, "--budget", "{}"), (KHALIL, "--directions", "{}"), (KHALIL, "--starts", "{}"),
    (KHALIL, "--seed", "{}"), (IPC, "--t-final", "{}"), (IPC, "--delta", "{}"),
    (IPC, "--saturation", "{}"), (IPC, "--time-limit", "{}"),
]  # fmt: skip
#: Texts Python's float()/int() read (or choked on) that the grammar refuses.
BAD = ["1_0", "\u0661", " 2", "2 ", "1" * 5000, "nan", "inf"]


def _run(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:  # argparse's usage error
        return int(exc.code or 0)


@pytest.mark.parametrize("text", BAD, ids=["underscore", "arabic-digit", "lead-space",
                                           "trail-space", "5000-digits", "nan", "inf"])  # fmt: skip
@pytest.mark.parametrize(("base", "option", "template"), OPTIONS,
                         ids=[f"{b[0]}{o}" for b, o, _ in OPTIONS])  # fmt: skip
def test_every_numeric_option_refuses_text_outside_the_grammar(capsys, base, option, template,
                                                               text):  # fmt: skip
    code = _run([*base, option, template.format(text)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert option in last or option.lstrip("-") in last, last


def test_integer_options_read_plain_integers(capsys):
    """The grammar does not refuse what it should read: --samples 4 --seed -0 runs (a 4-sample
    basin), and --jobs +1 is 1."""
    assert _run([*SAMPLES, "--samples", "4", "--seed", "-0", "--jobs", "+1", "--t-final", "1",
                 "--json"]) == 0  # fmt: skip
    assert '"n": 4' in capsys.readouterr().out


def test_spaces_in_a_parameter_range_are_refused_naming_it(capsys):
    """Decision (documented in roa.numparse): a number never holds or is padded by spaces, in
    every option, --param ranges included: ``mu= 1 .. 2 `` is refused, naming the option."""
    assert _run(["certify", "--system", "vanderpol", "--param", "mu= 1 .. 2 ", "--level", "1"]) == 2
    err = capsys.readouterr().err
    assert "--param mu= 1 .. 2" in err and "no spaces" in err
