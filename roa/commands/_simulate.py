"""``roa simulate``: one trajectory of any system, a thin shell over :func:`roa.simulate`."""

from __future__ import annotations

import argparse

from roa import numparse
from roa.commands import _common as C


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate",
        help="simulate a system from one initial state (status: converged, left_domain, ...)",
        description="One trajectory by scipy's solve_ivp (DOP853) until it converges to the "
        "equilibrium, leaves the domain, diverges (its norm reaches --diverge-bound, or it is "
        "still growing exponentially far out at --t-final: --diverge-growth) or reaches "
        "--t-final. Exit code 1 iff diverged.",
    )
    C.add_system(p)
    p.add_argument("--x0", "--ic", dest="x0", required=True, metavar="X1,X2,...",
                   help="initial state, one number per state of the system")  # fmt: skip
    C.add_stop_rules(p)
    p.add_argument("--time-limit", type=numparse.arg(), default=None, metavar="SECONDS",
                   help="wall-clock budget of the run (> 0); then it ends undecided")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument(
        "--plot",
        default=None,
        metavar="FILE",
        help="save a plot of the run (PNG): the states against time and, for a "
        "closed loop with a feedback (System.from_control), its inputs u(t) below",
    )
    p.set_defaults(func=run)


def compute(args: argparse.Namespace):  # noqa: ANN201 - the API's result
    import numpy as np

    import roa
    from roa.errors import RoaInputError

    system = C.system(args)
    x0 = np.array(C.floats(args.x0, "--x0", system.n))
    rules = C.stop_rules(args)
    try:
        return roa.simulate(system, x0, rules=rules, time_limit=args.time_limit)
    except RoaInputError as exc:
        raise RoaInputError(f"--x0: {exc}") from None


def run(args: argparse.Namespace) -> int:
    import numpy as np

    if args.plot:
        from roa.io import check_figure_path

        check_figure_path(args.plot)
    traj = compute(args)
    out = traj.to_dict()
    if args.plot:
        import matplotlib.pyplot as plt

        from roa.io import atomic_savefig

        fig = traj.plot().figure  # the states and, for a closed loop, its inputs u(t) below
        if fig.get_layout_engine() is None:
            fig.tight_layout()
        atomic_savefig(fig, args.plot)
        plt.close(fig)
        out["plot"] = args.plot
    if args.json:
        C.emit(args, out)
    else:
        print(f"status: {out['status']} ({traj.message})")
        print(f"final state ({', '.join(out['state_names'])}):",
              np.array2string(traj.final_state, precision=6))  # fmt: skip
        if "input_names" in out:
            print(f"final input ({', '.join(out['input_names'])}):",
                  np.array2string(np.asarray(out["final_input"]), precision=6),
                  f"(largest |u| along the run: {np.array2string(np.asarray(out['max_abs_input']), precision=4)})")  # fmt: skip
    return 1 if traj.status.value == "diverged" else 0
