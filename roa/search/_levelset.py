"""Khalil's level-set search (3.15): the largest set {s(x) <= level} on which V' < 0.

:func:`level_search` is the one entry point. Two independent methods, each returning a witness on
the boundary of the admissible set (``V'(x) = 0`` to rounding, or the domain boundary):

* ``"sampled"`` (:mod:`roa.search._levelset_sampled`): rays in random directions, bisection, cap refinement;
* ``"casadi"`` (:mod:`roa.search._levelset_casadi`): IPOPT multi-start ``min s(x) s.t. V'(x)/s(x)^(p/2) >= 0``
  (``p`` the degree at which V' starts), started at the first violations along random rays;
* ``"both"`` runs the two and checks that they agree.

The largest level is an *estimate* (an upper bound attained at the witness), not a certificate:
:func:`roa.certify` proves a level.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.model._checks import check_system
from roa.model._linearisation import jacobian, lyapunov_matrix
from roa.model._system import System
from roa.options import CasadiOptions, SampledOptions
from roa.progress import step
from roa.search._candidate import as_lyapunov
from roa.search._levelset_casadi import casadi_level
from roa.search._levelset_core import AGREEMENT_RTOL, WITNESS_ATOL, LevelSetResult, inner_level
from roa.search._levelset_sampled import sampled_level
from roa.status import LevelStatus

__all__ = [
    "AGREEMENT_RTOL",
    "METHODS",
    "SHAPES",
    "WITNESS_ATOL",
    "LevelSearchResult",
    "casadi_level",
    "inner_level",
    "jacobian",
    "level_search",
    "lyapunov_matrix",
    "sampled_level",
    "shape_matrix",
]

METHODS = ("sampled", "casadi", "both")
SHAPES = ("level", "ball")


def _finite(x: float | None) -> float | None:
    return None if x is None or not np.isfinite(x) else float(x)


@dataclass(frozen=True)
class LevelSearchResult:
    """The largest level of a shape on which V' < 0, how it was found, and a witness.

    Attributes
    ----------
    status : LevelStatus
        ``found`` (one method), ``agree`` / ``disagree`` / ``partial`` (both), or why there is no
        level (``unbounded``, ``not_locally_negative``, ``failed``).
    level : float or None
        The largest level (an upper bound attained at the witness); ``None`` when no level was
        found (then ``lower_bound`` says how far the rays reached: an estimate, not a bound).
    method, shape : str
        What ran and which shape (``"level"``, ``"ball"`` or ``"custom"``).
    witness : ndarray or None
        A state with ``V' = 0`` (or on the domain boundary) and ``s(witness) = level``.
    per_method : dict
        Each method's own result (``method="both"``).
    """

    status: LevelStatus
    level: float | None
    method: str
    shape: str
    witness: np.ndarray | None
    vdot_witness: float | None
    witness_kind: str | None
    seconds: float
    message: str = ""
    lower_bound: float | None = None
    relative_difference: float | None = None
    per_method: dict[str, LevelSearchResult] = field(default_factory=dict)
    details: dict[str, Any] = field(default_factory=dict)
    system: System | None = field(default=None, repr=False, compare=False)
    V: Lyapunov | None = field(default=None, repr=False, compare=False)
    S: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def ok(self) -> bool:
        """True when a level was found (and, with both methods, they agree)."""
        return self.status.ok

    def to_dict(self) -> dict[str, Any]:
        """What ``roa khalil --json`` prints (``value`` is a deprecated alias of ``level``)."""
        out: dict[str, Any] = {
            "level": self.level,
            "value": self.level,
            "status": self.status.value,
            "method": self.method,
            "shape": self.shape,
            "witness": None if self.witness is None else [float(v) for v in self.witness],
            "vdot_witness": _finite(self.vdot_witness),
            "witness_kind": self.witness_kind,
            "lower_bound": self.lower_bound,
            "seconds": round(self.seconds, 3),
            "message": self.message,
            **self.details,
        }
        if self.per_method:
            out["relative_difference"] = self.relative_difference
            out["per_method"] = {k: v.to_dict() for k, v in self.per_method.items()}
        if self.system is not None:
            out["system"] = self.system.name
        P = None if self.V is None else self.V.quadratic_matrix()
        if P is not None:
            out["P"] = P.tolist()
        elif self.V is not None:
            out["lyapunov"] = self.V.describe()
        return out

    def plot(self, ax: Any = None, *, n: int = 400) -> Any:
        """V' along the witness's ray against the shape value s, with the level marked (a new
        figure laid out so that a plain ``savefig`` keeps the axis labels)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
        if self.witness is None or self.system is None or self.V is None or self.level is None:
            ax.set_title(f"no witness ({self.status.value})")
            return ax
        c = self.V.center
        t = np.linspace(0.0, 1.5, n)[1:]
        X = c + t[:, None] * (self.witness - c)
        with np.errstate(all="ignore"):
            vd = self.V.derivative(self.system, X)
        if self.V.is_quadratic or self.S is not None:
            sv = self.level * t**2
        else:
            sv = self.V.value(X)
        ax.plot(sv, vd, label="V' along the witness's ray")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.axvline(self.level, color="C3", ls="--", label=f"level {self.level:.6g} ({self.status})")
        ax.set_xlabel(f"shape value s(x) ({self.shape}) [-]")
        ax.set_ylabel("V'(x) [1/time]")
        ax.legend(loc="best")
        return ax


def shape_matrix(system: System, V: Lyapunov, shape: Any) -> tuple[np.ndarray | None, str]:
    """The matrix S and name of a shape: ``"level"`` (V's P; ``None`` for a non-quadratic V, whose
    shape is V itself), ``"ball"`` (the system's norm, else the identity) or an n x n
    positive-definite matrix (``"custom"``)."""
    if isinstance(shape, str):
        if shape == "level":
            return V.P, "level"
        if shape == "ball":
            return (np.eye(system.n) if system.norm is None else np.asarray(system.norm)), "ball"
        raise RoaInputError(f"shape must be one of {SHAPES} or an n x n matrix, got {shape!r}")
    S = np.asarray(shape, dtype=float)
    if S.shape != (system.n, system.n):
        raise RoaInputError(f"shape matrix must be {system.n}x{system.n}, got {S.shape}")
    return S, "custom"


def _wrap(r: LevelSetResult, seconds: float, **extra: Any) -> LevelSearchResult:
    status = LevelStatus(r.status)
    found = status is LevelStatus.FOUND
    details = dict(r.details)
    lower = None
    message = ""
    if status is LevelStatus.UNBOUNDED:
        lower = _finite(r.value)
        rays = details.get("n_rays", details.get("n_directions"))
        on = f" on {rays} rays" if rays is not None else ""
        widen = "r_start" if r.method == "casadi" else "r_max"
        message = (
            f"no point with V' >= 0 found{on} up to s = {r.value:.4g} (V' < 0 may hold on every "
            "sublevel set); rays can miss a thin set where V' >= 0, so this is a sampled estimate, "
            f"not a bound; increase {widen} or the number of rays to search further"
        )
    elif status is LevelStatus.NOT_LOCALLY_NEGATIVE:
        message = (
            "V' is not negative definite at the equilibrium (largest eigenvalue of A'P + PA = "
            f"{details.get('max_eig_AtP_PA', float('nan')):.4g} >= 0): no level > 0 for this V"
        )
    elif status is LevelStatus.FAILED:
        message = "no admissible point found: try more starts or directions"
    return LevelSearchResult(
        status,
        _finite(r.value) if found else None,
        r.method,
        r.shape,
        r.witness,
        r.vdot_witness,
        r.witness_kind,
        seconds,
        message,
        lower,
        details=details,
        **extra,
    )


def level_search(
    system: System,
    V: Any = None,
    *,
    shape: Any = "level",
    method: str = "both",
    sampled: SampledOptions | None = None,
    casadi: CasadiOptions | None = None,
) -> LevelSearchResult:
    """Largest level of ``shape`` on which ``V' < 0`` (Khalil's estimate (3.15)).

    Parameters
    ----------
    system : System
        An autonomous system with an equilibrium.
    V : Lyapunov or n x n matrix, optional
        The Lyapunov candidate (default :func:`roa.default_lyapunov`): a ``QuadraticLyapunov``,
        ``PolynomialLyapunov``, ``FunctionLyapunov`` (any :class:`roa.lyapunov.Lyapunov`) or ``P``.
    shape : {"level", "ball"} or n x n matrix
        Sublevel sets of ``V`` itself, balls of the system's norm, or ``(x - x_eq)' S (x - x_eq)``.
        For a non-quadratic ``V``, "level" searches the first violation along rays by the value
        ``V(x)`` (sampled) and minimises ``V`` s.t. ``V'/V >= 0`` (CasADi).
    method : {"sampled", "casadi", "both"}
        ``both`` runs the two methods and reports whether they agree (relative gap 1e-4).
    sampled, casadi : SampledOptions, CasadiOptions, optional
        Options of each method (defaults in :mod:`roa.options`).

    Returns
    -------
    LevelSearchResult
        ``.level`` (``None`` unless a level was found), ``.status``, ``.witness``.

    Examples
    --------
    >>> import roa
    >>> from roa.systems.vanderpol import vanderpol
    >>> res = roa.level_search(vanderpol(), method="casadi")
    >>> res.status, round(res.level, 4)
    (<LevelStatus.FOUND: 'found'>, 2.3045)
    """
    if method not in METHODS:
        raise RoaInputError(f"method must be one of {METHODS}, got {method!r}")
    if system.equilibrium is None or system.time_varying:
        raise RoaInputError(
            f"system {system.name!r} has no equilibrium (time-varying): no level-set search"
        )
    if system.parameters:
        return _worst_over_box(system, V, shape=shape, method=method, sampled=sampled,
                               casadi=casadi)  # fmt: skip
    notes = check_system(system, analysis=True).notes
    lyap = as_lyapunov(system, V)
    S, name = shape_matrix(system, lyap, shape)
    sampled = SampledOptions() if sampled is None else sampled
    casadi = CasadiOptions() if casadi is None else casadi
    keep = {"system": system, "V": lyap, "S": S}
    runs: list[LevelSearchResult] = []
    if method in ("sampled", "both"):
        t0 = time.perf_counter()
        with step(f"level search: sampled rays ({sampled.n_directions} directions)"):
            r = sampled_level(system, lyap, S, shape=name, **sampled.to_dict())
        runs.append(_wrap(r, time.perf_counter() - t0, **keep))
    if method in ("casadi", "both"):
        t0 = time.perf_counter()
        opts = casadi.to_dict()
        with step(f"level search: CasADi/IPOPT ({casadi.n_starts} starts)"):
            r = casadi_level(system, lyap, S, shape=name, **opts)
        runs.append(_wrap(r, time.perf_counter() - t0, **keep))
    if notes:
        runs = [dataclasses.replace(r, details={**r.details, "notes": list(notes)}) for r in runs]
    if method != "both":
        return runs[0]
    return _combine(runs, keep)


def _rank(res: LevelSearchResult) -> float:
    """Order of results from the worst: no level because V' is not negative near the
    equilibrium (or the search failed) below any level, an unbounded search above any."""
    if res.level is not None:
        return float(res.level)
    return np.inf if res.status is LevelStatus.UNBOUNDED else -np.inf


def _worst_over_box(system: System, V: Any, **kw: Any) -> LevelSearchResult:
    """The search at each sample point of an uncertain system's parameter box (nominal value,
    vertices; :func:`roa.model._parameters.sample_points`), the lowest level reported with the
    parameter values it was found at (``details["parameters"]``) and every point's level
    (``details["per_parameter"]``). A proposal: nothing is searched between the points."""
    from roa.model._parameters import describe_point, sample_points

    check_system(system, analysis=True)  # the box's sample points, with their parameter values
    rows, best, best_p = [], None, None
    for p in sample_points(system):
        res = level_search(system.at(**p), V, **kw)
        rows.append({"parameters": p, "status": res.status.value, "level": res.level})
        if best is None or _rank(res) < _rank(best):
            best, best_p = res, p
    assert best is not None and best_p is not None
    note = (f"worst of {len(rows)} sample points of the parameter box at "
            f"{describe_point(best_p)} (nominal value and vertices; not a bound between them)")  # fmt: skip
    details = {**best.details, "parameters": best_p, "per_parameter": rows}
    return dataclasses.replace(best, message=f"{best.message}; {note}".lstrip("; "),
                               details=details, system=system)  # fmt: skip


def _combine(runs: list[LevelSearchResult], keep: dict[str, Any]) -> LevelSearchResult:
    """Both methods: the smaller found level, and whether they agree."""
    found = [r for r in runs if r.status is LevelStatus.FOUND]
    seconds = sum(r.seconds for r in runs)
    per = {r.method: r for r in runs}
    rel = None
    if len(found) == 2:
        a, b = (float(r.level) for r in found)  # type: ignore[arg-type]
        rel = abs(a - b) / max(abs(a), abs(b)) if max(abs(a), abs(b)) > 0 else 0.0
        status = LevelStatus.AGREE if rel <= AGREEMENT_RTOL else LevelStatus.DISAGREE
        best = min(found, key=lambda r: float(r.level))  # type: ignore[arg-type]
        message = (
            f"methods agree to {rel:.2g}"
            if status is LevelStatus.AGREE
            else (
                f"methods differ by {rel:.2g} (> {AGREEMENT_RTOL:g}): the smaller level is reported; "
                "try more directions or starts"
            )
        )
    elif len(found) == 1:
        status, best = LevelStatus.PARTIAL, found[0]
        other = next(r for r in runs if r is not best)
        message = f"only {best.method} found a level ({other.method}: {other.status.value})"
    else:
        statuses = {r.status for r in runs}
        if len(statuses) == 1:
            status = statuses.pop()
        elif LevelStatus.NOT_LOCALLY_NEGATIVE in statuses:
            status = LevelStatus.NOT_LOCALLY_NEGATIVE
        else:
            status = LevelStatus.FAILED
        best = next((r for r in runs if r.status is status), runs[0])
        message = best.message
    return LevelSearchResult(
        status,
        best.level if found else None,
        "both",
        best.shape,
        best.witness,
        best.vdot_witness,
        best.witness_kind,
        seconds,
        message,
        best.lower_bound,
        rel,
        per,
        dict(best.details),
        **keep,
    )
