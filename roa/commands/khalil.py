"""``roa khalil``: Khalil's level-set search (3.15) for the IPC or any system with an equilibrium."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from roa.io import to_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "khalil",
        help="largest ball / V-level set on which V' < 0 (Khalil's search, sampled and CasADi)",
        description=(
            "Largest c with V' < 0 on {s(x) <= c} minus the equilibrium. For the IPC (ipc, ipc-flat) "
            "V is (3.11) in the flat coordinates, shape 'ball' is ||q||^2 = ||Tx||^2. For another "
            "system (path/file.py:NAME) V = x'Px with P = LYAPUNOV_P from the file, or else the "
            "solution of A'P + PA = -I for the linearisation A; shape 'ball' is ||x - x_eq||^2."
        ),
    )
    p.add_argument("--system", default="ipc", help="ipc, ipc-flat, vanderpol or path/file.py:NAME")
    p.add_argument(
        "--shape",
        choices=("ball", "level"),
        default="ball",
        help="ball: Euclidean (IPC: ||q||^2); level: sublevel sets of V",
    )
    p.add_argument("--method", choices=("sampled", "casadi", "both"), default="both")
    p.add_argument(
        "--directions",
        type=int,
        default=20000,
        help="sampled: number of ray directions (default 20000)",
    )
    p.add_argument("--starts", type=int, default=16, help="casadi: IPOPT starts (default 16)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def setup(spec: str) -> tuple[Any, Any, dict[str, np.ndarray], bool]:
    """(system, V, {shape: matrix}, is_ipc) for a --system spec."""
    from roa.lyapunov import QuadraticLyapunov
    from roa.systems import load_module_attr, load_system

    if spec in ("ipc", "ipc-flat"):
        from roa.systems.ipc import lyapunov as ly

        shapes = {s: ly.shape_matrix(s) for s in ly.SHAPES}
        return ly.flat_system(), ly.paper_lyapunov(), shapes, True
    system = load_system(spec)
    if system.equilibrium is None:
        raise ValueError(f"--system {spec}: no equilibrium (time-varying); nothing to search")
    P = load_module_attr(spec, "LYAPUNOV_P")
    if P is None:
        from roa.levelset import lyapunov_matrix

        P = lyapunov_matrix(system)
    V = QuadraticLyapunov.for_system(system, P)
    return system, V, {"ball": np.eye(system.n), "level": V.P}, False


def run(args: argparse.Namespace) -> int:
    from roa.levelset import level_search

    if args.directions < 16:
        raise ValueError(f"--directions must be >= 16, got {args.directions}")
    if args.starts < 1:
        raise ValueError(f"--starts must be >= 1, got {args.starts}")
    system, V, shapes, is_ipc = setup(args.system)
    res = level_search(
        system,
        V,
        shapes[args.shape],
        shape=args.shape,
        method=args.method,
        sampled={"n_directions": args.directions, "seed": args.seed},
        casadi={"n_starts": args.starts, "seed": args.seed + 1},
    )
    res["system"] = args.system
    res["P"] = V.P.tolist()
    if is_ipc and res["witness"] is not None:
        from roa.systems.ipc import from_flat
        from roa.systems.ipc.lyapunov import Phi, to_q

        xi = np.asarray(res["witness"])
        res.update(
            witness_q=to_q(xi).tolist(),
            witness_physical=from_flat(xi).tolist(),
            Phi_witness=float(Phi(to_q(xi))),
        )
    if args.json:
        print(to_json(res))
        return 0 if res["status"] in ("found", "agree") else 1
    what = (
        "||q||^2"
        if is_ipc and args.shape == "ball"
        else ("V" if args.shape == "level" else "||x||^2")
    )
    print(
        f"{args.system}: largest {what} level with V' < 0: {res['value']:.10g}  "
        f"[{res['method']}, {res['status']}]"
    )
    for name, r in res.get("per_method", {}).items():
        print(f"  {name:8s} {r['value']:.10g}  ({r['status']})")
    if res["witness"] is not None:
        print(
            f"  witness x = {np.array2string(np.asarray(res['witness']), precision=6)}, "
            f"V'(x) = {res['vdot_witness']:.2e}"
        )
        if "witness_physical" in res:
            print(
                f"  witness q = {np.array2string(np.asarray(res['witness_q']), precision=6)}; "
                f"physical (q, q', theta, theta') = "
                f"{np.array2string(np.asarray(res['witness_physical']), precision=6)}"
            )
    return 0 if res["status"] in ("found", "agree") else 1
