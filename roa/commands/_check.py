"""``roa check``: recompute the values stored in results/reference.json; non-zero on any drift."""

from __future__ import annotations

import argparse

from roa.errors import RoaInputError
from roa.io import to_json


def register(sub: argparse._SubParsersAction, study: str | None = None) -> None:
    """Add the command; under ``roa study NAME`` (``study``) it has no ``--study``."""
    p = sub.add_parser("check", help="recompute stored reference values (results/reference.json)")
    p.add_argument("--only", nargs="+", metavar="KEY", default=None, help="check only these keys")
    p.add_argument(
        "--update",
        action="store_true",
        help="recompute and STORE the selected keys (all if no --only) instead of checking",
    )
    if study is None:
        p.add_argument(
            "--study", default=None, help="the study whose values are checked (default: ipc)"
        )
    p.add_argument("--reference", default="results/reference.json",
                   help="reference file (default results/reference.json of the checkout)")  # fmt: skip
    p.add_argument(
        "--recompute",
        nargs="*",
        metavar="EXPERIMENT",
        default=None,
        help="run these experiments again (all with results if none named) in their stored mode "
        "and compare every value of their summaries with the stored ones: catches deliberate "
        "edits that the hashes cannot (the reference values are not checked in this mode)",
    )
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    p.set_defaults(func=run, **({} if study is None else {"study": study}))


def run(args: argparse.Namespace) -> int:
    from roa.studies import _reference as reference, _registry as studies

    if args.recompute is not None:
        if args.update or args.only:
            raise RoaInputError(
                "--recompute compares experiments' results: not with --update or --only"
            )
        return _report(args, _recompute(args))
    registry = studies.get(args.study).registry()
    if args.update:
        stored = reference.update(registry, args.only, path=args.reference)
        print(
            f"stored {len(args.only or registry)} value(s) in {args.reference} "
            f"({len(stored)} entries)"
        )
        return 0
    rows = reference.check(registry, args.only, path=args.reference)
    if not args.only:  # the outputs of the study's experiments next to the reference file
        from pathlib import Path

        from roa.studies._experiment import verify_outputs

        study = studies.get(args.study)
        for summary in sorted(Path(args.reference).parent.glob("*/summary.json")):
            if (study.experiments / f"{summary.parent.name}.toml").is_file():
                problems = verify_outputs(summary.parent)
                rows.append(
                    {"key": f"outputs of {summary.parent.name}",
                     "status": "modified" if problems else "ok", "error": "; ".join(problems)}
                )  # fmt: skip
    return _report(args, rows)


def _recompute(args: argparse.Namespace) -> list[dict]:
    """Rows of ``--recompute`` (:mod:`roa.studies._recompute`)."""
    from pathlib import Path

    from roa.studies import _registry as studies
    from roa.studies._experiment import experiments_dir
    from roa.studies._recompute import recompute

    results = Path(args.reference).parent
    configs = experiments_dir(studies.get(args.study))
    names = list(args.recompute) or sorted(
        p.parent.name for p in results.glob("*/summary.json")
        if (configs / f"{p.parent.name}.toml").is_file()
    )  # fmt: skip
    if not names:
        raise RoaInputError(f"--recompute: no experiment results in {results}")
    return recompute(configs, results, names)


def _report(args: argparse.Namespace, rows: list[dict]) -> int:
    bad = [r for r in rows if r["status"] != "ok"]
    if args.json:
        print(to_json({"rows": rows, "failed": [r["key"] for r in bad]}))
    else:
        for r in rows:
            extra = ""
            if "stored" in r:
                extra = f"stored {r['stored']:.12g}, recomputed {r['recomputed']:.12g} (rtol {r['rtol']:g})"
            elif "recomputed" in r:
                extra = f"recomputed {r['recomputed']:.12g}; store it with roa check --update --only {r['key']}"
            elif "error" in r:
                extra = r["error"]
            print(f"{r['status']:>12s}  {r['key']}  {extra}")
    if bad:
        import sys

        print(
            f"roa check: {len(bad)} value(s) failed: {', '.join(r['key'] for r in bad)}",
            file=sys.stderr,
        )
        return 1
    return 0
