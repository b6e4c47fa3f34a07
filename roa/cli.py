"""The ``roa`` command line. Each subcommand lives in ``roa/commands/_NAME.py`` with ``register``."""

from __future__ import annotations

import argparse
import importlib
import sys

from roa.errors import RoaError, RoaInputError, TimeLimitReached

#: Subcommand modules under roa.commands, in --help order: the general tool, then ``study`` (a
#: case study's commands, ``roa study NAME ...``) and the shortcuts for the study of the checkout
#: in the current folder (``roa reproduce`` is ``roa study NAME reproduce`` there).
COMMANDS = (
    "simulate",
    "khalil",
    "certify",
    "verify",
    "basin",
    "study",
    "run",
    "reproduce",
    "report",
    "check",
)


def build_parser() -> argparse.ArgumentParser:
    from roa.commands._common import Parser

    parser = Parser(
        prog="roa",
        description="Region-of-attraction verification toolkit: simulate, estimate, certify, map basins.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"roa.commands._{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the CLI: input errors exit 2, other roa errors exit 1 with their message, bugs raise."""
    try:
        parser = build_parser()
        args = parser.parse_args(argv)  # --help and usage errors exit here, before heavy imports
    except KeyboardInterrupt:
        print("roa: interrupted; nothing was kept", file=sys.stderr)
        return 130
    import matplotlib

    matplotlib.use("Agg")  # files only, never a window
    from roa import progress

    progress.enable(True)  # a line per long step on stderr (bars only on a terminal)
    from roa import stage_limit

    # --time-limit also bounds each long step without a budget of its own (roa.stage_limit)
    stage_limit.limit(getattr(args, "time_limit", None))
    # the command as typed: "basin", or "study ipc reproduce"
    label = " ".join(
        str(part)
        for part in (
            args.command,
            getattr(args, "study_name", None),
            getattr(args, "study_command", None),
        )
        if part
    )
    try:
        return int(args.func(args) or 0)
    except TimeLimitReached as exc:
        print(f"roa {label}: stopped: {exc}", file=sys.stderr)
        return 1
    except RoaInputError as exc:
        print(f"roa {label}: error: {exc}", file=sys.stderr)
        return 2
    except RoaError as exc:
        print(f"roa {label}: failed: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as exc:
        # what was kept: the notes of the code interrupted (e.g. a basin's saved chunks)
        kept = "; ".join(getattr(exc, "__notes__", [])) or "nothing was kept"
        print(f"roa {label}: interrupted; {kept}", file=sys.stderr)
        return 130
    finally:
        stage_limit.limit(None)


if __name__ == "__main__":
    sys.exit(main())
