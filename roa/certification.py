"""Certify a level set of a Lyapunov candidate: the one chain "find a level, then prove it".

:func:`certify` is the entry point. A level is only called *certified* after the interval
branch-and-bound validation (:func:`roa.proof.validate.validate_level`), which is independent of
the SOS solver and of the level search that proposed it. A candidate level comes from

* the caller (``level=``),
* the SOS program (:func:`roa.search.sos.sos_level`, validated at ``safety_factor`` x its level),
* or the sampled level search (validated at ``sampled_safety`` x the sampled optimum), used when
  SOS does not apply or fails.

With ``check_above``, the level just above the candidate is validated too: a refutation there (a
witness with ``V' >= 0`` checked at 50 digits) shows that the certified level is close to the best
this ``V`` allows.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roa.checks import check_system
from roa.errors import RoaInputError
from roa.fingerprint import system_fingerprint
from roa.levelset import LevelSearchResult, level_search
from roa.lyapunov import Lyapunov, as_lyapunov, certificate_fields
from roa.options import IntervalOptions, SampledOptions, SosOptions, VsOptions
from roa.progress import step
from roa.proof.validate import Validation, validate_level
from roa.search.sos import SOSResult, sos_level
from roa.status import LevelStatus, SosStatus, Verdict
from roa.system import System

METHODS = ("sos", "interval", "both")


@dataclass(frozen=True)
class Certificate:
    """The verdict on ``{V <= level}``, with the evidence and how the level was chosen.

    Attributes
    ----------
    status : Verdict
        ``certified`` only after interval validation; ``refuted`` with a 50-digit witness;
        ``inconclusive`` otherwise (``message`` says why).
    level : float or None
        The level that was validated (or the SOS candidate with ``method="sos"``).
    method : str
        What produced the verdict: ``"interval"``, ``"sos"`` (an unchecked candidate: never
        certified) or ``"level search"`` (no candidate was found).
    level_source : str or None
        Where the level came from: ``"given"``, ``"sos"``, ``"sampled"``, ``"candidate"`` or
        ``"witness"`` (chosen again below a confirmed refutation witness,
        :func:`roa.certification_vs.certify_sampled`).
    candidate : float or None
        The level before the safety factor (SOS optimum or sampled optimum).
    above : Validation or None
        The validation of ``check_above * candidate`` (expected: refuted).
    """

    status: Verdict
    level: float | None
    method: str
    level_source: str | None
    seconds: float
    message: str = ""
    candidate: float | None = None
    safety_factor: float | None = None
    validation: Validation | None = None
    above: Validation | None = None
    sos: SOSResult | None = None
    search: LevelSearchResult | None = None
    vs: Any = None  # VsResult of a degree= search (roa.search.vs_iteration)
    system: System | None = field(default=None, repr=False, compare=False)
    V: Lyapunov | None = field(default=None, repr=False, compare=False)

    @property
    def certified(self) -> bool:
        return self.status is Verdict.CERTIFIED

    @property
    def witness(self) -> list[float] | None:
        return None if self.validation is None else self.validation.witness

    def to_dict(self) -> dict[str, Any]:
        """What ``roa certify --json`` prints."""
        out: dict[str, Any] = {}
        if self.system is not None:
            out["system"] = self.system.name
            out["system_fingerprint"] = system_fingerprint(self.system)
        if self.V is not None:
            out.update(certificate_fields(self.V))
        if self.sos is not None:
            out["sos"] = self.sos.to_json()
        if self.vs is not None:
            out["vs_search"] = self.vs.to_dict()
        if self.search is not None:
            out["level_search"] = {
                "status": self.search.status.value,
                "level": self.search.level,
                "method": self.search.method,
            }
            if self.level_source in ("sampled", "witness"):  # witness: candidate lowered
                out["sampled_level"] = self.search.level
        if self.validation is not None:
            out.update(self.validation.to_json())
        out.update(
            status=self.status.value,
            level=self.level,
            method=self.method,
            level_source=self.level_source,
            candidate=self.candidate,
            safety_factor=self.safety_factor,
            seconds=round(self.seconds, 3),
            message=self.message,
        )
        if self.above is not None:
            out["above"] = self.above.to_json()
        return out

    def plot(self, ax: Any = None, *, axes: tuple[int, int] = (0, 1), n: int = 200) -> Any:
        """The level set ``{V <= level}`` on the slice of two states through the equilibrium."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(5, 4.5))
        if self.level is None or self.V is None or self.system is None:
            ax.set_title(f"no level ({self.status.value})")
            return ax
        i, j = axes
        c = self.V.center
        style = "-" if self.certified else "--"
        label = f"V <= {self.level:.6g} ({self.status})"
        if self.V.P is not None:
            Pij = self.V.P[np.ix_([i, j], [i, j])]
            t = np.linspace(0, 2 * np.pi, n)
            L = np.linalg.cholesky(Pij)
            pts = np.sqrt(self.level) * np.linalg.solve(L.T, np.stack([np.cos(t), np.sin(t)]))
            ax.plot(c[i] + pts[0], c[j] + pts[1], style, label=label)
        else:
            _contour(ax, self.V, self.level, (i, j), n, style, label)
        names, units = self.system.state_names, self.system.state_units or ("-",) * self.system.n
        ax.set_xlabel(f"{names[i]} [{units[i]}]")
        ax.set_ylabel(f"{names[j]} [{units[j]}]")
        ax.legend(loc="best")
        return ax


def _contour(ax: Any, V: Lyapunov, level: float, axes: tuple[int, int], n: int, style: str,
             label: str) -> None:  # fmt: skip
    """The curve V = level on the slice of two states through the centre (any candidate)."""
    from roa.proof.cover import ray_box

    i, j = axes
    c = V.center
    half = ray_box(V, level)
    half = np.ones(V.n) if half is None else 1.2 * half
    a = np.linspace(c[i] - half[i], c[i] + half[i], n)
    b = np.linspace(c[j] - half[j], c[j] + half[j], n)
    A, B = np.meshgrid(a, b)
    X = np.broadcast_to(c, (*A.shape, V.n)).copy()
    X[..., i], X[..., j] = A, B
    ax.contour(A, B, V.value(X), levels=[level], colors="C0", linestyles=style)
    ax.plot([], [], style, color="C0", label=label)


def _validate(
    system: System, V: Lyapunov, level: float, opts: IntervalOptions, bounding_box: Any = None
) -> Validation:
    with step(f"interval validation of level {level:.6g}"):
        return validate_level(
            system, V, level, max_boxes=opts.max_boxes, batch=opts.batch, bounding_box=bounding_box
        )


def certify(
    system: System,
    V: Any = None,
    *,
    level: float | None = None,
    method: str = "both",
    sos: SosOptions | None = None,
    interval: IntervalOptions | None = None,
    sampled: SampledOptions | None = None,
    candidate: LevelSearchResult | float | None = None,
    check_above: float | None = None,
    bounding_box: Any = None,
    degree: int | None = None,
    vs: VsOptions | None = None,
) -> Certificate:
    """Certify (or refute) that ``{V <= level}`` lies in the region of attraction.

    Parameters
    ----------
    system : System
        Autonomous system with an equilibrium; its field must run on the interval namespace.
    V : Lyapunov or n x n matrix, optional
        The candidate (default :func:`roa.default_lyapunov`): any :class:`roa.lyapunov.Lyapunov`
        (``QuadraticLyapunov``, ``PolynomialLyapunov``, ``FunctionLyapunov``) or a matrix ``P``.
        SOS applies to a ``QuadraticLyapunov`` only: for any other ``V``, ``method="both"`` uses
        the sampled search and the interval validation (``level_source="sampled"``).
    level : float, optional
        Validate this level (> 0) by interval branch and bound. Default: find the largest.
    method : {"both", "sos", "interval"}
        How to find the level when ``level`` is not given: ``both`` (SOS, then interval
        validation; the sampled search if SOS does not apply or fails), ``interval`` (sampled
        search, then interval validation) or ``sos`` (the SOS candidate only: never certified).
        With ``level`` only ``interval`` (or ``both``) applies.
    sos, interval, sampled : SosOptions, IntervalOptions, SampledOptions, optional
        Options of each step.
    candidate : LevelSearchResult or float, optional
        A largest level found elsewhere (e.g. by :func:`roa.level_search` with both methods): it is
        validated at ``interval.sampled_safety`` x it, instead of searching again.
    check_above : float, optional
        Also validate ``check_above * candidate`` (> 1, e.g. 1.001); its verdict is ``.above``.
    bounding_box : array, optional
        Non-quadratic ``V``: a box holding the level set (see :func:`roa.validate_level`).
    degree : {2, 4, 6, 8}, optional
        Search a polynomial V of this degree by SOS V-s iteration seeded by ``V`` (quadratic),
        then certify the best candidates (:mod:`roa.certification_vs`); ``level``,
        ``candidate`` and ``method`` do not apply.
    vs : VsOptions, optional
        Options of the V-s iteration.

    Returns
    -------
    Certificate

    Examples
    --------
    >>> import roa
    >>> from roa.systems.vanderpol import vanderpol
    >>> cert = roa.certify(vanderpol(), level=2.30)
    >>> cert.status
    <Verdict.CERTIFIED: 'certified'>
    >>> roa.certify(vanderpol(), level=2.31).status
    <Verdict.REFUTED: 'refuted'>
    """
    t0 = time.perf_counter()
    if degree is not None:
        if level is not None or candidate is not None or method != "both":
            raise RoaInputError("degree= searches V and its level: drop level, candidate, method")
        from roa.certification_vs import certify_degree

        return certify_degree(system, V, degree=degree, vs=vs, interval=interval,
                              sampled=sampled, check_above=check_above)  # fmt: skip
    if method not in METHODS:
        raise RoaInputError(f"method must be one of {METHODS}, got {method!r}")
    if level is not None:
        if not (isinstance(level, int | float) and np.isfinite(level) and level > 0):
            raise RoaInputError(f"level must be a finite number > 0, got {level!r}")
        if method == "sos":
            raise RoaInputError(
                "method='sos' with a given level: a given level is checked by interval "
                "validation only; use method='interval', or drop level to let SOS find one"
            )
    if check_above is not None and not (np.isfinite(check_above) and check_above > 1):
        raise RoaInputError(f"check_above must be a finite number > 1, got {check_above!r}")
    if system.equilibrium is None or system.time_varying:
        raise RoaInputError(f"system {system.name!r} must be autonomous with an equilibrium")
    check_system(system, analysis=True)
    lyap = as_lyapunov(system, V)
    sos = SosOptions() if sos is None else sos
    interval = IntervalOptions() if interval is None else interval
    keep: dict[str, Any] = {"system": system, "V": lyap}
    quad = lyap.as_quadratic()
    quadratic = quad is not None
    if not quadratic and method == "sos" and level is None:
        raise RoaInputError(
            f"method='sos' needs a QuadraticLyapunov; V {lyap.name!r} is "
            f"{type(lyap).__name__}: use method='both' or 'interval' (sampled search + interval "
            "validation)"
        )
    box = bounding_box

    def _check(value: float) -> Validation:
        return _validate(system, lyap, value, interval, box)

    def done(**kw: Any) -> Certificate:
        return Certificate(seconds=time.perf_counter() - t0, **kw, **keep)

    if candidate is not None:
        if level is not None:
            raise RoaInputError("give either level or candidate, not both")
        search = candidate if isinstance(candidate, LevelSearchResult) else None
        value = candidate.level if isinstance(candidate, LevelSearchResult) else candidate
        if value is None or not (np.isfinite(value) and value > 0):
            if search is None:
                raise RoaInputError(f"candidate must be a finite number > 0, got {value!r}")
            return done(status=Verdict.INCONCLUSIVE, level=None, method="level search",
                        level_source=None, message="the candidate level search found no level",
                        search=search)  # fmt: skip
        return _validated(done, _check, float(value), interval.sampled_safety, "candidate",
                          check_above, search=search)  # fmt: skip
    if level is not None:
        v = _check(float(level))
        above = _check(check_above * level) if check_above else None
        return done(status=v.status, level=float(level), method="interval", level_source="given",
                    message=v.message, validation=v, above=above, candidate=float(level))  # fmt: skip
    sos_res = None
    if method in ("sos", "both") and quad is not None:  # SOS: quadratic V
        with step("SOS program (cvxpy + Clarabel)"):
            sos_res = sos_level(
                system,
                quad,
                recast_mode=sos.recast,
                multiplier_degree=sos.multiplier_degree,
                solver_options=sos.solver_options(),
                symmetry=sos.symmetry,
                aux_degree=sos.aux_degree,
            )
        ok = sos_res.status is SosStatus.SOLVED and sos_res.level is not None
        if method == "sos":
            msg = (
                "SOS candidate only (not independently checked); use method='both' for an "
                "interval validation"
                if ok
                else sos_res.message
            )
            return done(status=Verdict.INCONCLUSIVE, level=sos_res.level if ok else None,
                        method="sos", level_source="sos" if ok else None, message=msg,
                        sos=sos_res, candidate=sos_res.level)  # fmt: skip
        if ok:
            assert sos_res.level is not None
            return _validated(done, _check, sos_res.level, sos.safety_factor, "sos",
                              check_above, sos=sos_res)  # fmt: skip
    search = level_search(system, lyap, shape="level", method="sampled", sampled=sampled)
    if search.status is not LevelStatus.FOUND or search.level is None:
        msg = search.message or f"the level search ended {search.status.value}: no candidate"
        if search.status is LevelStatus.UNBOUNDED:
            msg += "; give level= to validate a level of your choice"
        return done(status=Verdict.INCONCLUSIVE, level=None, method="level search",
                    level_source=None, message=msg, sos=sos_res, search=search)  # fmt: skip
    note = (
        ""
        if quadratic or method == "interval"
        else (
            f"SOS applies to quadratic V only ({type(lyap).__name__}): level from the sampled search, "
            "checked by interval validation. "
        )
    )
    return _validated(done, _check, search.level, interval.sampled_safety, "sampled",
                      check_above, note=note, sos=sos_res, search=search)  # fmt: skip


def _validated(
    done: Any,
    check: Any,
    candidate: float,
    factor: float,
    source: str,
    check_above: float | None,
    note: str = "",
    **extra: Any,
) -> Certificate:
    v = check(factor * candidate)
    above = check(check_above * candidate) if check_above else None
    return done(status=v.status, level=factor * candidate, method="interval",
                level_source=source, message=note + v.message, candidate=candidate,
                safety_factor=factor, validation=v, above=above, **extra)  # fmt: skip
