"""``roa certify``: certify or refute a Lyapunov level set, a thin shell over :func:`roa.certify`."""

from __future__ import annotations

import argparse

from roa import numparse
from roa.commands import _common as C
from roa.options import IntervalOptions, SosOptions, VsOptions


def register(sub: argparse._SubParsersAction) -> None:
    sos, itv = SosOptions(), IntervalOptions()
    p = sub.add_parser(
        "certify",
        help="certify V' < 0 on {V <= level} (SOS + interval validation)",
        description=(
            "Certify that the sublevel set {V <= level} of a Lyapunov candidate V (any V: the "
            "system's default quadratic, a matrix, a polynomial JSON or file.py:NAME, see "
            "--lyapunov) lies in the region of attraction: V' < 0 on it minus the equilibrium (and inside the system's "
            "domain). With --level, that level is checked by interval branch and bound "
            "(certified / refuted with a 50-digit checked witness / inconclusive). Without --level "
            "(the default, --maximise), a candidate level is found first -- by the SOS program "
            f"(validated at {sos.safety_factor} x its level) and/or the sampled level search "
            f"(validated at {itv.sampled_safety} x the sampled optimum) -- and then validated. "
            "Only a check independent of the solver gives status 'certified': the interval "
            "branch and bound or the exact rational check of an SOS certificate (sos-exact). "
            "Exit code 0 iff certified. "
            "For a system with uncertain parameters (--param NAME=LOW..HIGH, or declared by the "
            "system) the level holds for every parameter of the box (--nominal: the nominal "
            "values only); a refutation names the parameter values of its witness. Without "
            "--lyapunov, a V designed for the box (common Lyapunov LMIs at its vertices and grid "
            "points) replaces the system's own V where that fails at the linearisation for some "
            "parameter value; a given V that fails there is reported with that value."
        ),
    )
    C.add_system(p, lyapunov=True)
    g = p.add_mutually_exclusive_group()
    g.add_argument("--level", type=numparse.arg(0.0, numparse.MAX_LEVEL, low_open=True), default=None,
                   help="validate this level in (0, 1e150] by interval branch and bound; default: "
                   "maximise")  # fmt: skip
    g.add_argument("--maximise", action="store_true",
                   help="find the largest level, then validate it (default: what happens without --level)")  # fmt: skip
    p.add_argument(
        "--method",
        choices=("sos", "interval", "both"),
        default=None,
        help="how to find the level when maximising: sos (SOS program only, an uncertified "
        "candidate), interval (sampled search, then interval validation), both (SOS, then "
        "interval validation; sampled search if SOS fails). With --level only 'interval' is "
        "possible. Default: both, or interval with --level",
    )
    p.add_argument("--max-boxes", type=numparse.integer(), default=itv.max_boxes,
                   help=f"box budget of the interval validation, 1..2e8 (default {itv.max_boxes})")  # fmt: skip
    p.add_argument("--check-above", type=numparse.arg(), default=None, metavar="FACTOR",
                   help="also validate FACTOR x the candidate level (> 1, e.g. 1.001): a refutation "
                   "there shows the certified level is close to the best for this V")  # fmt: skip
    p.add_argument("--degree", type=numparse.integer(), default=None, choices=(2, 4, 6, 8),
                   help="search a polynomial V of this degree by SOS V-s iteration (seeded by the "
                   "quadratic --lyapunov or the system's default), then certify it; its "
                   "coefficients are in the JSON (candidate_kind)")  # fmt: skip
    p.add_argument("--rounds", type=numparse.integer(), default=VsOptions().rounds,
                   help=f"V-s rounds with --degree, 1..50 (default {VsOptions().rounds})")  # fmt: skip
    p.add_argument("--budget", type=numparse.arg(), default=VsOptions().budget, metavar="SEC",
                   help="wall-clock seconds of the V-s iteration with --degree (> 0, default "
                   f"{VsOptions().budget:g}): it then stops with the rounds it completed")  # fmt: skip
    p.add_argument("--objective", choices=("shape", "volume"), default=VsOptions().objective,
                   help="what each V step of --degree enlarges: shape (the level of the seed's "
                   "ellipsoid inside the set) or volume (the set itself, by V's mean over a cube)"
                   f" (default {VsOptions().objective})")  # fmt: skip
    p.add_argument("--time-limit", type=numparse.arg(), default=None, metavar="SEC",
                   help="wall-clock budget of each interval validation, in (0, 1e9] seconds: "
                   "when it runs out the verdict is inconclusive, saying so; with --degree also "
                   "of the V-s iteration (the least of it and --budget), which then stops with "
                   "the rounds completed, status stopped (default: 3600, and 300 for the branch and "
                   "bound backing up the SOS route above 4 states and parameters); every other "
                   "long step (the SOS program, a level search, tracing the field) is stopped at "
                   "it, exit 1 naming the step")  # fmt: skip
    p.add_argument("--validator", choices=("auto", "interval", "sos"), default="auto",
                   help="what proves the level: auto (default: the interval branch and bound up "
                   "to 4 states and parameters, the exact SOS certificate above, each backing up "
                   "the other), interval (branch and bound only) or sos (exact SOS certificate "
                   "of a polynomial or exactly recast field)")  # fmt: skip
    p.add_argument("--nominal", action="store_true",
                   help="for a system with uncertain parameters: certify at their nominal values "
                   "only (default: for every parameter of the box)")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print one JSON object (default: text)")
    p.set_defaults(func=run)


def compute(args: argparse.Namespace):  # noqa: ANN201 - the API's result
    import roa
    from roa.errors import RoaInputError

    if args.level is not None and args.method not in (None, "interval"):
        raise RoaInputError(
            f"--method {args.method} with --level: a given level is checked by interval "
            "validation only; use --method interval (or omit --method), or drop --level to let "
            f"{args.method} find the level"
        )
    if args.level is not None and not args.level > 0:
        raise RoaInputError(f"--level must be a finite number > 0, got {args.level}")
    interval = C.options(
        lambda: roa.IntervalOptions(max_boxes=args.max_boxes, time_limit=args.time_limit),
        {"IntervalOptions.max_boxes": "--max-boxes", "IntervalOptions.time_limit": "--time-limit"},
    )
    if args.check_above is not None and not args.check_above > 1:
        raise RoaInputError(f"--check-above must be a finite number > 1, got {args.check_above}")
    system = C.system(args)
    if args.nominal:
        system = system.nominal()
    V = C.lyapunov(args, system)
    if args.degree is not None:
        if args.level is not None or args.method is not None:
            raise RoaInputError("--degree searches V and its level: drop --level and --method")
        # --time-limit bounds the V-s iteration too: it stops with the best round so far
        budget = args.budget if args.time_limit is None else min(args.budget, args.time_limit)
        vs = C.options(lambda: roa.VsOptions(rounds=args.rounds, budget=budget,
                                             objective=args.objective),
                       {"VsOptions.rounds": "--rounds", "VsOptions.budget": "--budget"})  # fmt: skip
        return roa.certify(system, V, degree=args.degree, vs=vs, interval=interval,
                           check_above=args.check_above, validator=args.validator)  # fmt: skip
    method = args.method or ("interval" if args.level is not None else "both")
    return roa.certify(system, V, level=args.level, method=method, interval=interval,
                       check_above=args.check_above, validator=args.validator)  # fmt: skip


def run(args: argparse.Namespace) -> int:
    cert = compute(args)
    out = cert.to_dict()
    if args.json:
        C.emit(args, out)
        return 0 if cert.certified else 1
    print(f"{out.get('system')}: V = {out.get('lyapunov')}")
    if "parameters" in out:
        box = ", ".join(f"{k} in [{r['low']:.6g}, {r['high']:.6g}]"
                        for k, r in out["parameters"].items())  # fmt: skip
        print(f"  for every parameter of the box: {box}")
    if cert.sos is not None:
        s = cert.sos
        print(f"  SOS: {s.status.value} (solver {s.solver_status}), level {C.fmt(s.level)}, "
              f"{s.seconds:.3g} s")  # fmt: skip
    if cert.vs is not None:
        r = cert.vs
        print(f"  V-s iteration (degree {r.degree}): {r.status.value}, {len(r.rounds)} rounds, "
              f"{r.seconds:.3g} s; {r.message}")  # fmt: skip
    if cert.safety_factor is not None:
        print(f"  candidate from {cert.level_source}: {C.fmt(cert.candidate)} "
              f"(validating {cert.safety_factor} x it)")  # fmt: skip
    v = cert.validation
    boxes = "no boxes" if v is None else f"{v.boxes} boxes"
    print(f"  {cert.status.value}: level {C.fmt(cert.level)}, by {cert.method}, {boxes}, "
          f"{cert.seconds:.3g} s")  # fmt: skip
    if cert.message:
        print(f"  {cert.message}")
    if v is not None and v.witness is not None:
        print(f"  witness: {v.witness}  ({v.witness_check})")
        if v.witness_parameters:
            print(f"  witness parameters: {v.witness_parameters}")
    if cert.above is not None:
        print(f"  above: {cert.above.status.value} at {C.fmt(cert.above.level)}")
    return 0 if cert.certified else 1
