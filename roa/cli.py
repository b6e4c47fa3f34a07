"""The ``roa`` command line. Each subcommand lives in ``roa/commands/NAME.py`` with ``register``."""

from __future__ import annotations

import argparse
import importlib
import sys

#: Subcommand modules under roa.commands, in --help order.
COMMANDS = ("simulate", "run", "reproduce", "report", "basin", "bound", "khalil", "check", "certify")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="roa",
        description="Region-of-attraction verification toolkit: simulate, estimate, certify, map basins.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"roa.commands.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except ValueError as exc:
        print(f"roa {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"roa {args.command}: interrupted; completed work was kept", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
