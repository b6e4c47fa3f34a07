"""``roa report``: regenerate paper_repro.md from results/."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction, study: str | None = None) -> None:
    """Add the command; under ``roa study NAME`` (``study``) it has no ``--study``."""
    p = sub.add_parser("report", help="generate the study's report (paper_repro.md) from results/")
    if study is None:
        p.add_argument("--study", default=None, help="the study (default: ipc)")
    p.add_argument("--results", default="results", help="results directory (default results/)")
    p.add_argument("--out", default=None, help="output path (default the study's, paper_repro.md)")
    p.add_argument(
        "--check",
        action="store_true",
        help="exit 1 if the file differs from what would be generated",
    )
    p.set_defaults(func=run, **({} if study is None else {"study": study}))


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from roa.errors import ResultsError
    from roa.studies import _registry as studies
    from roa.studies._experiment import write_report

    study = studies.get(args.study)
    out = args.out or study.report_name
    if not any(Path(args.results).glob("*/summary.json")):
        raise ResultsError(
            f"no experiment summaries in {Path(args.results).resolve()} (expected "
            "RESULTS/NAME/summary.json): run roa reproduce first, or pass --results"
        )
    from roa.studies._experiment import verify_outputs

    problems = [
        problem
        for summary in sorted(Path(args.results).glob("*/summary.json"))
        if (study.experiments / f"{summary.parent.name}.toml").is_file()
        for problem in verify_outputs(summary.parent)
    ]
    if problems:
        raise ResultsError(
            "results that no run produced: "
            + "; ".join(problems[:8])
            + ("" if len(problems) <= 8 else f" (and {len(problems) - 8} more)")
            + "; re-run those experiments (roa run CONFIG --force)"
        )
    ran = {p.parent.name for p in Path(args.results).glob("*/summary.json")}
    missing = sorted(c.stem for c in study.experiments.glob("*.toml") if c.stem not in ran)
    if missing:  # a report without them would silently drop their claims
        raise ResultsError(
            f"{len(missing)} experiment(s) of study {study.name!r} have no results in "
            f"{args.results}: {', '.join(missing)}; run them (roa run experiments/NAME.toml, or "
            "roa reproduce) before the report"
        )
    if args.check:
        text = study.render_report(args.results, out)
        current = Path(out).read_text() if Path(out).is_file() else ""
        if text != current:
            import difflib

            diff = [
                line
                for line in difflib.unified_diff(
                    current.splitlines(), text.splitlines(), lineterm="", n=0
                )
                if line[:1] in "+-" and line[:3] not in ("+++", "---")
            ]
            print(f"{out} differs from the report generated from {args.results}/ "
                  f"({len(diff)} lines); run `roa report`:")  # fmt: skip
            for line in diff[:40]:
                print(f"  {line[:160]}")
            return 1
        print(f"{out} is up to date")
        return 0
    print(write_report(study, args.results, out))
    return 0
