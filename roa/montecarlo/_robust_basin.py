"""Robust basins: the basin of a system with uncertain parameters, sampled over its parameter box.

A system with uncertain parameters (``System(parameters={"mu": (low, nominal, high)})``) stands for
a family of fields. :func:`roa.montecarlo._basin.robust_basin` (what :func:`roa.montecarlo.basin`
runs for such a system: one call) integrates every initial condition of a sampler once per
*parameter sample* (:func:`parameter_samples`: the nominal values, the box's vertices and seeded
uniform samples of the box), each run at fixed parameter values (``system.at(...)``), and keeps
every run's status: nothing is merged across parameters. Derived from them, per initial
condition:

* the **converged share**: the fraction of the sampled parameter values from which it converges;
* the **worst-case map**: whether it converges for *every* sampled parameter value.

What this claims and what it does not: the maps are statements about the *sampled* parameter
values only. An initial condition that converges for every sample may fail for a parameter value
between them; only a robust certificate (``roa certify`` on the box,
:mod:`roa.proof._robust`) speaks for every parameter of the box, and its set is what a terminal set
(``terminal=``) or a drawn region adds. A terminal set from a certificate file is re-verified for
the whole box (:func:`roa.montecarlo.terminal_from_certificate`, which runs the robust
validation on a system with parameters) before it finishes any run, for every sample.

Determinism: the samples depend only on the box and ``seed`` (the first ``k`` random samples are
the same for every count ``>= k``); each per-sample run is the engine's
(:mod:`roa.montecarlo._engine`), whose statuses do not depend on workers or chunk size. With an
output directory each sample's run is resumable in its own folder ``param_NNN`` (the run's
fingerprint includes the parameter values, so a folder of other values is never resumed).

Kernels: ``system.at(...)`` keeps a compiled numba field only when its factory can be rebuilt for
the new values (``factory.with_params``, :meth:`roa.model.System._rekernel`), never a kernel
compiled for other parameter values. A system without one gets a kernel generated from its field
once (:mod:`roa.integration._kernel_cache`), with the parameters as kernel arguments, used by every
sample; a field that cannot be compiled runs on the numpy backend.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.integration import _dopri as I  # noqa: N812  (status codes)
from roa.integration._terminal import TerminalSet
from roa.model._parameters import ParameterBox
from roa.model._system import System
from roa.montecarlo._engine import wilson_interval
from roa.montecarlo._sampling import GridSlice
from roa.options import (  # noqa: F401  (the sample counts are re-exported)
    DEFAULT_PARAM_SAMPLES,
    MAX_PARAM_SAMPLES,
    IntegratorOptions,
    RunOptions,
)
from roa.status import BasinStatus

#: Second word of the seed of the parameter samples (kept apart from the state samplers' streams).
_STREAM = 0x70617261


@dataclass(frozen=True)
class ParameterSample:
    """One parameter value of a robust basin run: ``kind`` is ``nominal``, ``vertex`` or
    ``random``; ``values`` every uncertain parameter by name."""

    index: int
    kind: str
    values: dict[str, float]

    def to_dict(self) -> dict[str, Any]:
        return {"index": self.index, "kind": self.kind, "parameters": dict(self.values)}


def _check_int(value: Any, what: str, low: int, high: int) -> int:
    if (
        isinstance(value, bool)
        or not isinstance(value, int | np.integer)
        or not low <= value <= high
    ):
        raise RoaInputError(f"{what} must be an integer in [{low}, {high}], got {value!r}")
    return int(value)


def parameter_samples(
    system: System, n_random: int = DEFAULT_PARAM_SAMPLES, seed: int = 0
) -> list[ParameterSample]:
    """The parameter values a robust basin is run at: the nominal values, the box's vertices
    (:meth:`roa.model._parameters.ParameterBox.vertices`) and ``n_random`` uniform samples of the box
    drawn from ``numpy.random.default_rng([seed, ...])`` (a value equal to an earlier one is
    listed once). Depends only on the box, ``n_random`` and ``seed``; the first ``k`` random
    samples are the same for every ``n_random >= k``."""
    n_random = _check_int(n_random, "param_samples", 0, MAX_PARAM_SAMPLES)
    seed = _check_int(seed, "param_seed", 0, 2**63 - 1)
    box = ParameterBox.of(system)
    nominal = {k: float(r.nominal) for k, r in system.parameters.items()}
    candidates: list[tuple[str, dict[str, float]]] = [("nominal", nominal)]
    candidates += [("vertex", {k: float(v) for k, v in p.items()}) for p in box.vertices()]
    if n_random:
        rng = np.random.default_rng([seed, _STREAM])
        u = rng.random((n_random, len(box.names)))
        lo, hi = np.array(box.lo), np.array(box.hi)
        for row in lo + u * (hi - lo):
            candidates.append(
                ("random", {k: float(v) for k, v in zip(box.names, row, strict=True)})
            )
    out: list[ParameterSample] = []
    seen: set[tuple[float, ...]] = set()
    for kind, values in candidates:
        key = tuple(values[k] for k in box.names)
        if key not in seen:
            seen.add(key)
            out.append(ParameterSample(len(out), kind, values))
    return out


@dataclass(frozen=True)
class RobustBasinResult:
    """Statuses of every initial condition for every parameter sample (module doc).

    Attributes
    ----------
    status : BasinStatus
        Of the worst-case map: ``all_converged`` when every initial condition converges for every
        sampled parameter value, ``none_converged`` when none does, else ``partly_converged``.
    samples : tuple of ParameterSample
        The parameter values, in run order.
    runs : tuple of BasinResult
        One basin run per sample (its own counts per status, codes and stop times).
    """

    status: BasinStatus
    samples: tuple[ParameterSample, ...]
    runs: tuple[Any, ...] = field(repr=False)
    seconds: float
    system: System = field(repr=False, compare=False)
    sampler: Any = field(repr=False, compare=False)
    param_seed: int = 0
    n_random: int = 0
    terminal: TerminalSet | None = field(default=None, repr=False, compare=False)
    regions: tuple[Any, ...] = field(default=(), repr=False, compare=False)

    @property
    def n(self) -> int:
        """Initial conditions (each run once per parameter sample)."""
        return int(self.runs[0].n)

    @property
    def codes(self) -> np.ndarray:
        """Status codes, shape ``(samples, n)``."""
        return np.stack([r.code for r in self.runs])

    @property
    def converged_count(self) -> np.ndarray:
        """Per initial condition: from how many sampled parameter values it converges."""
        return np.sum(self.codes == I.CONVERGED, axis=0)

    @property
    def share(self) -> np.ndarray:
        """Per initial condition: the share of the sampled parameter values it converges from."""
        return self.converged_count / len(self.samples)

    @property
    def worst_case(self) -> np.ndarray:
        """Per initial condition: converges for every sampled parameter value."""
        return self.converged_count == len(self.samples)

    def to_dict(self) -> dict[str, Any]:
        """What ``roa basin --json`` prints for a system with uncertain parameters: per
        parameter sample its own counts per status (never merged), and the derived maps'
        summaries (``worst_case``, ``converged_share``)."""
        m, n = len(self.samples), self.n
        worst = int(np.count_nonzero(self.worst_case))
        hist = np.bincount(self.converged_count, minlength=m + 1)
        first = self.runs[0]
        per = []
        for s, r in zip(self.samples, self.runs, strict=True):
            per.append({**s.to_dict(), "status": r.status.value, "counts": dict(r.counts),
                        "undecided_step_size_failures": r.step_size_failures,
                        "fraction_converged": r.fraction_converged,
                        "fraction_converged_ci95": list(r.ci95),
                        "entered_certified_set": r.entered_certified_set,
                        "chunks_computed": r.chunks_computed, "chunks_resumed": r.chunks_resumed,
                        "chunks_rejected": r.chunks_rejected, "backend": r.backend,
                        **({"certified_share": [dict(e) for e in r.certified_shares]}
                           if r.certified_shares else {})})  # fmt: skip
        box = {k: {"low": u.low, "nominal": u.nominal, "high": u.high}
               for k, u in self.system.parameters.items()}  # fmt: skip
        out: dict[str, Any] = {
            "system": self.system.name,
            "status": self.status.value,
            "n": n,
            "parameters": box,
            "parameter_samples": {
                "count": m,
                "nominal": sum(s.kind == "nominal" for s in self.samples),
                "vertices": sum(s.kind == "vertex" for s in self.samples),
                "random": sum(s.kind == "random" for s in self.samples),
                "seed": self.param_seed,
            },
            "per_parameter": per,
            "worst_case": {
                "meaning": "converged for every sampled parameter value (not proved between them)",
                "converged": worst,
                "fraction": worst / n if n else 0.0,
                "fraction_ci95": list(wilson_interval(worst, n)),
            },
            "converged_share": {
                "meaning": "per initial condition, the share of sampled parameter values from "
                "which it converges",
                "mean": float(np.mean(self.share)) if n else 0.0,
                "histogram": [int(v) for v in hist],
                "histogram_meaning": "entry j: initial conditions converging for exactly j of "
                "the sampled parameter values",
            },
            "ci_method": "Wilson score, 95 %",
            "t_final": first.rules.t_final,
            "converge_tol": first.rules.converge_tol,
            "diverge_bound": first.rules.diverge_bound,
            "diverge_growth": first.rules.diverge_growth,
            "rtol": first.integrator.rtol,
            "atol": first.integrator.atol,
            "terminal_set": None
            if self.terminal is None
            else {"name": self.terminal.name, "level": self.terminal.level,
                  "coords": self.terminal.coords, "margin": "V <= level (1 - 1e-9)",
                  "holds_for": "every parameter of the box (re-verified)"},
            "seconds": round(self.seconds, 3),
            **(self.sampler.describe(self.system.state_names)
               if hasattr(self.sampler, "describe") else {}),
        }  # fmt: skip
        if self.regions:
            out["regions"] = [self._region_entry(r) for r in self.regions]
        shares = self.certified_shares()
        if shares:
            out["certified_share"] = shares
        return out

    def certified_shares(self) -> list[dict[str, Any]]:
        """Per region and for the terminal set: the share of the initial conditions converging
        for every sampled parameter value (the worst case) that lie inside it, with its 95 %
        Clopper-Pearson interval (:mod:`roa.montecarlo._certified_share`; ``converged`` counts
        the worst case's points). Each sample's own shares are in ``per_parameter``."""
        from roa.montecarlo._certified_share import certified_shares

        code = np.where(self.worst_case, I.CONVERGED, I.DIVERGED)
        out = [dict(e) for e in certified_shares(self.regions, self.terminal, self.system,
                                                 self.sampler, code)]  # fmt: skip
        for e in out:
            e["meaning"] = "among the initial conditions converging for every sampled value"
        return out

    def _region_entry(self, region: Any) -> dict[str, Any]:
        out = {"name": region.name, "level": region.level, "status": region.status,
               "label": region.meta.get("label"), "V": region.describe_v()}  # fmt: skip
        if isinstance(self.sampler, GridSlice):
            inside = region.contains(self.sampler.points(0, self.sampler.n))
            k = int(inside.sum())
            conv = int(np.count_nonzero(self.worst_case[inside]))
            out["slice"] = {"points_in_region": k, "converged_for_every_sample": conv,
                            "all_converged": (conv == k) if k else None}  # fmt: skip
        return out

    def plot(self, path: str | Path | None = None, *, title: str | None = None) -> Any:
        """The converged-share map and the worst-case map of a :func:`grid_slice` run, with the
        terminal set and the regions drawn (:func:`roa.plotting._robust_basin.robust_figure`);
        saved to ``path`` when given. Returns the figure (closed when saved)."""
        from roa.plotting._robust_basin import robust_figure, save_figure

        if not isinstance(self.sampler, GridSlice):
            raise RoaInputError("plot() draws a 2-D slice: run basin() on a grid_slice sampler")
        fig = robust_figure(self, title=title)
        if path is not None:
            save_figure(fig, path)
        return fig
