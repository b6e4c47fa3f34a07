"""``roa certify``: SOS and/or rigorous interval certification of a Lyapunov level set."""

from __future__ import annotations

import argparse
import json

import numpy as np

from roa.io import to_json

#: SOS levels are validated at this fraction of rho: the SOS optimum is a supremum, attained on the
#: level surface only in the limit, so validation exactly at rho needs unboundedly many boxes.
SOS_SAFETY = 1 - 1e-4
#: A sampled optimum (an upper bound of the largest level) is validated at this fraction.
SAMPLED_SAFETY = 0.999


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "certify",
        help="certify V' < 0 on {V <= rho} (SOS + interval validation)",
        description=(
            "Certify that the sublevel set {V <= rho} of a quadratic Lyapunov candidate lies in the "
            "region of attraction: V' < 0 on it minus the equilibrium (and inside the system's "
            "domain). With --level RHO, that level is checked by interval branch and bound "
            "(certified / refuted with a 50-digit checked witness / inconclusive). Without --level "
            "(the default, --maximise), a candidate level is found first -- by the SOS program "
            f"(validated at {SOS_SAFETY} rho) and/or the sampled level search (validated at "
            f"{SAMPLED_SAFETY} of the sampled optimum) -- and then validated. Only an interval "
            "validation gives status 'certified'. The IPC analysis is in flat coordinates: use "
            "--system ipc-flat. Exit code 0 iff certified."
        ),
    )
    p.add_argument(
        "--system",
        default="ipc-flat",
        help="ipc-flat, vanderpol, or path/file.py:NAME (with LYAPUNOV_P); default ipc-flat",
    )
    p.add_argument(
        "--lyapunov",
        default=None,
        help="paper | optimised | sector (IPC), benchmark (Van der Pol), or a .json/.npy file with "
        "P; default: the system's own (paper / benchmark / LYAPUNOV_P)",
    )
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--level",
        type=float,
        default=None,
        help="validate this level rho > 0 by interval branch and bound (--method interval); "
        "default: none, maximise",
    )
    g.add_argument(
        "--maximise",
        action="store_true",
        help="find the largest level (SOS and/or sampled search), then validate it; this is what "
        "happens whenever --level is not given (default), the flag only makes it explicit",
    )
    p.add_argument(
        "--method",
        choices=("sos", "interval", "both"),
        default=None,
        help="how to find the level when maximising: sos (SOS program only, an uncertified "
        "candidate), interval (sampled search, then interval validation), both (SOS, then "
        "interval validation; sampled search if SOS fails). With --level only 'interval' is "
        "possible. Default: both, or interval with --level",
    )
    p.add_argument(
        "--max-boxes",
        type=int,
        default=3_000_000,
        help="box budget of the interval validation (exhausted -> inconclusive); default 3000000",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object (default: text)")
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
        from roa.systems.ipc.certified import load_optimised_P

        P = load_optimised_P(which="box" if spec == "optimised" else "sector")
    elif spec == "benchmark":
        from roa.systems.vanderpol import P_BENCHMARK

        P = P_BENCHMARK
    elif spec is None:
        P = load_module_attr(args.system, "LYAPUNOV_P")  # type: ignore[assignment]
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


def _search_level(system, V, out: dict):
    """Sampled optimum of the level (an upper bound), or ``None`` with status and message set."""
    from roa.levelset import level_search

    res = level_search(system, V, V.P, shape="level", method="sampled")
    out["level_search"] = {k: res[k] for k in ("status", "value", "method") if k in res}
    if res["status"] == "found":
        out.update(
            sampled_level=float(res["value"]), level_source="sampled", safety_factor=SAMPLED_SAFETY
        )
        return SAMPLED_SAFETY * float(res["value"])
    if res["status"] == "unbounded":
        msg = (
            f"the level search found no point with V' >= 0 up to V = {res['value']:.4g}: no "
            "finite candidate level (V' < 0 may hold on every sublevel set); give --level RHO"
        )
    elif res["status"] == "not_locally_negative":
        msg = (
            "V' is not negative definite at the equilibrium (largest eigenvalue of A'P + PA = "
            f"{res.get('max_eig_AtP_PA', float('nan')):.4g} >= 0): no level > 0 can be certified"
        )
    else:
        msg = f"the level search ended with status {res['status']!r}: no candidate level"
    out.update(status="inconclusive", level=None, method="level search", message=msg)
    return None


def run(args: argparse.Namespace) -> int:
    from roa.certify.sos import sos_level
    from roa.certify.validate import validate_level
    from roa.systems import load_system

    if args.level is not None and not (np.isfinite(args.level) and args.level > 0):
        raise ValueError(f"--level must be a finite number > 0, got {args.level}")
    if args.level is not None and args.method not in (None, "interval"):
        raise ValueError(
            f"--method {args.method} with --level: a given level is checked by interval "
            "validation only; use --method interval (or omit --method), or drop --level to let "
            f"{args.method} find the level"
        )
    method = args.method or ("interval" if args.level is not None else "both")
    if args.max_boxes < 1:
        raise ValueError(f"--max-boxes must be >= 1, got {args.max_boxes}")
    if args.system == "ipc":
        raise ValueError(
            "--system ipc: the IPC Lyapunov analysis (V of (3.11)) is in the flat coordinates "
            "(z1, z2, w1, w2); use --system ipc-flat"
        )
    system = load_system(args.system)
    if system.time_varying:
        raise ValueError("--system must be autonomous with an equilibrium")
    V = _lyapunov(args, system)
    out: dict = {"system": system.name, "lyapunov": V.name, "P": V.P.tolist()}
    level = args.level
    if method in ("sos", "both") and level is None:
        sos = sos_level(system, V)
        out["sos"] = sos.to_json()
        if sos.status == "solved" and sos.rho is not None and method == "sos":
            level = sos.rho
        elif sos.status == "solved" and sos.rho is not None:
            out.update(level_source="sos", safety_factor=SOS_SAFETY)
            level = SOS_SAFETY * sos.rho
        elif method == "sos":
            out.update(status="inconclusive", level=None, method="sos", message=sos.message)
    if level is None and method != "sos":
        level = _search_level(system, V, out)
    if level is not None:
        if method == "sos":
            out.update(
                status="inconclusive",
                level=level,
                method="sos",
                message="SOS candidate only (not independently checked); use --method both for "
                "an interval validation",
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
        if out.get("level_source") == "sos":
            print(f"  validating {out['safety_factor']} x SOS rho")
        if "sampled_level" in out:
            print(
                f"  sampled optimum: {out['sampled_level']:.6g} "
                f"(validating {out['safety_factor']} of it)"
            )
        print(
            f"  {out['status']}: level {out.get('level')}, method {out.get('method')}, "
            f"{out.get('boxes', '-')} boxes, {out.get('seconds', '-')} s"
        )
        if out.get("message"):
            print(f"  {out['message']}")
        if out.get("witness") is not None:
            print(f"  witness: {out['witness']}  ({out['witness_check']})")
    return 0 if out["status"] == "certified" else 1
