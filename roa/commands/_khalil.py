"""``roa khalil``: Khalil's level-set search (3.15), a thin shell over :func:`roa.level_search`."""

from __future__ import annotations

import argparse

from roa import numparse
from roa.commands import _common as C


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "khalil",
        help="largest ball / V-level set on which V' < 0 (Khalil's search, sampled and CasADi)",
        description=(
            "Largest c with V' < 0 on {s(x) <= c} minus the equilibrium (roa.level_search). Shape "
            "'level': sublevel sets of V; 'ball': (x - x_eq)' S (x - x_eq) with the system's norm S "
            "(for ipc-flat the paper's ||q||^2 = ||T xi||^2; else the identity). Exit code 0 iff a "
            "level was found (and both methods agree)."
        ),
    )
    C.add_system(p, lyapunov=True)
    p.add_argument("--shape", choices=("ball", "level"), default="ball",
                   help="ball (default): the system's norm; level: sublevel sets of V")  # fmt: skip
    p.add_argument("--method", choices=("sampled", "casadi", "both"), default="both",
                   help="default both (they must agree)")  # fmt: skip
    p.add_argument("--directions", type=numparse.integer(), default=20000,
                   help="sampled: number of ray directions, 16..2000000 (default 20000)")  # fmt: skip
    p.add_argument("--starts", type=numparse.integer(), default=16,
                   help="casadi: IPOPT starts, 1..10000 (default 16)")  # fmt: skip
    p.add_argument(
        "--seed", type=numparse.integer(), default=0, help="random seed >= 0 (default 0)"
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def compute(args: argparse.Namespace):  # noqa: ANN201 - the API's result
    import roa

    flags = {"SampledOptions.n_directions": "--directions", "CasadiOptions.n_starts": "--starts",
             "SampledOptions.seed": "--seed", "CasadiOptions.seed": "--seed"}  # fmt: skip
    sampled, casadi = C.options(
        lambda: (
            roa.SampledOptions(n_directions=args.directions, seed=args.seed),
            roa.CasadiOptions(n_starts=args.starts, seed=args.seed + 1),
        ),
        flags,
    )
    system = C.system(args)
    V = C.lyapunov(args, system)
    return roa.level_search(system, V, shape=args.shape, method=args.method, sampled=sampled,
                            casadi=casadi)  # fmt: skip


def run(args: argparse.Namespace) -> int:
    import numpy as np

    res = compute(args)
    if args.json:
        C.emit(args, res.to_dict())
        return 0 if res.ok else 1
    what = "V" if args.shape == "level" else "ball"
    name = res.system.name if res.system is not None else args.system
    print(f"{name}: largest {what} level with V' < 0: {C.fmt(res.level, '.10g')}  "
          f"[{res.method}, {res.status.value}]")  # fmt: skip
    if args.shape == "ball":  # the default differs from certify's: say which one this is
        print("  shape ball: the level c bounds (x - x_eq)' S (x - x_eq) with the system's norm S; "
              "roa certify and --shape level work on levels of V")  # fmt: skip
    for name, r in res.per_method.items():
        print(f"  {name:8s} {C.fmt(r.level, '.10g')}  ({r.status.value})")
    if res.witness is not None:
        print(f"  witness x = {np.array2string(res.witness, precision=6)}, "
              f"V'(x) = {C.fmt(res.vdot_witness, '.2e')}")  # fmt: skip
    if res.message:
        print(f"  {res.message}")
    return 0 if res.ok else 1
