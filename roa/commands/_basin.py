"""``roa basin``: Monte Carlo basin of attraction over a 2D slice or a box (:func:`roa.basin`)."""

from __future__ import annotations

import argparse
import itertools
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

from roa import numparse
from roa.commands import _common as C
from roa.errors import RoaInputError
from roa.io import atomic_write_json, check_figure_path, to_json
from roa.options import DEFAULT_PARAM_SAMPLES, MAX_PARAM_SAMPLES
from roa.shares import interval, share

if TYPE_CHECKING:
    from roa.model._system import System

EPILOG = """examples:
  roa basin --system ipc --slice theta,theta_dot --grid 200x150 --box theta=-1.57:1.57,theta_dot=-6:6 --plot map.png
  roa basin --system ipc:saturation=2 --slice q,theta --grid 100x100 --fix theta_dot=0.5 --json
  roa basin --system vanderpol --slice x1,x2 --grid 100x100 --box x1=-3:3,x2=-3:3 --plot map.png --trajectories 16
  roa basin --system ipc --samples 1000000 --box q=-1:1,q_dot=-1:1,theta=-1:1,theta_dot=-1:1 --out runs/box
  roa basin --system ipc --samples 20000 --scheduler tcp://10.0.0.5:8786 --json
  roa basin --system vanderpol --param mu=0.8..1.2 --param-samples 8 --slice x1,x2 --grid 80x80 --box x1=-3:3,x2=-3:3 --terminal-set cert.json --plot robust.png

For a system with uncertain parameters (--param NAME=LOW..HIGH, or declared by the system) every
initial state is run at each parameter sample (the nominal values, the box's vertices and
--param-samples seeded uniform samples, seed --seed); the JSON keeps every sample's counts per
status, and the maps derived from them: the converged share per initial state and the worst case
(converged for every sampled value; nothing is claimed between samples). --nominal: the nominal
values only.
"""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "basin",
        help="Monte Carlo basin of attraction: statuses over a 2D slice or random samples of a box",
        description=(
            "Simulate many initial conditions and report how each run ends (converged, "
            "left_domain, diverged, undecided; never merged): a 2D slice through the equilibrium "
            "(--slice A,B --grid NxM, the other states at the equilibrium or --fix) or seeded "
            "uniform samples of a box (--samples N). --box ranges every sampled state (default "
            "without --box: equilibrium +- 1). --plot draws the slice's map, with the sets "
            "{V <= RHO} of --lyapunov-level validated and drawn over it; --out makes the run "
            "resumable. Exit 0 when every run was done, 1 when --time-limit cut the run short."
        ),
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    C.add_system(p, lyapunov=True)
    p.add_argument(
        "--slice", default=None, metavar="AXIS1,AXIS2", help="two state names, e.g. theta,theta_dot"
    )
    p.add_argument(
        "--grid", default=None, metavar="NxM", help="grid points along AXIS1 x AXIS2, e.g. 200x150"
    )
    p.add_argument("--fix", action="append", default=[], metavar="NAME=VALUE",
                   help="value of a state off the slice (default: the equilibrium); repeatable")  # fmt: skip
    p.add_argument("--box", default=None, metavar="NAME=LO:HI,...",
                   help="ranges of the slice axes or of the sampled box, every one of them "
                   "(default without --box: equilibrium +- 1)")  # fmt: skip
    p.add_argument(
        "--samples",
        type=numparse.integer(),
        default=None,
        help="N seeded uniform samples of the box",
    )
    C.add_stop_rules(p)
    p.add_argument(
        "--rtol", type=numparse.arg(), default=1e-6, help="relative tolerance (default 1e-6)"
    )
    p.add_argument(
        "--atol", type=numparse.arg(), default=1e-9, help="absolute tolerance (default 1e-9)"
    )
    p.add_argument(
        "--chunk-size",
        type=numparse.integer(),
        default=4096,
        help="initial conditions per task (default 4096)",
    )
    p.add_argument(
        "--jobs",
        type=numparse.integer(),
        default=-1,
        help="parallel workers (default -1: all cores)",
    )
    p.add_argument(
        "--seed", type=numparse.integer(), default=0, help="seed of the random samples (default 0)"
    )
    p.add_argument(
        "--scheduler", default=None, metavar="ADDRESS", help="Dask scheduler, e.g. tcp://host:8786"
    )
    p.add_argument(
        "--out", default=None, metavar="DIR", help="resumable run directory (chunks, summary.json)"
    )
    p.add_argument("--force", action="store_true",
                   help="with --out: recompute every chunk instead of resuming (default: resume)")  # fmt: skip
    p.add_argument("--plot", default=None, metavar="FILE", help="save the slice's basin map (PNG)")
    p.add_argument("--trajectories", type=numparse.integer(), default=0, metavar="N",
                   help="with --plot: overlay N trajectories (roa simulate, the same stop rules) "
                   "started at N states spread over the slice, coloured by how they end, in "
                   "[1, 400]; projected onto the slice when the system has more states")  # fmt: skip
    p.add_argument("--time-limit", type=numparse.arg(), default=None, metavar="SEC",
                   help="wall-clock budget in seconds, in (0, 1e9]: when it runs out the run ends "
                   "inconclusive (exit 1) with the runs not run counted as not_run, no plot; "
                   "with --out the same command resumes from the completed chunks; tracing the "
                   "field for the compiled kernel is stopped at it (exit 1)")  # fmt: skip
    p.add_argument(
        "--lyapunov-level",
        type=numparse.arg(0.0, numparse.MAX_LEVEL, low_open=True),
        action="append",
        default=[],
        metavar="RHO",
        help="draw {V <= RHO} for --lyapunov (any V: a matrix, a polynomial JSON such as the "
        "output of `roa certify --degree D --json`, or file.py:NAME; default the system's V) after "
        "validating RHO with interval arithmetic (degree and verdict go in the legend); the "
        "share of converged points inside it, with a 95 %% interval, is printed and in the JSON "
        "(certified_share); repeatable",
    )
    p.add_argument(
        "--terminal-set",
        default=None,
        metavar="FILE",
        help="JSON of `roa certify --json` (status certified, for this system or its analysis "
        "coordinates, e.g. ipc-flat for ipc; quadratic V, or polynomial with --degree): runs "
        "entering {V <= level} stop as converged",
    )
    p.add_argument(
        "--param-samples", type=numparse.integer(), default=None, metavar="N",
        help="for a system with uncertain parameters: seeded uniform samples of the parameter box "
        f"on top of the nominal values and the vertices, in [0, {MAX_PARAM_SAMPLES}] (default "
        f"{DEFAULT_PARAM_SAMPLES}; seed --seed)",
    )  # fmt: skip
    p.add_argument("--nominal", action="store_true",
                   help="for a system with uncertain parameters: run at their nominal values only")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(func=run)


def parse_grid(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*([0-9]{1,9})\s*[xX]\s*([0-9]{1,9})\s*", text or "")
    if not m:
        raise RoaInputError(
            f"--grid: expected NxM with integers N, M >= 2 (e.g. 200x150), got "
            f"{numparse.shown(text)}"
        )
    nx, ny = int(m.group(1)), int(m.group(2))
    if nx < 2 or ny < 2 or nx * ny > 10**8:
        raise RoaInputError(f"--grid: N and M must be >= 2 and N*M <= 1e8, got {nx}x{ny}")
    return nx, ny


def parse_box(text: str | None, names: tuple[str, ...]) -> dict[str, tuple[float, float]]:
    import numpy as np

    out: dict[str, tuple[float, float]] = {}
    for part in (text or "").split(","):
        if not part.strip():
            continue
        m = re.fullmatch(r"\s*([A-Za-z_]\w*)\s*=\s*([^:]+):(.+)", part)
        if not m:
            raise RoaInputError(f"--box: expected NAME=LO:HI, got {part!r}")
        name = m.group(1)
        if name not in names:
            raise RoaInputError(f"--box: unknown state {name!r}; allowed: {', '.join(names)}")
        lo = numparse.parse_number(m.group(2), f"--box {name}")
        hi = numparse.parse_number(m.group(3), f"--box {name}")
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise RoaInputError(f"--box {name}: need finite LO < HI, got {lo}:{hi}")
        out[name] = (lo, hi)
    return out


def parse_fix(items: list[str], names: tuple[str, ...]) -> dict[str, float]:
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep:
            raise RoaInputError(f"--fix: expected NAME=VALUE, got {item!r}")
        if name not in names:
            raise RoaInputError(f"--fix: unknown state {name!r}; allowed: {', '.join(names)}")
        out[name] = numparse.parse_number(value, f"--fix {name}")
    return out


def build(args: argparse.Namespace):
    """Validate everything and return ``(system, sampler, rules)`` before any work."""

    from roa.montecarlo._sampling import box_sample, grid_slice

    system = C.system(args)
    if getattr(args, "nominal", False):
        system = system.nominal()
    if system.parameters:
        if args.param_samples is None:
            args.param_samples = DEFAULT_PARAM_SAMPLES
        n = args.param_samples
        if not 0 <= n <= MAX_PARAM_SAMPLES:
            raise RoaInputError(
                f"--param-samples must be an integer in [0, {MAX_PARAM_SAMPLES}], got {n!r}"
            )
        if not 0 <= args.seed < 2**63:
            raise RoaInputError(f"--seed must be an integer in [0, 2^63), got {args.seed}")
    elif args.param_samples is not None:
        raise RoaInputError(
            "--param-samples applies to a system with uncertain parameters (--param "
            f"NAME=LOW..HIGH); {args.system} has none" + (" with --nominal" if args.nominal else "")
        )
    if system.equilibrium is None or system.time_varying:
        raise RoaInputError(
            f"--system {args.system}: basins need an autonomous system with an equilibrium"
        )
    rules = C.stop_rules(args)
    names = system.state_names
    box = parse_box(args.box, names)
    fixed = parse_fix(args.fix, names)
    x_eq = system.x_eq

    def rng(name: str) -> tuple[float, float]:
        i = names.index(name)
        return box.get(name, (x_eq[i] - 1.0, x_eq[i] + 1.0))

    def require_box(needed: list[str]) -> None:
        """A --box given must range every state sampled: a state left out is an error, never a
        silent equilibrium +- 1 (that default holds only without --box)."""
        missing = [a for a in needed if a not in box]
        if box and missing:
            raise RoaInputError(
                f"--box gives no range for {', '.join(missing)}: give NAME=LO:HI for each of "
                f"{', '.join(needed)} (without --box every range is the equilibrium +- 1)"
            )

    if (args.slice is None) == (args.samples is None):
        raise RoaInputError("give either --slice AXIS1,AXIS2 with --grid NxM, or --samples N")
    if args.slice is not None:
        if args.grid is None:
            raise RoaInputError("--slice needs --grid NxM")
        axes = [a.strip() for a in args.slice.split(",")]
        if len(axes) != 2:
            raise RoaInputError(
                f"--slice: expected two state names AXIS1,AXIS2, got {args.slice!r}"
            )
        for a in axes:
            if a not in names:
                raise RoaInputError(f"--slice: unknown state {a!r}; allowed: {', '.join(names)}")
        extra = set(box) - set(axes)
        if extra:
            raise RoaInputError(f"--box: {sorted(extra)} are not slice axes (use --fix for them)")
        require_box(axes)
        shape = parse_grid(args.grid)
        sampler = grid_slice(system, axes, [rng(a) for a in axes], shape, fixed=fixed)
        _check_box_in_domain(
            system,
            [rng(n) if n in axes else (b, b) for n, b in zip(names, sampler.base, strict=True)],
        )
    else:
        if args.grid is not None or fixed:
            raise RoaInputError("--grid and --fix apply to --slice runs, not to --samples")
        if args.samples < 1:
            raise RoaInputError(f"--samples must be >= 1, got {args.samples}")
        require_box(list(names))
        ranges = [rng(n) for n in names]
        _check_box_in_domain(system, ranges)
        sampler = box_sample(system, ranges, args.samples, seed=args.seed)  # type: ignore[assignment]
    if args.chunk_size < 1:
        raise RoaInputError(f"--chunk-size must be >= 1, got {args.chunk_size}")
    if args.jobs == 0 or args.jobs < -1:
        raise RoaInputError(f"--jobs must be >= 1 or -1 (all cores), got {args.jobs}")
    return system, sampler, rules


def _check_box_in_domain(system: System, ranges: list[tuple[float, float]]) -> None:
    """Reject ranges that reach outside the system's domain (before any work starts).

    Every corner of the box must lie inside the domain (exact for domains that are boxes or
    convex, such as the IPC's |theta| < pi/2).
    """
    import numpy as np

    if system.margin is None:
        return
    names = system.state_names
    corners = np.array(list(itertools.product(*ranges)), dtype=float)
    bad = ~system.inside(corners)
    if bad.any():
        c = corners[np.argmax(bad)]
        raise RoaInputError(
            f"--box: the corner {dict(zip(names, np.round(c, 6).tolist(), strict=True))} is outside "
            f"the domain of {system.name} ({system.domain_description}); shrink the range"
        )


def lyapunov_regions(args: argparse.Namespace, system: System) -> list:
    """Regions {V <= rho} of ``--lyapunov-level`` for any ``--lyapunov`` (quadratic, polynomial,
    any function), each with the verdict of :func:`roa.certify` as its status."""
    import numpy as np

    import roa
    from roa.lyapunov._regions import Region
    from roa.plotting._basin import kind_text

    if not args.lyapunov_level:
        return []
    V = C.lyapunov(args, system)
    out = []
    for rho in args.lyapunov_level:
        if not (np.isfinite(rho) and rho > 0):
            raise RoaInputError(f"--lyapunov-level must be a finite number > 0, got {rho}")
        verdict = roa.certify(system, V, level=rho, method="interval")
        status = verdict.status.value
        reg = Region.from_lyapunov(f"V <= {rho:g} ({V.name})", V, rho, status)
        label = f"{V.name}: {kind_text(reg)} V <= {rho:g} [{status}]"
        if system.parameters:  # roa.certify decided it for every parameter of the box
            label += " for every parameter of the box"
        out.append(Region.from_lyapunov(reg.name, V, rho, status, None, {"label": label}))
    return out


def _check_out_dir(out: str | None) -> None:
    """``--out`` must be empty, new, or a previous ``roa basin`` run: never an experiment's results."""
    if out is None:
        return
    d = Path(out)
    for parent in d.resolve().parents:  # inside an experiment's folder, at any depth
        if (parent / "manifest.json").is_file():
            raise RoaInputError(
                f"--out {out}: it lies inside {parent}, the results of an experiment "
                "(manifest.json): choose a folder outside every experiment's results"
            )
    if d.is_dir() and any(d.glob("*/manifest.json")):
        raise RoaInputError(
            f"--out {out}: the directory holds the results of experiments (*/manifest.json): "
            "choose another --out directory"
        )
    if (d / "manifest.json").is_file():
        raise RoaInputError(
            f"--out {out}: this directory holds the results of an experiment (manifest.json); "
            "roa basin would overwrite them: choose another --out directory"
        )
    robust = (d / "parameter_samples.json").is_file()  # a robust run: param_NNN/chunks
    if d.is_dir() and any(d.iterdir()) and not (d / "chunks").is_dir() and not robust:
        raise RoaInputError(
            f"--out {out}: the directory exists and is not a roa basin run (no chunks/): choose an "
            "empty or new directory"
        )


def run(args: argparse.Namespace) -> int:
    import roa
    from roa.montecarlo._sampling import GridSlice

    _check_out_dir(args.out)
    system, sampler, rules = build(args)
    if args.plot and not isinstance(sampler, GridSlice):
        raise RoaInputError("--plot draws a slice: use it with --slice")
    if args.plot:
        check_figure_path(args.plot)
    if args.trajectories:
        from roa.plotting._basin import MAX_TRAJECTORIES

        if not 1 <= args.trajectories <= MAX_TRAJECTORIES:
            raise RoaInputError(
                f"--trajectories must be an integer in [1, {MAX_TRAJECTORIES}], got "
                f"{args.trajectories}"
            )
        if not (args.plot or args.out) or not isinstance(sampler, GridSlice):
            raise RoaInputError("--trajectories overlays runs on the slice's map: use it with "
                                "--slice and --plot")  # fmt: skip
        if system.parameters:
            raise RoaInputError(
                "--trajectories: a trajectory needs one value of each uncertain parameter; "
                "fix them with --param NAME=VALUE or --nominal"
            )
    plot = args.plot or (
        str(Path(args.out) / "basin.png") if args.out and isinstance(sampler, GridSlice) else None
    )
    regs = lyapunov_regions(args, system)
    terminal = None
    if args.terminal_set is not None:
        from roa.montecarlo._certified_set import terminal_from_certificate

        try:
            terminal = terminal_from_certificate(args.terminal_set, system)
        except RoaInputError as exc:
            raise RoaInputError(str(exc).replace("terminal set ", "--terminal-set ", 1)) from None
    integrator, run_opts = C.options(
        lambda: (
            roa.IntegratorOptions(rtol=args.rtol, atol=args.atol),
            roa.RunOptions(chunk_size=args.chunk_size, n_jobs=args.jobs, out_dir=args.out,
                           scheduler=args.scheduler, fresh=args.force,
                           time_limit=args.time_limit),
        ),
        {"IntegratorOptions.rtol": "--rtol", "IntegratorOptions.atol": "--atol",
         "RunOptions.chunk_size": "--chunk-size", "RunOptions.n_jobs": "--jobs",
         "RunOptions.time_limit": "--time-limit"},
    )  # fmt: skip
    if system.parameters:
        return _run_robust(args, system, sampler, rules, integrator, run_opts, terminal, regs,
                           plot)  # fmt: skip
    result = roa.basin(system, sampler, rules=rules, integrator=integrator, run=run_opts,
                       terminal=terminal, regions=regs)  # fmt: skip
    summary = result.to_dict()
    cut = result.status is roa.BasinStatus.INCONCLUSIVE
    if cut:
        summary["message"] = (
            f"the wall-clock budget of {args.time_limit:g} s ran out: "
            f"{summary['counts']['not_run']} of {summary['n']} initial conditions were not run "
            + ("(no plot drawn); run the same command again to resume from the completed chunks"
               if args.out else "(no plot drawn); give --out DIR to make a run resumable")
        )  # fmt: skip
    if plot and not cut:
        from roa.montecarlo._basin import overlay_runs
        from roa.plotting._basin import plot_slice

        runs = overlay_runs(system, sampler, args.trajectories, rules)
        if runs:
            summary["trajectories_drawn"] = {"n": len(runs), "counts": {
                s: sum(r.status.value == s for r in runs) for s in sorted({r.status.value for r in runs})}}  # fmt: skip
        plot_slice(system, sampler, result.code, plot, regions=regs, trajectories=runs,
                   title=f"basin of {system.name}")  # fmt: skip
    if args.out:
        atomic_write_json(Path(args.out) / "summary.json", summary)
    if summary.get("chunks_resumed"):  # a resumed run says what it reused (stderr: not data)
        import sys

        print(f"roa basin: resumed {summary['chunks_resumed']} completed chunk(s) from "
              f"{args.out}, computed {summary['chunks_computed']}", file=sys.stderr)  # fmt: skip
    if args.json:
        print(to_json(summary))
    else:
        c = summary["counts"]
        lo, hi = summary["fraction_converged_ci95"]
        print(f"n = {summary['n']}: " + ", ".join(f"{k} {v}" for k, v in c.items()))
        frac = summary["fraction_converged"]
        print(f"fraction converged {'unknown' if frac is None else share(frac, 4)} "
              f"(95 % CI {interval(lo, hi, 4)})")  # fmt: skip
        if terminal is not None:
            print(f"entered the certified set {terminal.name}: {summary['entered_certified_set']}")
        from roa.montecarlo._certified_share import share_line

        for entry in summary.get("certified_share", []):
            print(share_line(entry))
    if cut:
        import sys

        print(f"roa basin: inconclusive: {summary['message']}", file=sys.stderr)
        return 1
    return 0


def _run_robust(args: argparse.Namespace, system: System, sampler: Any, rules: Any,
                integrator: Any, run_opts: Any, terminal: Any, regs: list, plot: str | None
                ) -> int:  # fmt: skip
    """``roa basin`` on a system with uncertain parameters (:func:`roa.montecarlo._basin.robust_basin`)."""
    from roa.model._parameters import ParameterBox, describe_point
    from roa.montecarlo._basin import robust_basin

    result = robust_basin(system, sampler, param_samples=args.param_samples, param_seed=args.seed,
                          rules=rules, integrator=integrator, run=run_opts, terminal=terminal,
                          regions=regs if plot else ())  # fmt: skip
    summary = result.to_dict()
    if plot:
        result.plot(plot, title=f"robust basin of {system.name}")
    if args.out:
        atomic_write_json(Path(args.out) / "summary.json", summary)
    if args.json:
        print(to_json(summary))
        return 0
    print(f"n = {summary['n']} initial states x {len(result.samples)} parameter samples "
          f"({ParameterBox.of(system).describe()})")  # fmt: skip
    for entry in summary["per_parameter"]:
        c = entry["counts"]
        print(
            f"  {entry['kind']:8s} {describe_point(entry['parameters'])}: "
            + ", ".join(f"{k} {v}" for k, v in c.items())
        )
    w = summary["worst_case"]
    lo, hi = w["fraction_ci95"]
    print(f"converged for every sampled parameter value: {w['converged']} "
          f"({share(w['fraction'], 4)}, 95 % CI {interval(lo, hi, 4)}); mean converged "
          f"share {share(summary['converged_share']['mean'], 4)}")  # fmt: skip
    if terminal is not None:
        print(f"terminal set (proved for the whole box): {terminal.name}")
    from roa.montecarlo._certified_share import share_line

    for entry in summary.get("certified_share", []):  # over the worst case
        print(
            share_line(entry).replace(
                "the converged points", "the points converging for every sampled value"
            )
        )
    return 0
