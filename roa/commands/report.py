"""``roa report``: regenerate paper_repro.md from results/."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("report", help="generate paper_repro.md from the results/ summaries")
    p.add_argument("--results", default="results", help="results directory (default results/)")
    p.add_argument("--out", default="paper_repro.md", help="output path (default paper_repro.md)")
    p.add_argument(
        "--check",
        action="store_true",
        help="exit 1 if the file differs from what would be generated",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from roa.report import render_report, write_report

    if args.check:
        text = render_report(args.results, args.out)
        current = Path(args.out).read_text() if Path(args.out).is_file() else ""
        if text != current:
            print(
                f"{args.out} differs from the report generated from {args.results}/; run `roa report`"
            )
            return 1
        print(f"{args.out} is up to date")
        return 0
    print(write_report(args.results, args.out))
    return 0
