"""The roa command line: JSON outputs, clear errors, unknown arguments rejected."""

import json
import subprocess
import sys

import pytest

from roa.cli import build_parser, main


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "roa.cli", *args], capture_output=True, text=True, timeout=300
    )


@pytest.mark.parametrize("ic", ["0.4,0.25,0.2,2", "0,0,1.2,0.2", "1,0,-0.8,0"])
def test_simulate_paper_points_converge(ic, capsys):
    assert main(["study", "ipc", "simulate", "--ic", ic, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "converged"
    assert len(out["final_state"]) == 4
    assert max(abs(v) for v in out["final_state"]) < 1e-3


def test_simulate_tracking_reports_error(capsys):
    assert (
        main(
            [
                "study",
                "ipc",
                "simulate",
                "--ic",
                "0,0,1,0",
                "--reference",
                "2*sin(t/2)",
                "--t-final",
                "40",
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "completed"
    assert 0 < out["tracking_error_max_last_half"] < 0.1


def test_simulate_flat_coordinates_agree(capsys):
    main(
        [
            "study",
            "ipc",
            "simulate",
            "--ic",
            "0.4,0.25,0.2,2",
            "--json",
            "--t-final",
            "5",
            "--coordinates",
            "flat",
        ]
    )
    flat = json.loads(capsys.readouterr().out)
    main(["study", "ipc", "simulate", "--ic", "0.4,0.25,0.2,2", "--json", "--t-final", "5"])
    phys = json.loads(capsys.readouterr().out)
    assert flat["status"] == phys["status"] == "undecided"
    assert flat["final_state"] == pytest.approx(phys["final_state"], abs=1e-6)


@pytest.mark.parametrize(
    "args, message",
    [
        (["--ic", "0,0,1.7,0"], "theta = 1.7 rad is outside the domain"),
        (["--ic", "0,0,nan,0"], "finite"),
        (["--ic", "0,0,1"], "expected 4"),
        (["--ic", "0,0,0.1,0", "--poles=-1,-1,1,-1"], "not Hurwitz"),
        (["--ic", "0,0,0.1,0", "--delta", "-1"], "delta"),
    ],
)
def test_simulate_bad_input(args, message, capsys):
    assert main(["study", "ipc", "simulate", *args]) == 2
    assert message in capsys.readouterr().err


def test_unknown_arguments_raise():
    with pytest.raises(SystemExit):
        build_parser().parse_args(["study", "ipc", "simulate", "--ic", "0,0,0,0", "--bogus", "1"])
    with pytest.raises(SystemExit):
        build_parser().parse_args(["nonexistent-command"])


def test_every_command_has_help(capsys):
    """Every command (and every one of its options) is documented in --help."""
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name, subparser in sub.choices.items():
        with pytest.raises(SystemExit) as exit_info:
            main([name, "--help"])
        assert exit_info.value.code == 0, name
        text = capsys.readouterr().out
        assert "usage: roa" in text, name
        for action in subparser._actions:
            if action.option_strings and action.dest != "help":
                assert action.help, f"roa {name} {action.option_strings[0]} has no help text"


@pytest.mark.parametrize("command", ["simulate", "khalil", "certify", "basin"])
def test_a_missing_system_exits_2_listing_the_built_ins(command, capsys):
    """No analysis command has a default system: without --system it exits 2 (before any work)
    naming the option and the systems loadable by name, the library's and the studies'."""
    with pytest.raises(SystemExit) as exc:
        main([command, "--json"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"roa {command}: error:" in err and "--system" in err
    assert (
        "built-in systems: vanderpol, cubic-map; study ipc: ipc, ipc-flat, ipc-flat-uncertain;"
        in err
    )
    assert "path/file.py:NAME" in err


def test_an_unknown_system_lists_the_built_ins(capsys):
    assert main(["simulate", "--system", "nosuch", "--x0", "1,0"]) == 2
    err = capsys.readouterr().err
    assert (
        "nosuch" in err
        and "vanderpol, cubic-map; study ipc: ipc, ipc-flat, ipc-flat-uncertain" in err
    )


def test_the_console_script_runs():
    proc = run_cli("khalil", "--help")
    assert proc.returncode == 0 and "usage: roa khalil" in proc.stdout


def test_basin_box_outside_the_domain_is_rejected_before_work(capsys):
    assert (
        main(
            [
                "basin",
                "--system",
                "ipc",
                "--slice",
                "q,theta",
                "--grid",
                "5x5",
                "--box",
                "q=-1:1,theta=-2:2",
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert "--box" in err and "outside the domain" in err and "theta" in err


@pytest.mark.parametrize(
    "args, message",
    [
        (["simulate", "--system", "vanderpol", "--x0", "1,2,3"], "--x0: expected 2"),
        (["simulate", "--system", "vanderpol", "--x0", "1,2", "--converge-tol", "-1"],
         "--converge-tol must be"),
        (["simulate", "--system", "vanderpol:mu=x", "--x0", "1,2"], "NAME=NUMBER"),
        (["certify", "--system", "vanderpol", "--check-above", "0.5"], "--check-above must be"),
        (["khalil", "--system", "vanderpol", "--lyapunov", "/nonexistent.json"], "--lyapunov"),
        (["khalil", "--system", "vanderpol", "--directions", "3"], "--directions must be in"),
        (["basin", "--system", "vanderpol", "--samples", "5", "--terminal-set", "/no.json"],
         "--terminal-set"),
        (["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "3x3", "--converge-tol",
          "0"], "--converge-tol must be"),
        (["report", "--study", "nope"], "study must be one of"),
    ],
)  # fmt: skip
def test_new_options_reject_bad_input_in_one_line(args, message, capsys):
    """Exit 2, a message naming the option, no traceback."""
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_basin_json_is_the_result_to_dict(capsys):
    """The CLI prints the API result's to_dict() and nothing else (the same keys and counts)."""
    import roa
    import roa.io
    from roa.cli import main

    argv = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "6x5",
            "--box", "x1=-3:3,x2=-2:2", "--jobs", "1", "--json"]  # fmt: skip
    assert main(argv) == 0
    printed = json.loads(capsys.readouterr().out)
    system = roa.load_system("vanderpol")
    grid = roa.grid_slice(system, ("x1", "x2"), [(-3, 3), (-2, 2)], (6, 5))
    expected = json.loads(
        roa.io.to_json(roa.basin(system, grid, run=roa.RunOptions(n_jobs=1)).to_dict())
    )
    for d in (printed, expected):
        d.pop("seconds")
    assert printed == expected
    assert (
        printed["mode"] == "slice" and printed["axes"] == ["x1", "x2"] and printed["grid"] == [6, 5]
    )
