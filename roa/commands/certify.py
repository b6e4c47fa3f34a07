"""``roa certify``: SOS and/or rigorous interval certification of a Lyapunov level set."""

from __future__ import annotations

import argparse
import json

import numpy as np

from roa.io import to_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("certify", help="certify V' < 0 on {V <= rho} (SOS + interval validation)")
    p.add_argument(
        "--system",
        default="ipc-flat",
        help="ipc-flat (default), vanderpol, or path/file.py:NAME (with LYAPUNOV_P)",
    )
    p.add_argument(
        "--lyapunov",
        default=None,
        help="paper | optimised | sector (IPC), benchmark (Van der Pol), or a .json/.npy file with P; "
        "default: the system's own (paper / benchmark / LYAPUNOV_P)",
    )
    g = p.add_mutually_exclusive_group()
    g.add_argument("--level", type=float, default=None, help="validate this level rho > 0")
    g.add_argument(
        "--maximise",
        action="store_true",
        help="largest level: SOS candidate and/or sampled optimum, then validated (default)",
    )
    p.add_argument("--method", choices=("sos", "interval", "both"), default="both")
    p.add_argument("--max-boxes", type=int, default=3_000_000, help="interval box budget")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def _lyapunov(args: argparse.Namespace, system):
    from pathlib import Path

    from roa.lyapunov import QuadraticLyapunov
    from roa.systems import load_module_attr

    spec = args.lyapunov
    if spec is None:
        spec = {"ipc-flat": "paper", "vanderpol": "benchmark"}.get(args.system)
    if spec == "paper":
        if args.system != "ipc-flat":
            raise ValueError("--lyapunov paper is only defined for --system ipc-flat")
        from roa.systems.ipc.lyapunov import paper_lyapunov

        P = paper_lyapunov().P
    elif spec in ("optimised", "sector"):
        if args.system != "ipc-flat":
            raise ValueError(f"--lyapunov {spec} is only defined for --system ipc-flat")
        from roa.certify.regions import load_optimised_P

        P = load_optimised_P(which="box" if spec == "optimised" else "sector")
    elif spec == "benchmark":
        from roa.systems.vanderpol import P_BENCHMARK

        P = P_BENCHMARK
    elif spec is None:
        P = load_module_attr(args.system, "LYAPUNOV_P")
        if P is None:
            raise ValueError("--lyapunov: no default for this system; give a file with P")
    else:
        path = Path(spec)
        if not path.is_file():
            raise ValueError(
                f"--lyapunov {spec!r}: not paper/optimised/sector/benchmark and no such file"
            )
        P = np.load(path) if path.suffix == ".npy" else np.asarray(json.loads(path.read_text()))
    return QuadraticLyapunov.for_system(system, P, name=str(spec))


def run(args: argparse.Namespace) -> int:
    from roa.certify.sos import sos_level
    from roa.certify.validate import validate_level
    from roa.systems import load_system

    if args.level is not None and not (np.isfinite(args.level) and args.level > 0):
        raise ValueError(f"--level must be a finite number > 0, got {args.level}")
    if args.max_boxes < 1:
        raise ValueError(f"--max-boxes must be >= 1, got {args.max_boxes}")
    system = load_system(args.system)
    if system.time_varying:
        raise ValueError("--system must be autonomous with an equilibrium")
    V = _lyapunov(args, system)
    out: dict = {"system": system.name, "lyapunov": V.name, "P": V.P.tolist()}
    level = args.level
    if args.method in ("sos", "both") and level is None:
        sos = sos_level(system, V)
        out["sos"] = sos.to_json()
        if sos.status == "solved":
            level = sos.rho
        elif args.method == "sos":
            out.update(status="inconclusive", level=None, method="sos")
    if level is None and args.method != "sos":
        from roa.levelset import level_search

        res = level_search(system, V, V.P, shape="level", method="sampled")
        out["sampled_level"] = res["value"]
        level = 0.999 * float(res["value"])
    if level is not None:
        if args.method == "sos" and args.level is None:
            out.update(
                status="inconclusive",
                level=level,
                method="sos",
                message="SOS candidate only; use --method both for an independent check",
            )
        else:
            v = validate_level(system, V, level, max_boxes=args.max_boxes)
            out.update(v.to_json())
            out["method"] = "sos+interval" if "sos" in out else "interval"
    if args.json:
        print(to_json(out))
    else:
        print(f"{system.name}: V = {V.name}")
        if "sos" in out:
            s = out["sos"]
            print(
                f"  SOS: {s['status']} (solver {s['solver_status']}), rho = {s['level']}, {s['seconds']} s"
            )
        if "sampled_level" in out:
            print(f"  sampled optimum: {out['sampled_level']:.6g} (validating 0.999 of it)")
        print(
            f"  {out['status']}: level {out.get('level')}, method {out.get('method')}, "
            f"{out.get('boxes', '-')} boxes, {out.get('seconds', '-')} s"
        )
        if out.get("witness") is not None:
            print(f"  witness: {out['witness']}  ({out['witness_check']})")
    return 0 if out["status"] == "certified" else 1
