"""The strategies :func:`roa.certify` is built from: sources of V, level proposers, validators.

Each is a small object with ``accepts(system, V)`` and one action, as cvxpy's reductions are:

* **Validators** decide a level (:class:`Validator`): :class:`IntervalValidator`, the interval
  branch and bound of :func:`roa.proof.validate.validate_level`, and :class:`SosValidator`, an
  SOS certificate checked in exact rationals (polynomial fields and V, any dimension).
* **Level proposers** find a candidate level and own the safety factor it is validated at
  (:class:`LevelProposer`): :class:`GivenLevel`, :class:`CandidateLevel` (a level found
  elsewhere), :class:`SosLevel` (quadratic V), :class:`SampledLevel` (any V).
* **Sources of V** propose candidates (:class:`VSource`): :class:`VsIteration` (SOS V-s
  iteration), :class:`CuttingPlanes` (sampled cutting planes); a given V is its own source.

Proposers and sources prove nothing; only a validator's verdict reaches ``certified``.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.model.system import System
from roa.options import (
    BNB_DIM,
    BNB_SECONDS_BACKUP,
    IntervalOptions,
    SampledOptions,
    SampleSearchOptions,
    SosOptions,
    VsOptions,
)
from roa.progress import step
from roa.proof.preconditions import Preconditions, Route, check_preconditions
from roa.proof.putinar import check_level
from roa.proof.recast import level_scale, recast_preconditions
from roa.proof.recast_box import box_json
from roa.proof.reductions import IndependentBlocks, Rescale
from roa.proof.sos_stored import part_json
from roa.proof.validate import validate_level
from roa.proof.validation import Validation
from roa.search.levelset import LevelSearchResult, level_search
from roa.search.sos_certificate import default_eps, propose_certificate
from roa.search.sos_putinar import propose_putinar
from roa.search.sos_sparse import ROUTES, choose_route, propose_sparse
from roa.status import LevelStatus, SosStatus, Verdict


# -- validators ------------------------------------------------------------------------------------
@runtime_checkable
class Validator(Protocol):
    """Decides ``V' < 0`` on ``{V <= level}`` minus the equilibrium: certified, refuted (with a
    witness) or inconclusive."""

    @property
    def name(self) -> str: ...

    def accepts(self, system: System, V: Lyapunov) -> bool: ...

    def check(self, system: System, V: Lyapunov, level: float) -> Validation: ...


def _preconditions(system: System, V: Lyapunov, level: float, route: Route) -> Preconditions:
    """:func:`roa.proof.preconditions.check_preconditions` for a fresh certificate (a Putinar
    candidate of the domain containment proposed by :mod:`roa.search.sos_domain`)."""
    from roa.search.sos_domain import propose_domain_certificate

    with step(f"preconditions of level {level:.6g} ({route.name})"):
        return check_preconditions(system, V, level, route, propose=propose_domain_certificate)


def _with_domain(v: Validation, pre: Preconditions) -> Validation:
    """A certified ``v`` with the evidence of its domain containment: a Putinar certificate is
    stored inside the SOS certificate (``certificate["domain"]``, re-checked with it)."""
    if v.status is not Verdict.CERTIFIED or pre.domain is None:
        return v
    meta = {**v.meta, "domain": {k: val for k, val in pre.domain.items()
                                 if k in ("method", "boxes", "digest")}}  # fmt: skip
    cert = meta.get("certificate")
    if isinstance(cert, dict) and pre.domain.get("method") == "putinar":
        meta["certificate"] = {**cert, "domain": pre.domain}
    note = pre.notes.get("domain")
    message = f"{v.message}; domain: {note}" if note else v.message
    return dataclasses.replace(v, meta=meta, message=message)


#: What the interval branch and bound proves by itself (:class:`roa.proof.preconditions.Route`).
INTERVAL_ROUTE = Route("interval", parameters=True, cover=True, domain_by_boxes=True)
#: What the exact SOS routes prove by themselves (a box of parameters: the recast route).
SOS_ROUTE = Route("sos-exact", parameters=True)


@dataclass(frozen=True)
class IntervalValidator:
    """Interval branch and bound with outward rounding (:func:`roa.proof.validate.validate_level`).

    Accepts every autonomous system with an equilibrium and every V, continuous-time (``V' < 0``)
    or discrete-time (``V(F(x)) - V(x) < 0``, the whole sublevel set then proved invariant);
    ``bounding_box`` (any V) is a box holding the level set, proved by ``V > level`` on its
    faces (a map needs the whole sublevel set: the ``invariant`` precondition). For a system with
    uncertain parameters the level is proved for every parameter of the box
    (:func:`roa.proof.robust.validate_robust`).
    """

    options: IntervalOptions = field(default_factory=IntervalOptions)
    bounding_box: Any = None
    name: str = "interval"

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return system.equilibrium is not None and not system.time_varying

    def check(self, system: System, V: Lyapunov, level: float) -> Validation:
        pre = _preconditions(system, V, level, INTERVAL_ROUTE)
        if pre.refusal is not None:
            return pre.refusal
        if system.parameters:
            from roa.proof.robust import validate_robust
            from roa.search.robust_witness import sampled_witness

            with step(f"robust interval validation of level {level:.6g}", own_budget=True):
                return validate_robust(system, V, level, witness_search=sampled_witness,
                                       max_boxes=self.options.max_boxes,
                                       batch=self.options.batch,
                                       bounding_box=self.bounding_box,
                                       time_limit=self.options.seconds())  # fmt: skip
        with step(f"interval validation of level {level:.6g}", own_budget=True):
            return validate_level(system, V, level, max_boxes=self.options.max_boxes,
                                  batch=self.options.batch, bounding_box=self.bounding_box,
                                  time_limit=self.options.seconds())  # fmt: skip


@dataclass(frozen=True)
class SosValidator:
    """Exact SOS certificate of the level (:mod:`roa.proof.sos_check`): polynomial V.

    The numerical SOS program (:func:`roa.search.sos_certificate.propose_certificate`) proposes
    Gram matrices; their rounding and exact projection (Peyrl-Parrilo, python-flint) proves
    ``V' < 0`` on ``{V <= level}`` minus the equilibrium, or the verdict is inconclusive (with the
    reason). It never refutes (the pipeline refutes above with the branch and bound or a
    confirmed witness of the level search). Its
    cost grows polynomially with the dimension (the Gram basis), not exponentially as the branch
    and bound's boxes do.

    A system with uncertain parameters is proved for every parameter of its box: the parameters
    are indeterminates of the certificate, constrained to the box by Putinar multipliers
    (:mod:`roa.proof.recast_box`, through the recast route even for a polynomial field).

    A non-polynomial field (sin/cos of states, rational terms, square roots) is recast exactly
    (:mod:`roa.proof.recast`) and proved by a constrained certificate
    (:func:`roa.proof.putinar.check_level`, proposed by :mod:`roa.search.sos_putinar`); a field that
    cannot be recast (the term is named), or one with a domain, is decided by the interval branch
    and bound instead (``fallback=True``, the certificate's method is then ``interval``) or is
    inconclusive (``fallback=False``, and :meth:`accepts` refuses it).

    When ``V`` and ``V'`` of a polynomial field split over independent blocks of variables
    (:mod:`roa.proof.sos_blocks`: decoupled subsystems), each block gets its own certificate at the
    same level, which proves the whole. A coupled system whose dense program does not fit the
    memory budget (``route="auto"``; ``"sparse"`` forces it) gets the correlative-sparsity
    program instead (:mod:`roa.search.sos_sparse`: one Gram block per maximal clique of a chordal
    extension of the variables' interaction graph), proved by the same exact identity over the sum
    of its blocks (:func:`roa.proof.putinar.check_level`); its ``meta`` reports the cliques' and blocks' sizes,
    the solver's and the check's seconds and the process's peak memory (``peak_mib``). A dense
    coupled system with neither gets the sign-symmetry blocks and, for those too large for the
    interior point, scaled diagonally dominant blocks (``route="sdsos"``,
    :func:`roa.search.sos_sparse.sdsos_plan`), proved by exact scaled diagonal dominance.

    When the exact check fails at a proposed level (not one the caller gave), up to ``backoff``
    lower levels are tried on this route before any branch and bound
    (:mod:`roa.certification.backoff`; each try in the trace and in ``meta["backoff"]``).
    ``solver_options`` may name the solver (``"solver"``: ``"clarabel"``, ``"scs"`` or
    ``"auto"``) and its tolerances (:func:`roa.search.sdp.settings`).

    Examples
    --------
    >>> import roa
    >>> from roa.systems.vanderpol import vanderpol
    >>> roa.certify(vanderpol(), level=2.3, validator=roa.SosValidator()).status.value
    'certified'
    """

    multiplier_degree: int | None = None
    eps: float = 1e-6  # x the largest coefficient of V's lowest-degree part
    solver_options: Any = None
    name: str = "sos-exact"
    fallback: bool = True  # a field that cannot be recast goes to the branch and bound
    taylor: int | None = None  # order of the sin bounds of a recast (default from the level)
    refutes: bool = False  # the pipeline refutes above with the branch and bound
    route: str = "auto"  # "dense", "sparse" (cliques), "sdsos" or "auto" (by the memory budget)
    backoff: int = 5  # lower levels tried when the exact check fails (roa.certification.backoff)

    def __post_init__(self) -> None:
        if self.route not in ROUTES:
            raise RoaInputError(f"SosValidator route must be one of {ROUTES}, got {self.route!r}")
        if isinstance(self.backoff, bool) or not isinstance(self.backoff, int) or not (
                0 <= self.backoff <= 20):  # fmt: skip
            raise RoaInputError(f"SosValidator backoff must be an integer in [0, 20], got "
                                f"{self.backoff!r}")  # fmt: skip

    def accepts(self, system: System, V: Lyapunov) -> bool:
        if getattr(V, "terms", None) is None or system.equilibrium is None:
            return False
        if system.time_varying:
            return False
        return self.fallback or self.recast_error(system, V) is None

    @staticmethod
    def recast_error(system: System, V: Lyapunov) -> str | None:
        """None if the field is polynomial or can be recast exactly, else why not (naming the
        term)."""
        from roa.proof.recast import recast_exact
        from roa.proof.sos_check import NotPolynomial, exact_data

        if not getattr(system, "parameters", None):  # a box goes to the recast route
            try:
                exact_data(system, V)
                return None
            except NotPolynomial as exc:
                if system.time == "discrete":
                    return f"{exc} (a map is checked as a polynomial, never recast)"
        elif system.time == "discrete":
            return "a map with uncertain parameters is not checked by SOS (no recast for maps)"
        try:
            recast_exact(system, V, taylor=1)
            return None
        except NotPolynomial as exc:
            return str(exc)

    def check(self, system: System, V: Lyapunov, level: float) -> Validation:
        """The level decided by an exact SOS certificate, after every precondition of
        :mod:`roa.proof.preconditions` (the domain containment stored with the certificate)."""
        if self.fallback and self._needs_fallback(system, V):
            return self._prove(system, V, level)  # the branch and bound checks its own
        pre = _preconditions(system, V, level, SOS_ROUTE)
        if pre.refusal is not None:
            return pre.refusal
        return _with_domain(self._prove(system, V, level), pre)

    def _needs_fallback(self, system: System, V: Lyapunov) -> bool:
        from roa.proof.sos_check import NotPolynomial, exact_data

        if not getattr(system, "parameters", None):
            try:
                exact_data(system, V)
                return False
            except NotPolynomial:
                pass
        return self.recast_error(system, V) is not None

    def _prove(self, system: System, V: Lyapunov, level: float) -> Validation:
        from roa.proof.sos_check import NotPolynomial, exact_data, preconditions

        t0 = time.perf_counter()

        def out(status: Verdict, message: str, **meta: Any) -> Validation:
            return Validation(status, float(level), 0, time.perf_counter() - t0,
                              message=message, meta={"method": self.name, **meta})  # fmt: skip

        try:
            if getattr(system, "parameters", None):
                raise NotPolynomial("uncertain parameters")
            exact_data(system, V)
        except NotPolynomial:
            why = self.recast_error(system, V)
            if why is None:
                return self._check_recast(system, V, level, out)
            if not self.fallback:
                return out(Verdict.INCONCLUSIVE, f"not polynomial, no exact recast: {why}")
            v = IntervalValidator().check(system, V, level)  # robust for uncertain parameters
            return dataclasses.replace(v, message=f"SOS not applicable ({why}); interval branch "
                                       f"and bound: {v.message}",
                                       meta={**v.meta, "method": "interval"})  # fmt: skip
        with step(f"SOS exact validation of level {level:.6g}"):
            data, why = preconditions(system, V, level)
            if data is None:
                return out(Verdict.INCONCLUSIVE, why)
            first = self._prove_data(data, V, level, out)
        if first.status is Verdict.CERTIFIED:
            return first
        rescale = Rescale(level_scale(V, level))
        if not rescale.accepts(data):
            return first
        (scaled,), scale = rescale.apply(data)
        with step(f"SOS exact validation of level {level:.6g}, variables rescaled"):
            again = self._prove_data(scaled, V, level, out)
        if again.status is not Verdict.CERTIFIED:
            return first
        cert = rescale.invert(again.meta["certificate"]["parts"], scale)
        return dataclasses.replace(again, meta={**again.meta, "certificate": cert},
                                   message=f"{again.message} (in d = diag(scale) y, scale "
                                   f"{[str(r) for r in scale]}; unscaled: {first.message})")  # fmt: skip

    def _prove_data(self, data: Any, V: Lyapunov, level: float, out: Any) -> Validation:
        """The certificate of the exact data ``data`` (in ``d`` or in rescaled variables): one
        part per independent block of variables (:func:`roa.proof.sos_blocks.blocks`), each
        proposed by the dense or the sparse program (:func:`roa.search.sos_sparse.choose_route`)
        and proved by :func:`roa.proof.putinar.check_level`."""
        import resource

        split = IndependentBlocks()
        subs, parts = split.apply(data)
        whole = len(parts) == 1
        stored: list[dict[str, Any]] = []
        statuses: list[str] = []
        margins: list[float | None] = []
        sizes: list[int] = []
        figures: dict[str, Any] = {}
        sdp_seconds = 0.0
        res: Any = None
        plan: Any = None
        for block, sub in zip(parts, subs, strict=True):
            where = "" if whole else f" (block {list(block)})"
            route, plan, why = choose_route(sub, self.multiplier_degree, self.route,
                                            self.solver_options)  # fmt: skip
            if route == "too_large":
                return out(Verdict.INCONCLUSIVE, f"SOS program too large, not built{where}: {why}",
                           route=route)  # fmt: skip
            eps = default_eps(sub, self.eps)
            if plan is not None:  # the clique or the SDSOS pattern
                cand = propose_sparse(sub, level, plan, eps=eps,
                                      solver_options=self.solver_options)  # fmt: skip
                figures.update(route=route, why_sparse=why, blocks=plan.sizes, **cand.sizes)
                sizes += [len(b) for b in plan.sigma] if whole else [plan.largest]
            else:
                cand = propose_certificate(sub, level, eps=eps,
                                           multiplier_degree=self.multiplier_degree,
                                           solver_options=self.solver_options)  # fmt: skip
                sizes.append(max(cand.sizes["gram_sizes"]))
            statuses.append(cand.solver_status)
            margins.append(cand.margin)
            sdp_seconds += cand.seconds
            figures.update(solver_status=statuses[0] if whole else statuses,
                           margin=margins[0] if whole else margins,
                           sdp_seconds=round(sdp_seconds, 3), gram_sizes=sizes)  # fmt: skip
            if cand.certificate is None:
                return out(Verdict.INCONCLUSIVE, f"SOS solver failed{where} "
                           f"({cand.solver_status})", **figures)  # fmt: skip
            t0 = time.perf_counter()
            res = check_level(sub, level, eps, cand.certificate)
            if plan is not None:
                figures.update(check_seconds=round(time.perf_counter() - t0, 3),
                               peak_mib=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
                                              / 1024))  # fmt: skip
            if not res.ok or res.certificate is None:
                return out(Verdict.INCONCLUSIVE, f"SOS check failed{where}: {res.reason}",
                           residual=res.residual, min_pivot=res.min_pivot, **figures)  # fmt: skip
            extra = {"cliques": [list(c) for c in plan.cliques]} if route == "sparse" else {}
            if route == "sdsos":
                extra = {"sdsos": plan.sizes}
            stored.append(part_json(list(block), res.certificate, None if whole else eps,
                                    **extra))  # fmt: skip
        if whole:  # eps, digest, k, residual, min_pivot in the meta (eps read by a re-check)
            what = "SOS certificate"
            if plan is not None and plan.kind == "sdsos":
                what = (f"SDSOS certificate (sign blocks {[len(b) for b in plan.sigma]}, scaled "
                        f"diagonally dominant {plan.sizes['sdd_blocks']})")  # fmt: skip
            elif plan is not None:
                what = (f"sparse SOS certificate ({len(plan.cliques)} cliques of sizes <= "
                        f"{max(map(len, plan.cliques))})")  # fmt: skip
            return out(Verdict.CERTIFIED, f"{what} checked exactly: {res.reason}",
                       certificate={"parts": stored}, M=np.eye(V.n).tolist(), **figures,
                       residual=res.residual, min_pivot=res.min_pivot, **res.meta)  # fmt: skip
        # the whole of {V <= level} is proved (not one component): any frame bounds it
        reason = (f"{len(parts)} independent blocks of variables (sizes "
                  f"{[len(b) for b in parts]}), each: {res.reason}")  # fmt: skip
        return out(Verdict.CERTIFIED, f"SOS certificate checked exactly: {reason}",
                   certificate=split.invert(stored, parts), M=np.eye(V.n).tolist(),
                   **figures)  # fmt: skip

    def _check_recast(self, system: System, V: Lyapunov, level: float, out: Any) -> Validation:
        """The recast field's (or parameter box's) constrained certificate
        (:func:`roa.proof.putinar.check_level` with the recast's constraints)."""
        with step(f"SOS exact validation (recast field) of level {level:.6g}"):
            scale = level_scale(V, level)
            data, why = recast_preconditions(system, V, level, self.taylor, scale)
            if data is None:
                return out(Verdict.INCONCLUSIVE, why)
            eps = default_eps(data, self.eps)
            cand = propose_putinar(data, level, eps=eps, solver_options=self.solver_options)
            figures = {"solver_status": cand.solver_status, "margin": cand.margin,
                       "sdp_seconds": round(cand.seconds, 3), "eps": str(eps),
                       "sizes": cand.sizes, "recast": data.description}  # fmt: skip
            if cand.certificate is None:
                return out(Verdict.INCONCLUSIVE, f"SOS solver failed ({cand.solver_status})",
                           **figures)  # fmt: skip
            res = check_level(data, level, eps, cand.certificate)
            figures.update(residual=res.residual, min_pivot=res.min_pivot, **res.meta)
            if not res.ok or res.certificate is None:
                return out(Verdict.INCONCLUSIVE, f"SOS check failed: {res.reason}", **figures)
            cert = {"parts": [part_json(list(range(V.n)), res.certificate)],
                    "taylor": data.taylor, "scale": [str(r) for r in data.scale]}  # fmt: skip
            if data.parameters:  # the box it holds for (a re-check takes the system's)
                cert["parameters"] = box_json(data.parameters)
            return out(Verdict.CERTIFIED, f"SOS certificate of the recast field ({data.description}) "
                       f"checked exactly: {res.reason}", certificate=cert,
                       M=np.eye(V.n).tolist(), **figures)  # fmt: skip


@dataclass(frozen=True)
class AutoValidator:
    """The route that certifies, chosen from the problem's form.

    Where the branch and bound's dimension allows it (states plus uncertain parameters at most
    ``max_bnb_dim``) it decides first (it also refutes, with a 50-digit witness) and the exact SOS
    certificate is tried when it is inconclusive; above, the exact SOS certificate (polynomial or
    exactly recast fields, decoupled blocks) is tried first and the branch and bound decides when
    it does not certify. Either way only a validator's own proof certifies; the verdict's
    ``method`` names the one that decided. Above ``max_bnb_dim``, when the SOS route does not
    certify, the level search's witness (``witness_search``:
    :func:`roa.certification.pipeline.witness_by_search`, a 50-digit point of ``{V' >= 0}`` with
    ``V <= level``) refutes before the branch and bound runs, within its time budget
    (``time_limit``, default :data:`roa.options.BNB_SECONDS_BACKUP`).
    """

    options: IntervalOptions = field(default_factory=IntervalOptions)
    bounding_box: Any = None
    max_bnb_dim: int = BNB_DIM
    name: str = "auto"
    witness_search: bool = True

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return system.equilibrium is not None and not system.time_varying

    def check(self, system: System, V: Lyapunov, level: float) -> Validation:
        itv = IntervalValidator(self.options, self.bounding_box)
        sos = SosValidator(fallback=False)
        sos_ok = self.bounding_box is None and sos.accepts(system, V)

        def by_interval(v: Validation, note: str = "") -> Validation:
            return dataclasses.replace(v, message=f"{note}{v.message}",
                                       meta={**v.meta, "method": itv.name})  # fmt: skip

        if V.n + len(system.uncertain) <= self.max_bnb_dim or not sos_ok:
            v = itv.check(system, V, level)
            if v.status is not Verdict.INCONCLUSIVE or not sos_ok:
                return by_interval(v)
            s = sos.check(system, V, level)
            if s.status is not Verdict.INCONCLUSIVE:
                return s
            return by_interval(v, f"SOS route: {s.message}; branch and bound: ")
        s = sos.check(system, V, level)
        if s.status is not Verdict.INCONCLUSIVE:  # certified, or a precondition refuted
            return s
        note = ""
        if self.witness_search:
            from roa.certification.pipeline import witness_by_search

            found, note = witness_by_search(system, V, level, [])
            if found is not None:
                return dataclasses.replace(found, meta={**found.meta, "method": "witness search"})
        backup = IntervalValidator(self.options.replace(
            time_limit=self.options.seconds(BNB_SECONDS_BACKUP)), self.bounding_box)  # fmt: skip
        return by_interval(backup.check(system, V, level), f"SOS route: {s.message}; "
                           + (f"{note}; " if note else "") + "branch and bound: ")  # fmt: skip


# -- level proposers --------------------------------------------------------------------------------
@dataclass(frozen=True)
class Proposal:
    """A candidate level: ``candidate`` (an optimum, an upper bound of the largest level) and the
    ``level`` to validate (``factor`` x it); ``level`` None when there is none (``message``)."""

    source: str
    candidate: float | None
    factor: float | None
    message: str = ""
    sos: Any = None
    search: LevelSearchResult | None = None
    final: bool = False  # a proposal that is the answer itself (SOS only, never certified)
    parameters: dict[str, float] | None = None  # the parameter values it was found at

    @property
    def level(self) -> float | None:
        if self.candidate is None:
            return None
        return self.candidate * (1.0 if self.factor is None else self.factor)


@runtime_checkable
class LevelProposer(Protocol):
    """Proposes a level for V (never proves it)."""

    def accepts(self, system: System, V: Lyapunov) -> bool: ...

    def propose(self, system: System, V: Lyapunov) -> Proposal: ...


def _positive(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
        raise RoaInputError(f"{what} must be a finite number > 0, got {value!r}")
    if not value > 0:
        raise RoaInputError(f"{what} must be a finite number > 0, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class GivenLevel:
    """The caller's level, validated as it is (no safety factor, no retry below it)."""

    level: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "level", _positive(self.level, "level"))

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return True

    def propose(self, system: System, V: Lyapunov) -> Proposal:
        return Proposal("given", self.level, None)


@dataclass(frozen=True)
class CandidateLevel:
    """A largest level found elsewhere (a number, or a :class:`roa.LevelSearchResult`),
    validated at ``safety`` x it."""

    candidate: LevelSearchResult | float
    safety: float = 0.999

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return True

    def propose(self, system: System, V: Lyapunov) -> Proposal:
        search = self.candidate if isinstance(self.candidate, LevelSearchResult) else None
        value: Any = search.level if search is not None else self.candidate
        if value is None or not (np.isfinite(value) and value > 0):
            if search is None:
                raise RoaInputError(f"candidate must be a finite number > 0, got {value!r}")
            return Proposal("candidate", None, None, "the candidate level search found no level",
                            search=search)  # fmt: skip
        return Proposal("candidate", float(value), self.safety, search=search)


@dataclass(frozen=True)
class SosLevel:
    """The SOS program's largest level (:func:`roa.search.sos.sos_level`), quadratic V only;
    for a polynomial system whose V and V' split over independent blocks of variables, the least
    of the blocks' levels found by bisection (:mod:`roa.search.sos_bisection`); validated at
    ``options.safety_factor`` x it. ``only=True``: the SOS level is the answer
    (never certified: no independent check)."""

    options: SosOptions = field(default_factory=SosOptions)
    only: bool = False

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return V.as_quadratic() is not None and system.time == "continuous"

    def propose(self, system: System, V: Lyapunov) -> Proposal:
        from roa.search.sos import sos_level

        quad = V.as_quadratic()
        assert quad is not None
        o = self.options
        res = _block_sos_level(system, V, o)
        if res is None:
            with step("SOS program (cvxpy + Clarabel)"):
                res = sos_level(system, quad, recast_mode=o.recast,
                                multiplier_degree=o.multiplier_degree,
                                solver_options=o.solver_options(), symmetry=o.symmetry,
                                aux_degree=o.aux_degree)  # fmt: skip
        ok = res.status is SosStatus.SOLVED and res.level is not None
        if self.only:
            msg = (
                "SOS candidate only (not independently checked); use method='both' for an "
                "interval validation"
                if ok
                else res.message
            )
            return Proposal("sos", res.level if ok else None, None, msg, sos=res, final=True)
        if not ok:
            return Proposal("sos", None, None, res.message, sos=res)
        return Proposal("sos", res.level, o.safety_factor, sos=res)


def _block_sos_level(system: System, V: Lyapunov, o: SosOptions) -> Any:
    """The SOS level of a polynomial system whose V and V' split over independent blocks of
    variables (:func:`roa.search.sos_bisection.block_levels`: bisection per distinct block, the
    least level), or of a coupled one whose dense program does not fit the memory budget but
    whose sparse program does (:func:`roa.search.sos_sparse.choose_route`: bisection with the
    chordal clique program), as an ``SOSResult``; None when the data are not polynomial or
    neither applies (then the one program of :func:`roa.search.sos.sos_level` is used)."""
    from roa.proof.sos_check import NotPolynomial, exact_data
    from roa.search.sos import SOSResult
    from roa.search.sos_bisection import block_levels

    if system.equilibrium is None or system.time_varying or getattr(system, "parameters", None):
        return None
    try:
        data = exact_data(system, V)
    except NotPolynomial:
        return None
    parts = IndependentBlocks().blocks(data)
    sparse, plan = False, None
    if len(parts) < 2:
        route, plan, _ = choose_route(data, solver_options=o.solver_options())
        if route not in ("sparse", "sdsos"):
            return None
        sparse = True
    what = ("the sparse (chordal clique) program" if sparse and route == "sparse"
            else "the SDSOS program (sign blocks, scaled diagonally dominant)" if sparse
            else f"{len(parts)} independent blocks of variables")  # fmt: skip
    with step(f"SOS level by bisection with {what}"):
        bl = block_levels(data, solver_options=o.solver_options())
    sizes = {**bl.sizes, "programs": bl.programs}
    if sparse:
        assert plan is not None
        sizes["sparse"] = plan.sizes
        res = SOSResult(SosStatus.SOLVED if bl.level is not None else SosStatus.FAILED, bl.level,
                        "bisection", bl.seconds, "none (polynomial)", sizes,
                        f"SOS bisection with {what}: {bl.message}" if bl.level is None
                        else f"largest level of {what} (bisection)")  # fmt: skip
        return res
    if bl.level is None:
        return SOSResult(SosStatus.FAILED, None, "bisection", bl.seconds, "none (polynomial)",
                         sizes, f"SOS bisection over independent blocks: {bl.message}")  # fmt: skip
    return SOSResult(SosStatus.SOLVED, bl.level, "bisection", bl.seconds, "none (polynomial)",
                     sizes, f"least of {len(parts)} block levels (bisection)")  # fmt: skip


@dataclass(frozen=True)
class SampledLevel:
    """The sampled level search's optimum (:func:`roa.level_search`, any V), validated at
    ``safety`` x it."""

    options: SampledOptions | None = None
    safety: float = 0.999

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return True

    def propose(self, system: System, V: Lyapunov) -> Proposal:
        search = level_search(system, V, shape="level", method="sampled", sampled=self.options)
        if search.status is not LevelStatus.FOUND or search.level is None:
            msg = search.message or f"the level search ended {search.status.value}: no candidate"
            if search.status is LevelStatus.UNBOUNDED:
                msg += "; give level= to validate a level of your choice"
            return Proposal("sampled", None, None, msg, search=search)
        return Proposal("sampled", float(search.level), self.safety, search=search)


@dataclass(frozen=True)
class WorstCase:
    """A proposer run at each sample point of an uncertain system's parameter box
    (:func:`roa.model.parameters.sample_points`: nominal value, vertices and ``per_axis`` points along
    each axis); the lowest level wins.
    A proposal only: the robust validator decides for every parameter of the box."""

    inner: LevelProposer
    per_axis: int = 3  # interior points along each parameter's axis, beside the vertices

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return self.inner.accepts(system.nominal(), V)

    def propose(self, system: System, V: Lyapunov) -> Proposal:
        from roa.model.parameters import describe_point, sample_points

        best: Proposal | None = None
        for p in sample_points(system, per_axis=self.per_axis):
            prop = dataclasses.replace(self.inner.propose(system.at(**p), V), parameters=p)
            if prop.level is None:
                if prop.final or best is None:
                    best = best or prop
                continue
            if best is None or best.level is None or prop.level < best.level:
                best = prop
        assert best is not None
        if best.level is not None and best.parameters is not None:
            note = f"lowest over the box's sample points at {describe_point(best.parameters)}"
            best = dataclasses.replace(best, message=f"{best.message}; {note}".lstrip("; "))
        return best


# -- sources of V ------------------------------------------------------------------------------------
@runtime_checkable
class VSource(Protocol):
    """Proposes candidates V from a quadratic seed (never proves them)."""

    @property
    def seed(self) -> Any: ...

    @property
    def degree(self) -> int: ...

    def search(self, system: System, seed: Any) -> Any: ...


DEGREES = (2, 4, 6, 8)


@dataclass(frozen=True)
class VsIteration:
    """SOS V-s iteration (:func:`roa.search.vs_iteration.vs_search`): one candidate per round,
    tried best shape level first; ``options.validate`` of them are validated at most."""

    degree: int = 4
    options: VsOptions = field(default_factory=VsOptions)
    seed: Any = None  # the quadratic seed (default: the system's quadratic V)

    def __post_init__(self) -> None:
        if self.degree not in DEGREES:
            raise RoaInputError(f"degree must be one of {DEGREES}, got {self.degree!r}")

    def search(self, system: System, seed: Any) -> Any:
        from roa.search.vs_iteration import vs_search

        vs = self.options
        with step(f"SOS V-s iteration, degree {self.degree}", own_budget=True):
            return vs_search(system, seed, degree=self.degree,
                             shape=None if vs.shape is None else np.asarray(vs.shape),
                             rounds=vs.rounds, multiplier_degree=vs.multiplier_degree,
                             symmetry=vs.symmetry, aux_degree=vs.aux_degree, recast_mode=vs.recast,
                             tol=vs.tol, solver_options=vs.solver_options(),
                             solver=vs.solver, budget=vs.budget)  # fmt: skip


@dataclass(frozen=True)
class CuttingPlanes:
    """Sampled cutting planes (:func:`roa.search.cutting_planes.sample_search`): one candidate,
    its level chosen at ``options.level_safety`` x its sampled optimum (capped at 1, the search's
    target level) or by ``level`` (a number, or ``level(V, c*)``)."""

    options: SampleSearchOptions = field(default_factory=SampleSearchOptions)
    hard: Any = None
    soft: Any = None
    level: Any = None
    seed: Any = None  # the quadratic seed (default: the system's quadratic V)

    @property
    def degree(self) -> int:
        return int(self.options.degree)

    def search(self, system: System, seed: Any) -> Any:
        from roa.search.cutting_planes import sample_search

        with step(f"sampled search of V, degree {self.options.degree}"):
            return sample_search(system, seed, hard=self.hard, soft=self.soft,
                                 options=self.options)  # fmt: skip
