"""Monte Carlo basin of attraction: :func:`basin` integrates every initial condition of a sampler.

Samplers (:mod:`roa.montecarlo._sampling`): :func:`grid_slice` (a 2-D slice), :func:`box_sample`
(seeded uniform samples of a box), :func:`region_sample` (inside or on a level set). Every run ends
with its own status (converged, left_domain, diverged, undecided), never merged.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.integration import _integrator as I  # noqa: N812
from roa.integration._terminal import TerminalSet
from roa.model._checks import check_system
from roa.model._system import System
from roa.montecarlo._certified_share import certified_shares
from roa.montecarlo._engine import converged_interval, run_basin
from roa.montecarlo._robust_basin import RobustBasinResult, parameter_samples
from roa.montecarlo._sampling import GridSlice
from roa.options import DEFAULT_PARAM_SAMPLES, IntegratorOptions, RunOptions
from roa.status import BasinStatus, StopRules


@dataclass(frozen=True)
class BasinResult:
    """Statuses of every initial condition of a sampler, counted per status.

    Attributes
    ----------
    status : BasinStatus
        ``all_converged``, ``partly_converged`` or ``none_converged``; ``inconclusive`` when the
        wall-clock budget (``RunOptions.time_limit``) ran out first.
    counts : dict
        Count per :class:`roa.status.RunStatus` value (converged, left_domain, diverged, undecided),
        and ``not_run`` (initial conditions without a status) when the budget ran out.
    fraction_converged, ci95 : float or None, (float, float)
        Share of converged runs and its 95 % Wilson interval; for an ``inconclusive`` run None and
        an interval that holds whatever the runs not run would give.
    code, t_end : ndarray
        Per initial condition: status code (:mod:`roa.integration._integrator`) and stop time.
    entered_certified_set : int
        Converged runs finished on entering the terminal set (counted in ``counts["converged"]``;
        their stop time is the entry time).
    terminal : TerminalSet or None
        The certified terminal set of the run, if any.
    backend : str
        What integrated the runs: ``numba`` (the system's own compiled field), ``numba-generated``
        (a kernel compiled from its traced field, :mod:`roa.integration._kernel_cache`) or
        ``numpy``; ``backend_note`` says why a field was not compiled.
    certified_shares : tuple of dict
        Per region given to :func:`basin` and for the terminal set: the share of the converged
        initial conditions inside it, with its 95 % Clopper-Pearson interval, over the slice or
        the sampled n-dimensional box (:mod:`roa.montecarlo._certified_share`, which says what the
        interval means for each). Empty without regions or terminal set.
    """

    status: BasinStatus
    n: int
    counts: dict[str, int]
    fraction_converged: float | None
    ci95: tuple[float, float]
    code: np.ndarray = field(repr=False)
    t_end: np.ndarray = field(repr=False)
    seconds: float
    chunks_computed: int
    chunks_resumed: int
    step_size_failures: int
    chunks_rejected: int
    system: System = field(repr=False, compare=False)
    sampler: Any = field(repr=False, compare=False)
    rules: StopRules = field(default_factory=StopRules)
    integrator: IntegratorOptions = field(default_factory=IntegratorOptions)
    entered_certified_set: int = 0
    terminal: TerminalSet | None = field(default=None, repr=False, compare=False)
    regions: tuple[Any, ...] = field(default=(), repr=False, compare=False)
    backend: str = "numpy"
    backend_note: str | None = None
    certified_shares: tuple[dict[str, Any], ...] = field(default=(), compare=False)

    def to_dict(self) -> dict[str, Any]:
        """What ``roa basin --json`` prints (with the command's description of the samples)."""
        return {
            "system": self.system.name,
            "status": self.status.value,
            "n": self.n,
            "counts": dict(self.counts),
            "undecided_step_size_failures": self.step_size_failures,
            "fraction_converged": self.fraction_converged,
            "fraction_converged_ci95": list(self.ci95),
            "ci_method": "Wilson score, 95 %",
            "t_final": self.rules.t_final,
            "converge_tol": self.rules.converge_tol,
            "diverge_bound": self.rules.diverge_bound,
            "diverge_growth": self.rules.diverge_growth,
            "rtol": self.integrator.rtol,
            "atol": self.integrator.atol,
            "chunks_computed": self.chunks_computed,
            "chunks_resumed": self.chunks_resumed,
            "chunks_rejected": self.chunks_rejected,
            "entered_certified_set": self.entered_certified_set,
            "terminal_set": None
            if self.terminal is None
            else {"name": self.terminal.name, "level": self.terminal.level,
                  "coords": self.terminal.coords, "margin": "V <= level (1 - 1e-9)"},
            "seconds": round(self.seconds, 3),
            "backend": self.backend,
            **({"backend_note": self.backend_note} if self.backend_note else {}),
            **(self.sampler.describe(self.system.state_names)
               if hasattr(self.sampler, "describe") else {}),
            **({"state_units": dict(zip(self.system.state_names, self.system.state_units,
                                        strict=True))}
               if self.system.state_units else {}),
            **({"regions": [region_entry(r, self.sampler, self.code) for r in self.regions]}
               if self.regions else {}),
            **({"certified_share": [dict(e) for e in self.certified_shares]}
               if self.certified_shares else {}),
        }  # fmt: skip

    def plot(self, ax: Any = None, *, regions: Any = (), title: str | None = None,
             trajectories: Any = 0, rules: StopRules | None = None) -> Any:  # fmt: skip
        """The basin map of a :func:`grid_slice` run, with optional regions drawn over it.

        ``trajectories``: a number ``k`` of runs to overlay, started at ``k`` states spread over
        the slice (:func:`roa.plotting._basin.trajectory_starts`), or an array of initial states;
        each is simulated by :func:`roa.simulate` (``rules``, default the run's) and
        drawn in the slice's coordinates, coloured by how it ended.
        """
        import matplotlib.pyplot as plt

        from roa.plotting._basin import draw_slice

        if not isinstance(self.sampler, GridSlice):
            raise RoaInputError("plot() draws a 2-D slice: run basin() on a grid_slice sampler")
        runs = overlay_runs(self.system, self.sampler, trajectories, rules or self.rules)
        if ax is None:
            _, ax = plt.subplots(figsize=(8.6, 6.0))
        draw_slice(ax, self.system, self.sampler, self.code, regions=regions, trajectories=runs,
                   title=f"basin of {self.system.name}" if title is None else title)  # fmt: skip
        return ax


def overlay_runs(system: System, grid: GridSlice, trajectories: Any,
                 rules: StopRules | None = None) -> list[Any]:  # fmt: skip
    """The runs a basin map overlays: none for ``0``/``None``, ``k`` runs from states spread over
    the slice for an integer ``k``, else one run from each given initial state (rows of ``n``)."""
    from roa.integration._simulation import simulate
    from roa.plotting._basin import trajectory_starts

    if trajectories is None or (isinstance(trajectories, int) and trajectories == 0):
        return []
    if isinstance(trajectories, int | np.integer) and not isinstance(trajectories, bool):
        starts = trajectory_starts(grid, int(trajectories))
    else:
        starts = system.check_state(np.atleast_2d(np.asarray(trajectories, dtype=float)),
                                    what="trajectories (initial states)")  # fmt: skip
    return [simulate(system, x0, rules=rules) for x0 in starts]


def basin(
    system: System,
    sampler: Any,
    *,
    rules: StopRules | None = None,
    integrator: IntegratorOptions | None = None,
    run: RunOptions | None = None,
    terminal: TerminalSet | str | Path | dict | None = None,
    regions: Sequence[Any] = (),
    param_samples: int = DEFAULT_PARAM_SAMPLES,
    param_seed: int = 0,
) -> Any:  # BasinResult, or RobustBasinResult for a system with uncertain parameters
    """Integrate every initial condition of ``sampler`` and count the statuses.

    For a system with uncertain parameters (``system.parameters``) this is
    :func:`robust_basin`: one run per parameter sample (nominal,
    vertices and ``param_samples`` seeded uniform samples drawn with ``param_seed``), returning a
    :class:`~roa.montecarlo.RobustBasinResult` (statuses per sample, never merged;
    the converged-share and worst-case maps derived from them). Otherwise a
    :class:`BasinResult`.

    Parameters
    ----------
    system : System
        Autonomous system with an equilibrium.
    sampler : GridSlice, BoxSample or RegionSample
        The initial conditions (:func:`roa.grid_slice`, :func:`roa.box_sample`, ...).
    rules : StopRules, optional
        ``t_final``, ``converge_tol``, ``diverge_bound``.
    integrator : IntegratorOptions, optional
        Tolerances and backend of the batch Dormand-Prince integrator.
    run : RunOptions, optional
        Workers, chunk size, resumable directory, Dask scheduler (none changes the result).
    terminal : TerminalSet, path or dict, optional
        A certified set ``{V <= level}`` (or the JSON of ``roa certify --json``, refused unless
        certified and for this system or its analysis coordinates): runs that enter it stop as
        converged, counted in ``entered_certified_set`` (:mod:`roa.integration._terminal`).
    regions : sequence of Region, optional
        Estimates to compare with the basin: on a :func:`grid_slice` the grid points inside
        each and whether all converged (``regions`` of :meth:`BasinResult.to_dict`); on any
        sampler the share of converged initial conditions inside each, and inside the terminal
        set, with a 95 % interval (``certified_shares``, JSON ``certified_share``).

    Examples
    --------
    >>> import roa
    >>> from roa.systems.vanderpol import vanderpol
    >>> sys_ = vanderpol()
    >>> grid = roa.grid_slice(sys_, ("x1", "x2"), [(-3, 3), (-3, 3)], (11, 11))
    >>> res = roa.basin(sys_, grid, run=roa.RunOptions(n_jobs=1))
    >>> res.status, res.counts["converged"] + res.counts["diverged"] == res.n
    (<BasinStatus.PARTLY_CONVERGED: 'partly_converged'>, True)
    """
    if system.parameters:
        return _over_box(system, sampler, param_samples, param_seed, rules, integrator, run,
                         terminal, regions)  # fmt: skip
    return _at_fixed_parameters(system, sampler, rules, integrator, run, terminal, regions)


def robust_basin(
    system: System,
    sampler: Any,
    *,
    param_samples: int = DEFAULT_PARAM_SAMPLES,
    param_seed: int = 0,
    rules: StopRules | None = None,
    integrator: IntegratorOptions | None = None,
    run: RunOptions | None = None,
    terminal: TerminalSet | str | Path | dict | None = None,
    regions: Sequence[Any] = (),
) -> RobustBasinResult:
    """:func:`basin` of a system with uncertain parameters (a :class:`roa.RoaInputError` for
    one without): the basin at every parameter sample (:func:`parameter_samples` with
    ``param_samples`` random ones and ``param_seed``); see :mod:`roa.montecarlo._robust_basin` for
    what the derived maps claim. ``terminal`` (a certificate file or its dict) is re-verified for
    the whole box once, then finishes runs at every sample. With ``run.out_dir``, sample ``i``
    runs (and resumes) in ``out_dir/param_{i:03d}``, and ``out_dir/parameter_samples.json`` lists
    the samples."""
    if not system.parameters:
        raise RoaInputError(
            f"system {system.name!r} declares no uncertain parameters: use roa.basin (or "
            "--param NAME=LOW..HIGH for a box)"
        )
    return _over_box(system, sampler, param_samples, param_seed, rules, integrator, run,
                     terminal, regions)  # fmt: skip


def _over_box(system: System, sampler: Any, param_samples: int, param_seed: int,
              rules: StopRules | None, integrator: IntegratorOptions | None,
              run: RunOptions | None, terminal: TerminalSet | str | Path | dict | None,
              regions: Sequence[Any]) -> RobustBasinResult:  # fmt: skip
    """The basin at every parameter sample of ``system``'s box (see :func:`robust_basin`)."""
    t0 = time.perf_counter()
    samples = parameter_samples(system, param_samples, param_seed)
    run = RunOptions() if run is None else run
    if terminal is not None and not isinstance(terminal, TerminalSet):
        from roa.montecarlo._certified_set import terminal_from_certificate

        terminal = terminal_from_certificate(terminal, system)  # proved for the whole box
    if run.out_dir is not None:
        from roa.io import atomic_write_json

        Path(run.out_dir).mkdir(parents=True, exist_ok=True)
        atomic_write_json(Path(run.out_dir) / "parameter_samples.json",
                          {"seed": int(param_seed), "random": int(param_samples),
                           "samples": [s.to_dict() for s in samples]})  # fmt: skip
    # one traced and compiled kernel for every sample (parameters are its arguments)
    from roa.integration._kernel_cache import compiled_system

    backend = "auto" if integrator is None else integrator.backend
    system, _, _ = compiled_system(
        system, backend, terminal, int(getattr(sampler, "n", 0)) * len(samples)
    )
    runs = []
    for s in samples:
        sub = run if run.out_dir is None else replace(
            run, out_dir=str(Path(run.out_dir) / f"param_{s.index:03d}"))  # fmt: skip
        runs.append(_at_fixed_parameters(system.at(**s.values), sampler, rules, integrator, sub,
                                         terminal, regions))  # fmt: skip
    worst = np.all(np.stack([r.code for r in runs]) == I.CONVERGED, axis=0)
    k = int(np.count_nonzero(worst))
    n = worst.size
    status = (BasinStatus.ALL_CONVERGED if k == n
              else BasinStatus.NONE_CONVERGED if k == 0 else BasinStatus.PARTLY_CONVERGED)  # fmt: skip
    return RobustBasinResult(status, tuple(samples), tuple(runs), time.perf_counter() - t0,
                             system, sampler, int(param_seed), int(param_samples),
                             terminal, tuple(regions))  # fmt: skip


def _at_fixed_parameters(system: System, sampler: Any, rules: StopRules | None,
                         integrator: IntegratorOptions | None, run: RunOptions | None,
                         terminal: TerminalSet | str | Path | dict | None,
                         regions: Sequence[Any]) -> BasinResult:  # fmt: skip
    """The basin of ``system`` at its parameter values (see :func:`basin`)."""
    t0 = time.perf_counter()
    rules = StopRules() if rules is None else rules
    integrator = IntegratorOptions() if integrator is None else integrator
    run = RunOptions() if run is None else run
    if system.equilibrium is None or system.time_varying:
        raise RoaInputError(
            f"system {system.name!r}: basins need an autonomous system with an equilibrium"
        )
    check_system(system)
    for attr in ("n", "points", "fingerprint"):
        if not hasattr(sampler, attr):
            raise RoaInputError(
                f"sampler must have n, points(start, stop) and fingerprint() (e.g. "
                f"roa.grid_slice or roa.box_sample), got {type(sampler).__name__}"
            )
    if terminal is not None and not isinstance(terminal, TerminalSet):
        from roa.montecarlo._certified_set import terminal_from_certificate

        terminal = terminal_from_certificate(terminal, system)
    res = run_basin(
        system,
        sampler,
        rules=rules,
        rtol=integrator.rtol,
        atol=integrator.atol,
        margin_tol=integrator.margin_tol,
        backend=integrator.backend,
        chunk_size=run.chunk_size,
        n_jobs=run.n_jobs,
        out_dir=run.out_dir,
        scheduler=run.scheduler,
        progress=run.progress,
        fresh=run.fresh,
        terminal=terminal,
        time_limit=run.time_limit,
    )
    counts = res.counts()
    k = counts["converged"]
    not_run = counts.get("not_run", 0)
    status = (
        BasinStatus.INCONCLUSIVE
        if not_run
        else BasinStatus.ALL_CONVERGED
        if k == res.n
        else (BasinStatus.NONE_CONVERGED if k == 0 else BasinStatus.PARTLY_CONVERGED)
    )
    return BasinResult(
        status,
        res.n,
        counts,
        None if not_run else (k / res.n if res.n else 0.0),
        converged_interval(k, not_run, res.n),
        res.code,
        res.t_end,
        time.perf_counter() - t0,
        res.chunks_computed,
        res.chunks_resumed,
        int(np.sum(res.code == I.STEP_FAILURE)),
        int(res.meta.get("chunks_rejected", 0)),
        system,
        sampler,
        rules,
        integrator,
        res.entered_certified_set,
        terminal,
        tuple(regions),
        str(res.meta.get("backend", "numpy")),
        res.meta.get("backend_note"),
        certified_shares(regions, terminal, system, sampler, res.code),
    )


def region_entry(region: Any, grid: Any, code: np.ndarray) -> dict[str, Any]:
    """What the JSON says of a region: name, level, status, its V (``P`` or the polynomial's
    kind, degree, monomials and coefficients) and the slice's grid points inside it."""
    from roa.plotting._basin import slice_containment

    out = {"name": region.name, "level": region.level, "status": region.status,
           "label": region.meta.get("label"), "V": region.describe_v()}  # fmt: skip
    if isinstance(grid, GridSlice):
        inside = slice_containment(grid, code, region)
        out["slice"] = {k: inside[k] for k in ("points_in_region", "converged", "all_converged")}
    return out
