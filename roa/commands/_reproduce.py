"""``roa reproduce``: every experiment, then the report."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from roa.errors import RoaInputError


def register(sub: argparse._SubParsersAction, study: str | None = None) -> None:
    """Add the command; under ``roa study NAME`` (``study``) it has no ``--study``."""
    p = sub.add_parser("reproduce", help="run every experiment and regenerate paper_repro.md")
    p.add_argument("--quick", action="store_true", help="reduced grids (minutes, what CI runs)")
    p.add_argument("--force", action="store_true", help="re-run experiments even if cached")
    if study is None:
        p.add_argument("--study", default=None, help="the study to reproduce (default: ipc)")
    p.add_argument(
        "--experiments",
        default=None,
        help="directory of configs (default: ./experiments if present, else the study's own)",
    )
    p.add_argument(
        "--results",
        default=None,
        help="results directory (default results/, or results-quick/ with --quick)",
    )
    p.add_argument(
        "--report",
        default=None,
        help="report path (default the study's report, paper_repro.md for ipc; under RESULTS/ "
        "with --quick)",
    )
    p.set_defaults(func=run, shortcut=study is None, **({} if study is None else {"study": study}))


def run(args: argparse.Namespace) -> int:
    from roa.studies import _registry as studies
    from roa.studies._experiment import (
        experiments_dir,
        list_experiments,
        run_experiment,
        write_report,
    )

    study = studies.get(args.study)
    if args.shortcut and args.experiments is None and not any(Path("experiments").glob("*.toml")):
        raise RoaInputError(
            "roa reproduce runs the experiments of the study checkout in this folder "
            "(experiments/*.toml) and there are none here; to write the results of study "
            f"{study.name!r} into this folder, run `roa study {study.name} reproduce`"
        )
    results = args.results or ("results-quick" if args.quick else "results")
    name = study.report_name
    report_path = args.report or (f"{results}/{name}" if args.quick else name)
    directory = Path(args.experiments) if args.experiments else experiments_dir(study)
    configs = list_experiments(directory)
    if not configs:
        raise RoaInputError(f"--experiments: no *.toml configs in {directory}")
    t_all = time.perf_counter()
    for i, path in enumerate(configs, 1):
        t0 = time.perf_counter()
        print(f"[{i}/{len(configs)}] {path.stem} ...", flush=True)
        summary = run_experiment(path, results=results, quick=args.quick, force=args.force)
        state = "cached" if summary.get("cached") else f"{time.perf_counter() - t0:.1f} s"
        print(f"[{i}/{len(configs)}] {path.stem}: {state}", flush=True)
    report = write_report(study, results, report_path)
    print(f"report: {report}  (total {time.perf_counter() - t_all:.1f} s)")
    return 0
