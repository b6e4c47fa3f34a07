"""``roa study NAME COMMAND``: a case study's commands, apart from the general tool.

Every installed study (:mod:`roa.studies`) gets the harness commands (``run``, ``reproduce``,
``report``, ``check``) bound to it, plus the commands it declares (``Study.commands``). ``roa study``
alone lists the installed studies and their commands.
"""

from __future__ import annotations

import argparse
import importlib

#: The harness commands every study has, in --help order.
HARNESS = ("run", "reproduce", "report", "check")


def register(sub: argparse._SubParsersAction) -> None:
    from roa.studies import _registry as studies

    p = sub.add_parser(
        "study",
        help="a case study's commands: its experiments, report, reference checks and own commands",
        description="roa study NAME COMMAND: the commands of an installed case study.",
    )
    names = p.add_subparsers(dest="study_name", metavar="STUDY")
    listing: dict[str, list[str]] = {}  # study name -> its command names, as registered
    for study in studies.registered().values():
        q = names.add_parser(study.name, help=f"the {study.name} study ({study.package})")
        commands = q.add_subparsers(dest="study_command", required=True, metavar="COMMAND")
        for name in HARNESS:
            importlib.import_module(f"roa.commands._{name}").register(commands, study=study.name)
        for module in study.commands:
            importlib.import_module(module).register(commands)
        listing[study.name] = list(commands.choices)
    p.set_defaults(func=_list, listing=listing)


def _list(args: argparse.Namespace) -> int:
    """``roa study`` without a study: what is installed."""
    if not args.listing:
        print("no study is installed (entry point group 'roa.studies')")
        return 0
    for name, commands in args.listing.items():
        print(f"{name}: roa study {name} {{{', '.join(commands)}}}")
    return 0
