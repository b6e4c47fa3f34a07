"""``roa run``: run one experiment config into results/NAME/."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction, study: str | None = None) -> None:
    """Add the command; under ``roa study NAME`` (``study``) it has no ``--study``."""
    p = sub.add_parser(
        "run", help="run one experiment config (experiments/NAME.toml) into results/NAME/"
    )
    p.add_argument("config", help="path to an experiment TOML file")
    p.add_argument("--quick", action="store_true", help="use the config's reduced [quick] settings")
    p.add_argument(
        "--force", action="store_true", help="re-run even if config and code are unchanged"
    )
    p.add_argument(
        "--results",
        default=None,
        help="results directory (default results/, or results-quick/ with --quick)",
    )
    p.set_defaults(func=run, **({} if study is None else {"study": study}))


def run(args: argparse.Namespace) -> int:
    from roa.studies._experiment import run_experiment

    results = args.results or ("results-quick" if args.quick else "results")
    summary = run_experiment(args.config, results=results, quick=args.quick, force=args.force)
    state = "cached" if summary.get("cached") else "done"
    print(f"{summary['experiment']}: {state} -> {results}/{summary['experiment']}/")
    for claim in summary.get("claims", []):
        print(f"  [{claim['verdict']}] {claim['id']}: {claim['claim']} -- ours: {claim['ours']}")
    return 0
