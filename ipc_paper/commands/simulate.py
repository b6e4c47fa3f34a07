"""``roa study ipc simulate``: one closed-loop run of the IPC with the paper's controller settings
(reference tracking, poles, mass ratio, saturation, flat or physical coordinates)."""

from __future__ import annotations

import argparse
from typing import Any

from roa import numparse
from roa.commands import floats
from roa.errors import RoaInputError
from roa.io import to_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate",
        help="IPC study: one closed-loop run with the paper's controller options (reference, poles)",
    )
    p.add_argument(
        "--ic", required=True, help="initial state Q,QD,TH,THD (theta in rad, |theta| < pi/2)"
    )
    p.add_argument(
        "--reference",
        default=None,
        help="F*(t): 'sin:A,W', or an expression in t, e.g. '2*sin(t/2)'",
    )
    p.add_argument("--t-final", type=numparse.arg(), default=60.0, help="final time (default 60)")
    p.add_argument(
        "--delta", type=numparse.arg(), default=None, help="mass ratio M/m > 0 (default 1.0)"
    )
    p.add_argument(
        "--poles",
        default=None,
        help="4 closed-loop poles, e.g. --poles=-1,-1,-2,-2 (default -1,-1,-1,-1; complex as -1+1j)",
    )
    p.add_argument("--coefficients", default=None, help="h0,h1,h2,h3 of p(s) instead of --poles")
    p.add_argument(
        "--saturation", type=numparse.arg(), default=None, help="actuator limit |u| <= U"
    )
    p.add_argument("--time-limit", type=numparse.arg(), default=None, metavar="SECONDS",
                   help="wall-clock budget of the run (> 0); then it ends undecided")  # fmt: skip
    p.add_argument(
        "--coordinates",
        choices=("physical", "flat"),
        default="physical",
        help="integrate the physical model or the closed loop (3.8) in flat coordinates "
        "(default physical)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--plot", default=None, metavar="FILE", help="save a plot of the run (PNG)")
    p.set_defaults(func=run)


#: Largest |pole| of p(s) (or root of the --coefficients polynomial): the closed loop's stiffness
#: grows with it, and beyond this the explicit integrator would run for hours.
MAX_POLE = 1e3


def _gains(args: argparse.Namespace, gains_class: Any) -> Any:
    """The controller gains of ``--poles`` or ``--coefficients`` (default: the paper's); every
    problem is an input error naming the option."""
    import numpy as np

    if not (args.poles or args.coefficients):
        return gains_class.default()
    flag = "--poles" if args.poles else "--coefficients"
    try:
        if args.poles:
            try:
                poles = [complex(p.strip().replace("i", "j")) for p in args.poles.split(",")]
            except ValueError:
                raise RoaInputError(
                    f"expected comma-separated numbers (complex as -1+1j), got {args.poles!r}"
                ) from None
            if not all(np.isfinite(p.real) and np.isfinite(p.imag) for p in poles):
                raise RoaInputError(f"poles must be finite, got {args.poles!r}")
            gains = gains_class.from_poles(poles)
        else:
            gains = gains_class.from_coefficients(floats(args.coefficients, "--coefficients", 4))
        h = gains.h
        roots = np.roots([1.0, h[3], h[2], h[1], h[0]])
        if not np.max(np.abs(roots)) <= MAX_POLE:
            raise RoaInputError(
                f"every pole of p(s) must have |pole| <= {MAX_POLE:g} (a stiffer loop would run "
                f"for hours), got {np.max(np.abs(roots)):.4g}"
            )
    except RoaInputError as exc:
        msg = str(exc)
        raise RoaInputError(msg if msg.startswith(flag) else f"{flag}: {msg}") from None
    return gains


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from ipc_paper import system as ipc
    from ipc_paper.system.controller import Gains, make_reference
    from roa.integration import simulate
    from roa.status import StopRules

    x0 = np.array(floats(args.ic, "--ic", 4))
    if args.poles and args.coefficients:
        raise RoaInputError("--poles and --coefficients are exclusive")
    gains = _gains(args, Gains)
    if not args.t_final > 0:
        raise RoaInputError(f"--t-final must be > 0, got {args.t_final}")
    if not np.isfinite(x0).all():
        raise RoaInputError(f"--ic: the state must be finite (no NaN/inf), got {args.ic!r}")
    try:
        ipc.coordinates.check_physical(x0)
    except RoaInputError as exc:
        raise RoaInputError(f"--ic: {exc}") from None
    reference = make_reference(args.reference)
    delta = ipc.DEFAULT_DELTA if args.delta is None else args.delta
    rules = StopRules(t_final=args.t_final)
    if args.coordinates == "flat":
        system = ipc.transformed(gains=gains, reference=reference)
        traj = simulate(system, ipc.to_flat(x0), rules=rules, time_limit=args.time_limit)
        x_phys = ipc.from_flat(traj.x)
    else:
        system = ipc.closed_loop(
            delta=delta, gains=gains, reference=reference, saturation=args.saturation
        )
        traj = simulate(system, x0, rules=rules, time_limit=args.time_limit)
        x_phys = traj.x
    out = {
        "status": traj.status.value,
        "message": traj.message,
        "t_end": traj.t_end,
        "final_state": x_phys[-1].tolist(),
        "state_names": list(ipc.PHYSICAL_NAMES),
        "delta": delta,
        "gains": list(gains.h),
        "reference": reference.description,
    }
    if not reference.is_zero:
        z1 = ipc.to_flat(x_phys)[:, 0]
        err = np.abs(z1 - reference.derivatives(traj.t)[0])
        half = traj.t >= traj.t_end / 2
        out["tracking_error_max_last_half"] = float(err[half].max())
    if args.plot:
        from roa.plotting import plot_run

        plot_run(
            ipc.closed_loop(delta=delta, gains=gains),
            traj.t,
            x_phys,
            args.plot,
            title=f"IPC from {args.ic}: {traj.status.value}",
        )
        out["plot"] = args.plot
    if args.json:
        print(to_json(out))
    else:
        print(f"status: {out['status']} ({traj.message})")
        print("final state (q, q_dot, theta, theta_dot):", np.array2string(x_phys[-1], precision=6))
        if "tracking_error_max_last_half" in out:
            print(f"max |z1 - F*| over the last half: {out['tracking_error_max_last_half']:.4g}")
    return 0 if traj.status.value != "diverged" else 1
