"""Studies declare systems that load by name like the library's built-ins (roa.studies).

A toy study is registered in place of the installed ones (``roa.studies.registered``): its system
is the scalar decay x' = -k x, whose only parameter k must reach the factory.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from roa import System, load_system
from roa.errors import RoaInputError
from roa.studies import _registry as studies
from roa.systems import BUILTIN, builtin_names, describe_builtins


def decay(k: float = 1.0) -> System:
    return System(
        name=f"decay_{k:g}",
        field=lambda t, x, xp: (-k * x[0],),
        equilibrium=(0.0,),
        state_names=("x",),
    )


def _study(name: str, systems: dict[str, str]) -> studies.Study:
    return studies.Study(name, "tests", Path("."), "m:R", "m:r", systems=systems)


@pytest.fixture
def registry(monkeypatch):
    """Replace the installed studies by the ones a test puts in the returned dict."""
    found: dict[str, studies.Study] = {}
    monkeypatch.setattr(studies, "registered", lambda: found)
    return found


def test_a_study_system_loads_by_name_with_parameters(registry):
    registry["toy"] = _study("toy", {"decay": f"{__name__}:decay"})
    assert load_system("decay").name == "decay_1"
    assert load_system("decay:k=2.5").name == "decay_2.5"
    with pytest.raises(RoaInputError, match="NAME=NUMBER"):
        load_system("decay:k")
    with pytest.raises(RoaInputError, match="unexpected keyword"):
        load_system("decay:mu=2")
    assert builtin_names() == {**dict.fromkeys(BUILTIN), "decay": "toy"}
    assert describe_builtins() == "vanderpol, cubic-map; study toy: decay"


def test_the_library_built_ins_come_first(registry):
    registry["toy"] = _study("toy", {"vanderpol": f"{__name__}:decay"})
    assert load_system("vanderpol").name == "vanderpol"
    assert builtin_names()["vanderpol"] is None


def test_a_name_declared_by_two_studies_is_an_error_when_loaded(registry):
    registry["a"] = _study("a", {"decay": f"{__name__}:decay"})
    registry["b"] = _study("b", {"decay": f"{__name__}:decay", "other": f"{__name__}:decay"})
    with pytest.raises(RoaInputError, match="declared by several studies"):
        load_system("decay")
    assert load_system("other:k=3").name == "decay_3"


def test_without_studies_only_the_library_built_ins_remain(registry):
    assert builtin_names() == dict.fromkeys(BUILTIN)
    with pytest.raises(RoaInputError, match=r"not a built-in system \(vanderpol, cubic-map\)"):
        load_system("ipc")


def test_roa_study_lists_each_study_with_its_commands(capsys):
    from roa.cli import main

    assert main(["study"]) == 0
    assert (
        "ipc: roa study ipc {run, reproduce, report, check, bound, simulate}"
        in capsys.readouterr().out
    )


def test_a_studys_own_commands_are_not_top_level_commands(capsys):
    from roa.cli import build_parser

    for name in ("bound", "ipc-simulate"):
        with pytest.raises(SystemExit):
            build_parser().parse_args([name])
    build_parser().parse_args(["study", "ipc", "bound"])  # where they live


def test_reproduce_outside_a_study_checkout_writes_nothing_and_names_the_study_command(
    tmp_path, monkeypatch, capsys
):
    from roa.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["reproduce", "--quick"]) == 2
    err = capsys.readouterr().err
    assert "roa reproduce: error" in err and "roa study ipc reproduce" in err
    assert list(tmp_path.iterdir()) == []


def test_an_unknown_study_or_study_command_exits_2_naming_it(capsys):
    from roa.cli import main

    for argv, bad in ((["study", "nope"], "nope"), (["study", "ipc", "frobnicate"], "frobnicate")):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        err = capsys.readouterr().err
        assert exc.value.code == 2 and f"'{bad}'" in err and "Traceback" not in err
