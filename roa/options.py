"""Options of every method, as frozen dataclasses with their defaults in one place.

Each class validates its fields on construction (:class:`roa.errors.RoaInputError` naming the field
and the allowed range) and builds from a mapping with :meth:`Options.from_mapping`, which rejects
unknown keys using the dataclass's own fields (experiment ``[params]`` tables map onto them)::

    >>> from roa.options import SampledOptions
    >>> SampledOptions(n_directions=2000).n_directions
    2000
    >>> SampledOptions.from_mapping({"n_directions": 2000, "seed": 3}).seed
    3
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Self

from roa.errors import RoaInputError

#: Upper bounds that keep a single call within the memory of a workstation.
MAX_DIRECTIONS = 2_000_000
MAX_BOXES = 200_000_000

#: Seeded uniform parameter samples of a robust basin by default (on top of the nominal values
#: and the vertices of the parameter box).
DEFAULT_PARAM_SAMPLES = 8
#: At most this many seeded uniform parameter samples in a robust basin.
MAX_PARAM_SAMPLES = 1000


def _int(obj: Any, name: str, lo: int, hi: int | None = None) -> None:
    value = getattr(obj, name)
    what = f"{type(obj).__name__}.{name}"
    if isinstance(value, bool) or not isinstance(value, int):
        raise RoaInputError(f"{what} must be an integer, got {value!r}")
    if value < lo or (hi is not None and value > hi):
        rng = f">= {lo}" if hi is None else f"in [{lo}, {hi}]"
        raise RoaInputError(f"{what} must be {rng}, got {value}")


def _pos(obj: Any, name: str, *, upper: float = math.inf, closed_upper: bool = False) -> None:
    value = getattr(obj, name)
    what = f"{type(obj).__name__}.{name}"
    ok = isinstance(value, int | float) and not isinstance(value, bool) and value > 0
    ok = ok and (value <= upper if closed_upper else value < upper)
    if not ok:
        rng = (
            "a finite number > 0"
            if upper == math.inf
            else f"in (0, {upper:g}" + ("]" if closed_upper else ")")
        )
        raise RoaInputError(f"{what} must be {rng}, got {value!r}")


class Options:
    """Mixin: construction from a mapping that rejects unknown keys, and a plain-dict view."""

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any] | None, *, where: str = "") -> Self:
        """Build from ``mapping``; unknown keys raise :class:`RoaInputError` listing the allowed."""
        mapping = dict(mapping or {})
        names = [f.name for f in dataclasses.fields(cls)]  # type: ignore[arg-type]
        unknown = sorted(set(mapping) - set(names))
        if unknown:
            prefix = f"{where}: " if where else ""
            raise RoaInputError(
                f"{prefix}unknown option(s) {unknown} for {cls.__name__}; allowed: "
                f"{', '.join(names)}"
            )
        for key, value in list(mapping.items()):
            if isinstance(value, list):  # TOML arrays -> tuples (frozen, hashable)
                mapping[key] = tuple(value)
        return cls(**mapping)

    def replace(self, **changes: Any) -> Self:
        """A copy with ``changes`` (validated like the constructor)."""
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)  # type: ignore[call-overload]


@dataclass(frozen=True)
class SampledOptions(Options):
    """Sampled level search: rays in random directions, bisection, cap refinement.

    Parameters
    ----------
    n_directions : int
        Random directions on the unit sphere of the shape, in [16, 2e6].
    r_max : float
        Search radius in shape units (sqrt of the level); rays without violation count as infinite.
    n_radial : int
        Points of the geometric radial grid used for bracketing (>= 8).
    refine_rounds, refine_directions, n_candidates : int
        Cap refinement: rounds, directions per round, and how many best directions to refine.
    seed : int
        Random seed (>= 0).
    """

    n_directions: int = 20000
    r_max: float = 100.0
    n_radial: int = 96
    refine_rounds: int = 20
    refine_directions: int = 192
    n_candidates: int = 3
    seed: int = 0

    def __post_init__(self) -> None:
        _int(self, "n_directions", 16, MAX_DIRECTIONS)
        _pos(self, "r_max")
        _int(self, "n_radial", 8, 100_000)
        _int(self, "refine_rounds", 0, 1000)
        _int(self, "refine_directions", 1, 100_000)
        _int(self, "n_candidates", 1, 1000)
        _int(self, "seed", 0)

    @classmethod
    def with_accuracy(cls, accuracy: str) -> SampledOptions:
        """Presets: ``"low"`` (2,000 directions), ``"medium"`` (the default), ``"high"`` (200,000)."""
        presets = {"low": 2000, "medium": 20000, "high": 200000}
        if accuracy not in presets:
            raise RoaInputError(f"accuracy must be one of {list(presets)}, got {accuracy!r}")
        return cls(n_directions=presets[accuracy])


@dataclass(frozen=True)
class CasadiOptions(Options):
    """CasADi/IPOPT level search: min s(x) s.t. V'(x)/s(x) >= 0, multi-start.

    Parameters
    ----------
    n_starts : int
        IPOPT starts per problem, in [1, 10000].
    r_start : (float, float)
        Range ``0 < low < high`` of shape radii scanned along the rays for starting points (the
        default reaches s = 10^4, as the sampled search's ``r_max``).
    n_candidates : int
        Random directions (rays) scanned for violating starting points (>= 1).
    seed : int
        Random seed (>= 0).
    """

    n_starts: int = 16
    r_start: tuple[float, float] = (0.1, 100.0)
    n_candidates: int = 8000
    seed: int = 1

    def __post_init__(self) -> None:
        _int(self, "n_starts", 1, 10_000)
        r = tuple(self.r_start)
        if len(r) != 2 or not (0 < r[0] < r[1] < math.inf):
            raise RoaInputError(
                f"CasadiOptions.r_start must be (low, high), 0 < low < high, got {r}"
            )
        object.__setattr__(self, "r_start", (float(r[0]), float(r[1])))
        _int(self, "n_candidates", 1, MAX_DIRECTIONS)
        _int(self, "seed", 0)


@dataclass(frozen=True)
class SosOptions(Options):
    """SOS program for the largest level (cvxpy + Clarabel).

    Parameters
    ----------
    recast : {"exact", "enclosure"}
        How non-polynomial factors of V' are made polynomial.
    multiplier_degree : int or None
        Degree of the free multiplier of V' (default: the smallest that makes the degrees match).
    symmetry : {"auto", True, False}
        Exploit an odd field (smaller Gram blocks, same optimum).
    aux_degree : int or None
        Largest degree of auxiliary (recast) variables in bases and multipliers; ``None``: no cap.
    time_limit : float or None
        Clarabel's time limit in seconds.
    safety_factor : float
        The SOS optimum is a supremum: :func:`roa.certify` validates ``safety_factor * level``,
        in (0, 1].
    """

    recast: str = "exact"
    multiplier_degree: int | None = None
    symmetry: str | bool = "auto"
    aux_degree: int | None = None
    time_limit: float | None = None
    safety_factor: float = 1 - 1e-4

    def __post_init__(self) -> None:
        if self.recast not in ("exact", "enclosure"):
            raise RoaInputError(
                f"SosOptions.recast must be 'exact' or 'enclosure', got {self.recast!r}"
            )
        if self.symmetry not in ("auto", True, False):
            raise RoaInputError(
                f"SosOptions.symmetry must be 'auto', True or False, got {self.symmetry!r}"
            )
        if self.multiplier_degree is not None:
            _int(self, "multiplier_degree", 0, 12)
        if self.aux_degree is not None:
            _int(self, "aux_degree", 0, 12)
        if self.time_limit is not None:
            _pos(self, "time_limit")
        _pos(self, "safety_factor", upper=1.0, closed_upper=True)

    def solver_options(self) -> dict[str, Any] | None:
        return None if self.time_limit is None else {"time_limit": float(self.time_limit)}


@dataclass(frozen=True)
class VsOptions(Options):
    """Search of a polynomial V by SOS V-s iteration (:func:`roa.search.vs_search`).

    Parameters
    ----------
    rounds : int
        Largest number of V steps, 1..50.
    shape : array or None
        Matrix ``S`` of the shape function ``p = (x - x_eq)' S (x - x_eq)`` whose sublevel set is
        enlarged (default: the seed's ``P``).
    tol : float
        Stop when the shape level grows by less than this (relative), in (0, 1).
    validate : int
        How many candidates (best shape level first) are validated until one is certified, 1..20.
    solver : {"auto", "clarabel", "scs"}
        SDP solver (``auto``: Clarabel for Gram blocks <= 80 monomials, else SCS).
    max_iters : int or None
        Iteration cap of the SDP solver, 1..10^6 (SCS default 50,000): an inaccurate answer is
        still a candidate, proved or not by the validation.
    multiplier_degree, aux_degree, symmetry, recast, time_limit
        As in :class:`SosOptions`.
    budget : float or None
        Wall-clock seconds for the whole V-s iteration (default 600; ``None``: none). No SDP is
        started past it, and each is given the time left as its solver time limit; the iteration
        then stops with the candidates of the rounds completed (the best is validated).
    method : {"sos", "sampled"}
        ``sos``: the V-s iteration; ``sampled``: the sampled cutting-plane search
        (``roa.certify`` with :class:`roa.CuttingPlanes`, no SDP over the field), with ``sampled``
        its options (:class:`SampleSearchOptions`; ``degree`` is taken from ``roa.certify``).
    objective : {"shape", "volume"}
        What each V step enlarges: ``shape`` the level of ``{p <= beta}`` inside ``{V <= 1}``;
        ``volume`` the set ``{V <= 1}`` itself, by minimising V's mean over a cube (a proxy of
        its volume; no shape containment kept).
    reach : float
        Half-width of that cube in the seed's whitened coordinates (the seed's certified set is
        their unit ball), > 0.
    """

    rounds: int = 8
    shape: Any = None
    tol: float = 2e-3
    validate: int = 3
    solver: str = "auto"
    max_iters: int | None = None
    multiplier_degree: int | None = None
    aux_degree: int | None = None
    symmetry: str | bool = "auto"
    recast: str = "exact"
    time_limit: float | None = None
    budget: float | None = 600.0
    method: str = "sos"
    sampled: Any = None
    objective: str = "shape"
    reach: float = 1.5

    def __post_init__(self) -> None:
        _int(self, "rounds", 1, 50)
        if self.method not in ("sos", "sampled"):
            raise RoaInputError(f"VsOptions.method must be 'sos' or 'sampled', got {self.method!r}")
        if isinstance(self.sampled, Mapping):
            object.__setattr__(self, "sampled", SampleSearchOptions.from_mapping(self.sampled))
        if self.sampled is not None and not isinstance(self.sampled, SampleSearchOptions):
            raise RoaInputError(
                "VsOptions.sampled must be a SampleSearchOptions (or a mapping of its fields), "
                f"got {type(self.sampled).__name__}"
            )
        _int(self, "validate", 1, 20)
        if self.objective not in ("shape", "volume"):
            raise RoaInputError(f"VsOptions.objective must be 'shape' or 'volume', got "
                                f"{self.objective!r}")  # fmt: skip
        _pos(self, "reach")
        if self.budget is not None:
            _pos(self, "budget")
        if self.max_iters is not None:
            _int(self, "max_iters", 1, 10**6)
        _pos(self, "tol", upper=1.0)
        if self.solver not in ("auto", "clarabel", "scs"):
            raise RoaInputError(
                f"VsOptions.solver must be 'auto', 'clarabel' or 'scs', got {self.solver!r}"
            )
        SosOptions(recast=self.recast, multiplier_degree=self.multiplier_degree,
                   symmetry=self.symmetry, aux_degree=self.aux_degree,
                   time_limit=self.time_limit)  # fmt: skip
        if self.shape is not None:
            import numpy as np

            S = np.asarray(self.shape, dtype=float)
            if S.ndim != 2 or S.shape[0] != S.shape[1] or not np.all(np.isfinite(S)):
                raise RoaInputError(
                    f"VsOptions.shape must be a finite square matrix, got {S.shape}"
                )
            if not np.allclose(S, S.T) or np.linalg.eigvalsh(0.5 * (S + S.T))[0] <= 0:
                raise RoaInputError("VsOptions.shape must be symmetric positive definite")
            object.__setattr__(self, "shape", tuple(tuple(float(v) for v in r) for r in S))

    def solver_options(self) -> dict[str, Any] | None:
        out: dict[str, Any] = {}
        if self.time_limit is not None:
            out["time_limit"] = float(self.time_limit)
        if self.max_iters is not None:
            out["max_iters"] = int(self.max_iters)
        return out or None


@dataclass(frozen=True)
class SampleSearchOptions(Options):
    """Sampled cutting-plane search of a polynomial V (:func:`roa.search._cutting_planes.sample_search`)
    and its certification (``roa.certify`` with :class:`roa.CuttingPlanes`).

    Parameters
    ----------
    degree : int
        Degree of V, one of 2, 4, 6, 8.
    rounds : int
        Largest number of programs (cutting-plane rounds), 1..200.
    cuts : int
        Violators added per round (worst first), 1..100,000.
    directions, radial : int
        Rays through ``{V <= 1 + slack}`` searched for violators, 10..10^6, and points per ray,
        2..1000.
    margin : float
        Required decrease ``V' <= -margin |y|^2`` at the cut points (whitened ``y``), in (0, 10).
    local_margin : float or None
        The LMI on V's quadratic part, ``-(A'P2 + P2 A) >= local_margin I``, in (0, 10) (default
        ``margin``): a stronger local decrease lets the validation's local proof cover a larger
        box around the equilibrium.
    positivity : float
        Gram blocks ``>= positivity I`` (``V >= positivity |y|^2``), in (0, 1).
    slack : float
        Violators are searched in ``{V <= 1 + slack}``, in [0, 1).
    grow : float
        Default soft targets: the seed's level set scaled by this (radius in ``y``), in (0, 100).
    outer, outer_points : float, int
        ``V >= 1`` at ``outer_points`` points (0..10^6) of the sphere ``|y| = outer`` (whitened
        radius, 0 for none, else in (grow, 1000)): keeps ``{V <= 1}`` compact and small.
    soft_points, initial_cuts : int
        Default soft targets, 0..10^6, and the first cut points drawn in the seed's level set,
        1..10^6.
    symmetry : {"auto", True, False}
        Even V and even/odd Gram blocks for odd fields (``auto``: a sampled test).
    simulate : bool
        Classify violators by simulation (RK4 with step ``dt`` up to ``horizon``, in (0, 10) and
        (0, 10^4)): converging ones become decrease cuts, the others excluded points.
    seed : int
        Random seed (>= 0).
    level_safety : float
        The certified level is ``level_safety`` x the sampled optimum of V, capped at 1 (the target
        level), in (0, 1]; the level ``1.001`` x the optimum is checked to be refuted.
    """

    degree: int = 4
    rounds: int = 30
    cuts: int = 400
    directions: int = 6000
    radial: int = 24
    margin: float = 0.01
    local_margin: float | None = None
    positivity: float = 1e-3
    slack: float = 0.02
    grow: float = 1.5
    soft_points: int = 3000
    outer: float = 3.0
    outer_points: int = 2000
    initial_cuts: int = 2000
    symmetry: str | bool = "auto"
    simulate: bool = True
    dt: float = 0.05
    horizon: float = 40.0
    seed: int = 0
    level_safety: float = 0.98

    def __post_init__(self) -> None:
        if self.degree not in (2, 4, 6, 8):
            raise RoaInputError(
                f"SampleSearchOptions.degree must be one of 2, 4, 6, 8, got {self.degree!r}"
            )
        _int(self, "rounds", 1, 200)
        _int(self, "cuts", 1, 100_000)
        _int(self, "directions", 10, 10**6)
        _int(self, "radial", 2, 1000)
        _int(self, "soft_points", 0, 10**6)
        _int(self, "initial_cuts", 1, 10**6)
        _int(self, "outer_points", 0, 10**6)
        if not (
            isinstance(self.outer, int | float)
            and (self.outer == 0 or self.grow < self.outer < 1000)
        ):
            raise RoaInputError(
                f"SampleSearchOptions.outer must be 0 or in (grow, 1000), got {self.outer!r}"
            )
        _int(self, "seed", 0)
        _pos(self, "margin", upper=10.0)
        if self.local_margin is not None:
            _pos(self, "local_margin", upper=10.0)
        _pos(self, "positivity", upper=1.0)
        _pos(self, "grow", upper=100.0)
        _pos(self, "level_safety", upper=1.0, closed_upper=True)
        _pos(self, "dt", upper=10.0)
        _pos(self, "horizon", upper=1e4)
        if not isinstance(self.simulate, bool):
            raise RoaInputError(
                f"SampleSearchOptions.simulate must be a bool, got {self.simulate!r}"
            )
        if not (isinstance(self.slack, int | float) and 0 <= self.slack < 1):
            raise RoaInputError(f"SampleSearchOptions.slack must be in [0, 1), got {self.slack!r}")
        if self.symmetry not in ("auto", True, False):
            raise RoaInputError(
                f"SampleSearchOptions.symmetry must be 'auto', True or False, got {self.symmetry!r}"
            )


#: States plus uncertain parameters up to which the interval branch and bound decides a level
#: first (:class:`roa.AutoValidator`); above, it backs up the exact SOS route.
BNB_DIM = 4
#: Default wall-clock budget (s) of one interval validation: six times the longest validation of
#: the paper's evidence (R4, 617 s over a parameter box), so that no reported result depends on
#: it.
BNB_SECONDS = 3600.0
#: Default wall-clock budget (s) of the branch and bound as the backup of the SOS route above
#: :data:`BNB_DIM` (:class:`roa.AutoValidator`), where its box budget alone would run for hours
#: (ring-20: no verdict in 900 s).
BNB_SECONDS_BACKUP = 300.0


@dataclass(frozen=True)
class IntervalOptions(Options):
    """Interval branch-and-bound validation of a level.

    Parameters
    ----------
    max_boxes : int
        Budget of box evaluations, in [1, 2e8]; exhausted -> ``inconclusive``.
    batch : int
        Boxes evaluated per vectorised step, in [1, 1e7].
    sampled_safety : float
        A sampled optimum (an upper bound of the largest level) is validated at this fraction,
        in (0, 1].
    time_limit : float or None
        Wall-clock budget of one validation in seconds, in (0, 1e9]: when it runs out the
        verdict is ``inconclusive`` saying so (checked between batches of boxes). None: the
        default budget, :data:`BNB_SECONDS` (:data:`BNB_SECONDS_BACKUP` for the backup of the
        SOS route above :data:`BNB_DIM`, :class:`roa.AutoValidator`).
    """

    max_boxes: int = 3_000_000
    batch: int = 100_000
    sampled_safety: float = 0.999
    time_limit: float | None = None

    def __post_init__(self) -> None:
        _int(self, "max_boxes", 1, MAX_BOXES)
        _int(self, "batch", 1, 10_000_000)
        _pos(self, "sampled_safety", upper=1.0, closed_upper=True)
        t = self.time_limit
        if t is not None and (
            isinstance(t, bool) or not isinstance(t, int | float) or not 0 < t <= 1e9
        ):
            raise RoaInputError(
                f"IntervalOptions.time_limit must be a number of seconds in (0, 1e9], got {t!r}"
            )

    def seconds(self, default: float = BNB_SECONDS) -> float:
        """The time budget of one validation: ``time_limit``, else ``default``."""
        return float(self.time_limit) if self.time_limit is not None else default


@dataclass(frozen=True)
class IntegratorOptions(Options):
    """Batch Dormand-Prince 5(4) integration of many initial conditions.

    Parameters
    ----------
    rtol, atol : float
        Error tolerances (scipy's definitions); ``rtol`` in [2.2e-14, 1), ``atol`` > 0.
    margin_tol : float
        The domain is left when ``margin(x) <= margin_tol`` (>= 0).
    backend : {"auto", "numba", "numpy"}
        ``auto`` uses the system's numba kernel when it has one.
    """

    rtol: float = 1e-6
    atol: float = 1e-9
    margin_tol: float = 0.0
    backend: str = "auto"

    def __post_init__(self) -> None:
        eps = 2.220446049250313e-16
        if not (isinstance(self.rtol, int | float) and 100 * eps <= self.rtol < 1):
            raise RoaInputError(
                f"IntegratorOptions.rtol must be in [{100 * eps:.2g}, 1), got {self.rtol!r}"
            )
        _pos(self, "atol")
        if not (isinstance(self.margin_tol, int | float) and 0 <= self.margin_tol < math.inf):
            raise RoaInputError(
                f"IntegratorOptions.margin_tol must be a finite number >= 0, got {self.margin_tol!r}"
            )
        if self.backend not in ("auto", "numba", "numpy"):
            raise RoaInputError(
                f"IntegratorOptions.backend must be 'auto', 'numba' or 'numpy', got {self.backend!r}"
            )


@dataclass(frozen=True)
class RunOptions(Options):
    """How a basin run is executed (none of these changes the result).

    Parameters
    ----------
    chunk_size : int
        Initial conditions per task, in [1, 1e6].
    n_jobs : int
        Worker processes: -1 for all cores, else in [1, 4 x cores].
    out_dir : str or None
        Resumable run directory (chunks and a fingerprint).
    scheduler : str or None
        Address of a Dask scheduler (``tcp://host:port``).
    progress : bool or None
        Progress bar (default: on for runs of more than 50 chunks).
    fresh : bool
        Recompute every chunk of ``out_dir`` instead of resuming from it.
    time_limit : float or None
        Wall-clock budget of the run in seconds, in (0, 1e9]: when it runs out the run ends
        ``inconclusive`` with the initial conditions not run counted as ``not_run`` (the
        completed chunks are kept; with ``out_dir`` the same run resumes from them).
    """

    chunk_size: int = 4096
    n_jobs: int = -1
    out_dir: str | None = None
    scheduler: str | None = None
    progress: bool | None = None
    fresh: bool = False
    time_limit: float | None = None

    def __post_init__(self) -> None:
        _int(self, "chunk_size", 1, 1_000_000)
        cores = os.cpu_count() or 1
        if self.n_jobs != -1:
            _int(self, "n_jobs", 1, 4 * cores)
        if self.out_dir is not None:
            object.__setattr__(self, "out_dir", os.fspath(self.out_dir))
        if self.time_limit is not None:
            _pos(self, "time_limit", upper=1e9, closed_upper=True)
