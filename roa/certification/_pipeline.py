"""``roa.certify``: a pipeline of strategies, "find V, propose a level, prove it, refute above".

The stages, each an object of :mod:`roa.certification._strategies` or of this module:

1. **V**: the caller's candidate (default :func:`roa.default_lyapunov`), or ``(V, proposer)``
   pairs from a source of V (:class:`~roa.certification.VsIteration`,
   :class:`~roa.certification.CuttingPlanes`) seeded by a quadratic V.
2. **Level**: the first proposer that accepts V and finds a level (default: SOS for a quadratic V,
   else the sampled level search); each proposer owns its safety factor.
3. **Proof**: the validator (the interval branch and bound) decides the level. It alone can
   certify.
4. **Refinement** (:class:`RetryPolicy`): a proposed level refuted by a confirmed witness (V' >= 0
   at 50 digits, in the equilibrium's component) is chosen again below ``V(witness)``, which
   bounds the true optimum (``retries`` times at most; a level the caller gave is never changed);
   a level proposed at sample points of a parameter box and left inconclusive is backed off.
5. **Refutation above** (:class:`WitnessRefuter`): with ``check_above``, ``check_above`` x the
   optimum is refuted, by a confirmed witness below it when there is one, else by the validator.

:func:`certify` maps its arguments (numbers, mode and validator names, shorthands) to these
objects in one place (:func:`plan`); :func:`run` and the stages see objects only. Every stage
leaves an entry in ``Certificate.trace``.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roa.certification._result import Certificate
from roa.certification._strategies import (
    DEGREES,
    AutoValidator,
    CandidateLevel,
    Candidates,
    CuttingPlanes,
    GivenLevel,
    IntervalValidator,
    LevelProposer,
    Proposal,
    ProposerBase,
    SampledLevel,
    SosLevel,
    SosValidator,
    Validator,
    VsIteration,
    VSource,
    as_proposer,
    as_validator,
    positive_level,
    searchable,
    witness_by_search,
)
from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov, QuadraticLyapunov
from roa.model._checks import check_system
from roa.model._parameters import ParameterBox
from roa.model._system import System
from roa.options import IntervalOptions, SampledOptions, SosOptions, VsOptions
from roa.progress import step
from roa.proof._validation import Reason, Validation
from roa.search._candidate import as_lyapunov
from roa.search._levelset import LevelSearchResult
from roa.status import Verdict

METHODS = ("sos", "interval", "both")
VALIDATORS = ("interval", "sos", "auto")
#: Times a proposed level is chosen again below a confirmed witness.
RETRIES = 3
#: Factors of the levels tried after an inconclusive validation of a level proposed at sample
#: points of a parameter box (the worst case may lie between them).
BACKOFF = (0.98, 0.95, 0.9)

#: A confirmed witness ``(x, check, V(x), parameters)`` bounding the optimum from above.
Proof = tuple[Any, Any, float, Any]


# -- policies ----------------------------------------------------------------------------------------
@dataclass
class Attempt:
    """The level under validation and what the pipeline knows about it: its validation ``v``,
    the level ``value``, the least known upper bound ``opt`` of the optimum, a confirmed witness
    ``proof`` below it, and the notes of the refinement and of the back-off."""

    v: Validation
    value: float
    opt: float
    proof: Proof | None = None
    notes: list[str] = field(default_factory=list)
    backoff: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class RetryPolicy:
    """What follows the first validation of a proposed level (never of a level the caller gave).

    * :meth:`refine`: up to ``retries`` times, a level refuted by a confirmed witness (``V' >= 0``
      at 50 digits, in the equilibrium's component) or by a confirmed point outside the domain is
      chosen again below the value of V there, which bounds the true optimum;
    * :meth:`back_off`: for a system with a parameter box, an inconclusive level proposed at the
      box's sample points is tried at ``backoff`` factors of itself (at most ``retries`` of them),
      unless the domain or the cover made it inconclusive (neither depends on the level's place
      below the worst case).
    """

    retries: int = RETRIES
    backoff: tuple[float, ...] = BACKOFF

    def __post_init__(self) -> None:
        r = self.retries
        if isinstance(r, bool) or not isinstance(r, int) or not 0 <= r <= 10:
            raise RoaInputError(f"retries must be an integer in [0, 10], got {r!r}")

    def bound(self, system: System, V: Lyapunov, v: Validation) -> tuple[float, str, Any] | None:
        """``(value, why, proof)``: the upper bound of the optimum that ``v`` proves (a point
        outside the domain, or the lowest confirmed witness near its witness, ``proof`` then
        the witness when it bounds), or None."""
        outside = v.meta.get("domain_level") if v.status is Verdict.REFUTED else None
        if outside is not None:  # the set leaves the domain at V = outside (50 digits)
            return float(outside), "a point outside the domain", None
        confirmed = (v.witness_check or {}).get("confirmed")
        if v.status is not Verdict.REFUTED or v.witness is None or not confirmed:
            return None
        from roa.search._witness import lowest_confirmed_witness

        wp = v.witness_parameters
        at = system.at(**wp) if wp else system
        bound, x, check = lowest_confirmed_witness(at, V, np.asarray(v.witness, dtype=float))
        if not bound > 0 or x is None:  # only a point proved in the component bounds c*
            return None
        return bound, "V' >= 0", (x, check, bound, wp)

    def refine(self, run: Run, a: Attempt, rounds: int, level_for: Callable[[float], float],
               factor: float) -> None:  # fmt: skip
        """Choose the level again below each confirmed bound, ``rounds`` times at most."""
        for _ in range(rounds):
            found = self.bound(run.system, run.V, a.v)
            if found is None:
                break
            bound, why, proof = found
            if proof is not None and bound <= a.opt:
                a.proof = proof  # refutes every level >= V(x)
            a.opt = min(a.opt, bound)
            new = (
                min(level_for(a.opt), factor * a.opt) if run.choose is not None else factor * a.opt
            )
            if not 0 < new < a.value:
                break
            a.notes.append(f"refuted at {a.value:.7g} ({why} at V = {bound:.10g}, 50 digits)")
            run.trace.append({"stage": "refine", "witness_level": bound, "next_level": new})
            a.value = new
            a.v = run.validate(a.value, "validate below the witness")

    def back_off(self, run: Run, a: Attempt) -> None:
        """Lower levels after an inconclusive validation of a level proposed at a parameter
        box's sample points (class doc)."""
        if not run.system.parameters or a.v.status is not Verdict.INCONCLUSIVE:
            return
        for factor in self.backoff[: max(self.retries, 0)]:
            if a.v.reason in (Reason.DOMAIN, Reason.NO_COVER):
                break  # neither depends on where the level is below the worst case
            new = factor * a.value
            a.backoff.append(f"inconclusive at {a.value:.7g}, backed off to {new:.7g}")
            run.trace.append({"stage": "back off", "from": a.value, "next_level": new})
            a.value = new
            a.v = run.validate(a.value, "validate below (back off)")
            if a.v.status is not Verdict.INCONCLUSIVE:
                break


@dataclass(frozen=True)
class WitnessRefuter:
    """Refutes a level ``top`` above the optimum: by a confirmed witness below it (a retry's,
    or the proposal's own search witness for a freshly found V or a parameter box, proved again
    at 50 digits in the equilibrium's component), else by the validator's refuter
    (:meth:`Validator.refuter <roa.certification.Validator.refuter>`, with a cover
    from rays for a freshly found V), with the level search's witness
    (:func:`witness_by_search`) where the branch and bound cannot decide: first above the
    dimension it covers, else after an inconclusive validation."""

    def refute(self, run: Run, top: float, proof: Proof | None, prop: Proposal) -> Validation:
        from roa.proof._witness import WITNESS_SLACK, refuted_by
        from roa.search._witness import lowest_confirmed_witness

        system, V, trace = run.system, run.V, run.trace
        own = run.fresh or bool(system.parameters)
        if own and proof is None and prop.search is not None and prop.search.witness is not None:
            w = np.asarray(prop.search.witness, dtype=float)
            wp = prop.parameters if system.parameters else None
            val, x, check = lowest_confirmed_witness(system.at(**wp) if wp else system, V, w)
            if x is not None and val * WITNESS_SLACK <= top:
                proof = (x, check, val, wp)
        if proof is not None and proof[2] * WITNESS_SLACK <= top:
            how = f"local minimum of V on {{V' >= 0}}, V = {proof[2]:.10g}"
            trace.append({"stage": "refute above", "by": "witness", "level": top})
            return refuted_by(proof[0], proof[1], top, how, parameters=proof[3])
        validator = run.validator.refuter()
        if run.fresh:
            from roa.search._rays import ray_box

            validator = validator.with_cover(lambda: ray_box(V, top))
        search_ok = searchable(system)
        v = None
        if not (search_ok and V.n > validator.max_bnb_dim):
            with step(f"refutation check of {V.name} at level {top:.6g}"):
                v = _validate(system, V, validator, top, trace, "refute above")
            if v.status is not Verdict.INCONCLUSIVE or not search_ok:
                return v
        found, note = witness_by_search(system, V, top, trace)
        if found is not None:
            return found
        validator = validator.without_witness_search()  # the search just ran: not again
        if v is None:
            with step(f"refutation check of {V.name} at level {top:.6g}"):
                v = _validate(system, V, validator, top, trace, "refute above")
        if note and v.status is Verdict.INCONCLUSIVE:
            v = dataclasses.replace(v, message=f"{v.message}; {note}")
        return v


# -- the one adapter: certify's arguments as objects ------------------------------------------------
@dataclass(frozen=True)
class Plan:
    """What :func:`certify` runs, as objects: ``V`` with its level ``proposers``, or a ``source``
    of ``(V, proposer)`` pairs seeded by ``seed`` (``proposer`` the level of a candidate that
    brings none); the ``validator``, the retry ``policy``, the ``refuter`` and ``check_above``."""

    validator: Validator
    policy: RetryPolicy = field(default_factory=RetryPolicy)
    V: Lyapunov | None = None
    proposers: tuple[ProposerBase, ...] = ()
    source: VSource | None = None
    seed: QuadraticLyapunov | None = None
    proposer: LevelProposer | None = None
    check_above: float | None = None
    refuter: WitnessRefuter = field(default_factory=WitnessRefuter)

    def run(self, system: System, t0: float | None = None) -> Certificate:
        t0 = time.perf_counter() if t0 is None else t0
        if self.source is not None:
            assert self.seed is not None and self.proposer is not None
            return from_source(system, self.seed, self.source, self.proposer, self.validator,
                               self.check_above, self.policy, t0, self.refuter)  # fmt: skip
        assert self.V is not None
        return run(system, self.V, self.proposers, self.validator, check_above=self.check_above,
                   retries=self.policy, t0=t0, refuter=self.refuter)  # fmt: skip


def certify(
    system: System,
    V: Any = None,
    *,
    level: float | LevelProposer | None = None,
    method: str = "both",
    sos: SosOptions | None = None,
    interval: IntervalOptions | None = None,
    sampled: SampledOptions | None = None,
    candidate: LevelSearchResult | float | None = None,
    check_above: float | None = None,
    bounding_box: Any = None,
    degree: int | None = None,
    vs: VsOptions | None = None,
    validator: Validator | str | None = None,
    retries: int | RetryPolicy = RETRIES,
) -> Certificate:
    """Certify (or refute) that ``{V <= level}`` lies in the region of attraction.

    Parameters
    ----------
    system : System
        Autonomous system with an equilibrium; its field must run on the interval namespace.
    V : Lyapunov, n x n matrix or source of V, optional
        The candidate (default :func:`roa.default_lyapunov`): any :class:`roa.lyapunov.Lyapunov`
        or a matrix ``P``; or a source of candidates (:class:`roa.VsIteration`,
        :class:`roa.CuttingPlanes`) seeded by the system's quadratic V.
    level : float or level proposer, optional
        A level (> 0) to validate as it is, or a proposer object (:class:`roa.SosLevel`,
        :class:`roa.SampledLevel`, :class:`roa.CandidateLevel`, :class:`roa.GivenLevel`).
        Default: SOS for a quadratic V, else (or when SOS fails) the sampled level search.
    method : {"both", "sos", "interval"}
        Shorthand for the proposers when ``level`` is not given: ``both`` (SOS, then the sampled
        search), ``interval`` (the sampled search) or ``sos`` (the SOS level only: never
        certified).
    sos, interval, sampled : SosOptions, IntervalOptions, SampledOptions, optional
        Options of the SOS proposer, of the validator and of the sampled proposer.
    candidate : LevelSearchResult or float, optional
        A largest level found elsewhere, validated at ``interval.sampled_safety`` x it.
    check_above : float, optional
        Also refute ``check_above`` x the optimum (> 1, e.g. 1.001); its verdict is ``.above``.
    bounding_box : array, optional
        A box holding the level set, any ``V`` (see :func:`roa.proof.validate_level`).
    degree : {2, 4, 6, 8}, optional
        Shorthand for ``V=roa.VsIteration(degree, vs)`` (``vs.method="sampled"``:
        ``roa.CuttingPlanes``), seeded by ``V`` (quadratic).
    vs : VsOptions, optional
        Options of the search of V.
    validator : Validator or {"interval", "sos", "auto"}, optional
        What decides a level: a validator object, or ``"auto"`` (the default, as on the command
        line: :class:`roa.AutoValidator`, the branch and bound up to 4 states and parameters,
        the exact SOS certificate above, each backing up the other), ``"interval"``
        (:class:`roa.IntervalValidator`, the branch and bound only) or ``"sos"``
        (:class:`roa.SosValidator`).
    retries : int or RetryPolicy
        Times a proposed level is chosen again below a confirmed refutation witness (0 to 10),
        or the policy itself (:class:`RetryPolicy`).

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
    return plan(system, V, level=level, method=method, sos=sos, interval=interval,
                sampled=sampled, candidate=candidate, check_above=check_above,
                bounding_box=bounding_box, degree=degree, vs=vs, validator=validator,
                retries=retries).run(system, t0)  # fmt: skip


def plan(
    system: System,
    V: Any = None,
    *,
    level: Any = None,
    method: str = "both",
    sos: SosOptions | None = None,
    interval: IntervalOptions | None = None,
    sampled: SampledOptions | None = None,
    candidate: Any = None,
    check_above: float | None = None,
    bounding_box: Any = None,
    degree: int | None = None,
    vs: VsOptions | None = None,
    validator: Any = None,
    retries: int | RetryPolicy = RETRIES,
) -> Plan:
    """The objects of :func:`certify`'s arguments (the one place that reads mode and validator
    names, numbers and shorthands), every argument checked before any program is built."""
    policy = retries if isinstance(retries, RetryPolicy) else RetryPolicy(retries)
    if check_above is not None and not (np.isfinite(check_above) and check_above > 1):
        raise RoaInputError(f"check_above must be a finite number > 1, got {check_above!r}")
    interval = IntervalOptions() if interval is None else interval
    if validator is not None and not isinstance(validator, str) and bounding_box is not None:
        raise RoaInputError("bounding_box belongs to the validator: give one or the other")
    check = validator_named(validator, interval, bounding_box)
    source: VSource | None = None
    if degree is not None:
        if level is not None or candidate is not None or method != "both":
            raise RoaInputError("degree= searches V and its level: drop level, candidate, method")
        source = source_of_degree(degree, vs)
    elif isinstance(V, VSource):  # a source of V given as V, seeded by its own seed
        source, V = V, V.seed
    _check_system(system)
    if method == "sos" and level is None and system.time != "continuous":
        raise RoaInputError(
            f"system {system.name!r} is discrete-time: method='sos' (the SOS level search) is "
            "for continuous-time systems; use method='interval' (the sampled search), or "
            "validator='sos' to prove a level of a polynomial map with an exact SOS certificate"
        )
    if source is not None and system.time != "continuous":
        raise RoaInputError(
            f"system {system.name!r} is discrete-time: the search of V (degree=, VsIteration, "
            "CuttingPlanes) is for continuous-time systems; give V (default: A'PA - P = -I)"
        )
    if source is not None:
        seed = quadratic_seed(system, V, "the search of V starts from a quadratic seed; V")
        return Plan(check, policy, source=source, seed=seed, check_above=check_above,
                    proposer=SampledLevel(sampled, interval.sampled_safety))  # fmt: skip
    lyap = as_lyapunov(system, V)
    if isinstance(level, int | float) and not isinstance(level, bool):
        representable_level(system, lyap, positive_level(level))
        if check_above is not None:
            representable_level(system, lyap, check_above * level, what="check_above x level")
    proposers = proposers_of(lyap, level, method, candidate, sos, interval, sampled)
    return Plan(check, policy, V=lyap, proposers=tuple(proposers), check_above=check_above)


def validator_named(validator: Any, interval: IntervalOptions, bounding_box: Any) -> Validator:
    """The validator object of ``certify``'s ``validator`` argument (an object or a name of
    :data:`VALIDATORS`)."""
    if validator == "interval":
        return IntervalValidator(interval, bounding_box)
    if validator is None or validator == "auto":
        return AutoValidator(interval, bounding_box)
    if validator == "sos":
        if bounding_box is not None:
            raise RoaInputError("bounding_box belongs to the branch and bound, not to 'sos'")
        return SosValidator()
    if isinstance(validator, str):
        raise RoaInputError(f"validator must be one of {VALIDATORS} or a validator object, "
                            f"got {validator!r}")  # fmt: skip
    return as_validator(validator)


def source_of_degree(degree: Any, vs: VsOptions | None) -> VSource:
    """The source of V of ``certify``'s ``degree=`` shorthand: :class:`VsIteration`, or
    :class:`CuttingPlanes` for ``vs.method="sampled"``."""
    if degree not in DEGREES:
        raise RoaInputError(f"degree must be one of {DEGREES}, got {degree!r}")
    vs = VsOptions() if vs is None else vs
    if vs.method == "sampled":
        from roa.options import SampleSearchOptions

        o = (SampleSearchOptions() if vs.sampled is None else vs.sampled).replace(degree=degree)
        return CuttingPlanes(o)
    return VsIteration(degree, vs)


def _check_system(system: System) -> None:
    if system.equilibrium is None or system.time_varying:
        raise RoaInputError(f"system {system.name!r} must be autonomous with an equilibrium")
    check_system(system, analysis=True)


def proposers_of(
    lyap: Lyapunov,
    level: Any,
    method: str,
    candidate: Any,
    sos: SosOptions | None,
    interval: IntervalOptions,
    sampled: SampledOptions | None,
) -> list[ProposerBase]:
    """The level proposers of ``certify``'s shorthand arguments (``level``, ``candidate`` and
    the ``method`` of :data:`METHODS`), in the order they are tried."""
    if method not in METHODS:
        raise RoaInputError(f"method must be one of {METHODS}, got {method!r}")
    if level is not None and not isinstance(level, int | float):
        if candidate is not None:
            raise RoaInputError("give either level or candidate, not both")
        if not isinstance(level, LevelProposer):
            raise RoaInputError(
                f"level must be a number > 0 or a level proposer, got {type(level).__name__}"
            )
        return [as_proposer(level)]
    if level is not None:
        if method == "sos":
            raise RoaInputError(
                "method='sos' with a given level: a given level is checked by the validator "
                "only; use method='interval', or drop level to let SOS find one"
            )
        if candidate is not None:
            raise RoaInputError("give either level or candidate, not both")
        return [GivenLevel(level)]
    if candidate is not None:
        return [CandidateLevel(candidate, interval.sampled_safety)]
    sos = SosOptions() if sos is None else sos
    if method == "sos":
        if not lyap.is_quadratic:
            raise RoaInputError(
                f"method='sos' needs a QuadraticLyapunov; V {lyap.name!r} is "
                f"{type(lyap).__name__}: use method='both' or 'interval' (sampled search, then "
                "the validator)"
            )
        return [SosLevel(sos, only=True)]
    sampled_level = SampledLevel(sampled, interval.sampled_safety)
    return [SosLevel(sos), sampled_level] if method == "both" else [sampled_level]


# -- the run: propose, prove, refine, refute above ---------------------------------------------------
@dataclass
class Run:
    """One run of the pipeline on ``V``: what every step reads, and the ``trace`` it writes."""

    system: System
    V: Lyapunov
    validator: Validator
    policy: RetryPolicy
    refuter: WitnessRefuter
    t0: float
    choose: Callable[[float], float] | None = None
    fresh: bool = False
    trace: list[dict[str, Any]] = field(default_factory=list)

    def validate(self, level: float, stage: str) -> Validation:
        return _validate(self.system, self.V, self.validator, level, self.trace, stage)

    def done(self, **kw: Any) -> Certificate:
        return Certificate(seconds=time.perf_counter() - self.t0, system=self.system, V=self.V,
                           trace=tuple(self.trace), **kw)  # fmt: skip


def run(
    system: System,
    V: Lyapunov,
    proposers: Sequence[LevelProposer],
    validator: Validator,
    *,
    check_above: float | None = None,
    retries: int | RetryPolicy = RETRIES,
    t0: float | None = None,
    choose: Any = None,
    fresh: bool = False,
    refuter: WitnessRefuter | None = None,
) -> Certificate:
    """Propose a level for ``V``, prove it, refine below a witness, refute above.

    ``choose(opt)`` is the level validated for an optimum ``opt`` (default: the proposal's factor
    x ``opt``); ``fresh``: V was just found by a search (its level search's witness may refute
    the level above, whose cover is then taken from rays); ``retries``: the number of
    refinements or the :class:`RetryPolicy`; ``refuter``: default :class:`WitnessRefuter`.
    """
    policy = retries if isinstance(retries, RetryPolicy) else RetryPolicy(retries)
    r = Run(system, V, as_validator(validator), policy, refuter or WitnessRefuter(),
            time.perf_counter() if t0 is None else t0, choose, fresh)  # fmt: skip
    if not r.validator.accepts(system, V):
        raise RoaInputError(f"validator {r.validator.name!r} does not accept V {V.name!r}")
    chain = [as_proposer(p) for p in proposers]
    local = _not_locally_negative(system, V)
    if local is not None and not any(p.given for p in chain):
        r.trace.append({"stage": "linearisation", "parameters": local[0], "max_eig": local[1]})
        return r.done(status=Verdict.INCONCLUSIVE, level=None, method="linearisation",
                      level_source=None, message=local[2])  # fmt: skip
    if system.parameters:  # levels proposed at the box's sample points, the lowest first
        chain = [p.over_box() for p in chain]
    prop, sos_res, skipped = _propose(system, V, chain, r.trace)
    if prop.final:
        return r.done(status=Verdict.INCONCLUSIVE, level=prop.candidate, method="sos",
                      level_source="sos" if prop.candidate is not None else None,
                      message=prop.message, sos=prop.sos, candidate=prop.candidate)  # fmt: skip
    if prop.level is None:
        return r.done(status=Verdict.INCONCLUSIVE, level=None, method="level search",
                      level_source=None, message=prop.message, sos=sos_res,
                      search=prop.search)  # fmt: skip
    assert prop.candidate is not None
    given = prop.source == "given"
    a, backed_off = _first_validation(r, prop, given)
    factor = 1.0 if prop.factor is None else prop.factor

    def level_for(o: float) -> float:
        return float(choose(o)) if choose is not None else factor * o

    policy.refine(r, a, 0 if given and not fresh else policy.retries, level_for, factor)
    if not given:
        policy.back_off(r, a)
    above = _above(r, a, prop, check_above)
    message = _message(r, a, prop, skipped and not given, local)
    if given and not fresh:
        return r.done(status=a.v.status, level=a.value, method=_method(r, a), level_source="given",
                      message=message, validation=a.v, above=above, candidate=a.value)  # fmt: skip
    source = "backoff" if a.backoff or backed_off else "witness" if a.notes else prop.source
    return r.done(status=a.v.status, level=a.value, method=_method(r, a), level_source=source,
                  message=message, candidate=a.opt,
                  safety_factor=None if choose is not None else factor, validation=a.v,
                  above=above, sos=sos_res, search=prop.search)  # fmt: skip


def _method(r: Run, a: Attempt) -> str:
    """The route that decided: the validation's own ``method``, else the validator's name."""
    return str(a.v.meta.get("method", r.validator.name))


def _first_validation(r: Run, prop: Proposal, given: bool) -> tuple[Attempt, bool]:
    """The proposal's level validated: by the exact SOS route and its back-off where the
    validator tries it first (:func:`roa.certification._backoff.exact_first`, never for a given
    level), else by the validator; and whether the exact back-off moved the level."""
    from roa.certification._backoff import exact_first

    assert prop.candidate is not None and prop.level is not None
    opt = prop.candidate
    value = prop.level if given or r.choose is None else float(r.choose(opt))
    first = None if given else exact_first(r.system, r.V, r.validator, value, r.trace)
    if first is not None:  # the exact SOS route and its back-off decided (before any B&B)
        return Attempt(first[0], first[1], opt), first[1] != value
    return Attempt(r.validate(value, "validate"), value, opt), False


def _above(r: Run, a: Attempt, prop: Proposal, check_above: float | None) -> Validation | None:
    """``check_above`` x the optimum refuted (:class:`WitnessRefuter`), or None without it."""
    if check_above is None:
        return None
    top = check_above * a.opt
    try:
        representable_level(r.system, r.V, top, what="check_above x the optimum")
    except RoaInputError as exc:  # refused before any program: no verdict above
        return Validation(Verdict.INCONCLUSIVE, top, 0, 0.0, message=str(exc))
    return r.refuter.refute(r, top, a.proof, prop)


def _message(r: Run, a: Attempt, prop: Proposal, skipped: bool,
             local: tuple[dict[str, float], float, str] | None) -> str:  # fmt: skip
    """The certificate's message: the validation's, then the refinement's and the back-off's
    notes, why SOS did not propose (``skipped``), the linearisation's refusal of a given level."""
    message = a.v.message
    if a.notes:
        message = (f"{message}; retried below confirmed witnesses (sampled optimum "
                   f"{prop.candidate:.7g}): " + "; ".join(a.notes))  # fmt: skip
    if a.backoff:
        message = (f"{message}; the proposal is the worst of the parameter box's sample points, "
                   "not a bound between them: " + "; ".join(a.backoff))  # fmt: skip
    if skipped:
        why = (
            "to continuous-time systems only (this one is a map)"
            if r.system.time == "discrete"
            else f"to quadratic V only ({type(r.V).__name__})"
        )
        message = (f"SOS applies {why}: level from the sampled search, checked by the "
                   f"validator. {message}")  # fmt: skip
    if local is not None:  # a given level: the validator's verdict, and why
        message = f"{local[2]}. {message}"
    return message


def _not_locally_negative(
    system: System, V: Lyapunov
) -> tuple[dict[str, float], float, str] | None:
    """For a parameter box: the first sample point where V' is not negative definite at the
    equilibrium (:func:`roa.search._candidate.worst_linearisation`), its eigenvalue and a message
    saying so (as ``roa khalil`` does); None when there is none or no box. At such a point no
    level > 0 holds for this V (V' >= 0 arbitrarily close to the equilibrium, or, for a zero
    eigenvalue, nothing from the linearisation)."""
    from roa.model._parameters import describe_point
    from roa.search._candidate import worst_linearisation

    if not system.parameters:
        return None
    worst = worst_linearisation(system, V)
    if worst is None:
        return None
    p, lam = worst
    message = (
        f"V' is not negative definite at the equilibrium for {describe_point(p)} (largest "
        f"eigenvalue of A'P + PA = {lam:.4g} >= 0 for the linearisation there): no level > 0 "
        f"for this V over the box ({ParameterBox.of(system).describe()}); a V designed for the "
        "box: omit V (the default then solves common Lyapunov LMIs at the box's points)"
    )
    return p, lam, message


def _propose(
    system: System, V: Lyapunov, proposers: Sequence[ProposerBase], trace: list[dict[str, Any]]
) -> tuple[Proposal, Any, bool]:
    """The first proposal with a level (or the last one), the SOS result met on the way, and
    whether a proposer declined V before a fallback search proposed."""
    prop: Proposal | None = None
    sos_res, skipped = None, False
    for proposer in proposers:
        if not proposer.accepts(system, V):
            skipped = True
            trace.append({"stage": "propose", "by": proposer.label, "accepted": False})
            continue
        prop = proposer.propose(system, V)
        trace.append({"stage": "propose", "by": proposer.label, "source": prop.source,
                      "candidate": prop.candidate, "level": prop.level})  # fmt: skip
        sos_res = prop.sos if prop.sos is not None else sos_res
        if prop.level is not None or prop.final:
            return prop, sos_res, skipped and proposer.fallback
    if prop is None:
        raise RoaInputError(f"no level proposer accepts V {V.name!r}")
    return prop, sos_res, False


def _validate(system: System, V: Lyapunov, validator: Validator, level: float,
              trace: list[dict[str, Any]], stage: str) -> Validation:  # fmt: skip
    v = validator.check(system, V, level)
    trace.append({"stage": stage, "by": validator.name, "level": level, "status": v.status.value,
                  "boxes": v.boxes, "seconds": round(v.seconds, 3)})  # fmt: skip
    return v


def from_source(
    system: System,
    seed: QuadraticLyapunov,
    source: VSource,
    proposer: LevelProposer,
    validator: Validator,
    check_above: float | None,
    policy: RetryPolicy,
    t0: float,
    refuter: WitnessRefuter | None = None,
) -> Certificate:
    """Certify the ``(V, proposer)`` pairs of a source of V, in its order, until one is
    certified or ``validate`` of them were validated (a candidate without a level costs no
    proof); ``proposer`` proposes for a candidate that brings none."""
    found: Candidates = source.search(system, seed, proposer)
    if not found.pairs:
        return Certificate(status=Verdict.INCONCLUSIVE, level=None, method=found.method,
                           level_source=None, seconds=time.perf_counter() - t0,
                           message=found.message, vs=found.result, search=found.search,
                           system=system, V=seed if found.V is None else found.V)  # fmt: skip
    last, tried = None, 0
    for cand in found.pairs:
        with step(cand.label) if cand.label else _quiet():
            cert = run(system, cand.V, [cand.proposer], validator, check_above=check_above,
                       retries=policy, t0=t0, choose=cand.choose, fresh=cand.fresh,
                       refuter=refuter)  # fmt: skip
        if cert.validation is None and last is not None:
            continue  # a candidate without a sampled level costs no proof
        extra: dict[str, Any] = {}
        if cand.search is not None:
            extra["search"] = cand.search
        if cand.level_source is not None and cert.level_source != "witness":
            extra["level_source"] = cand.level_source
        last = dataclasses.replace(cert, vs=found.result, seconds=time.perf_counter() - t0,
                                   **extra)  # fmt: skip
        tried += cert.validation is not None
        if cert.certified or tried >= found.validate:
            return last
    assert last is not None
    return last


def _quiet() -> Any:
    import contextlib

    return contextlib.nullcontext()


#: The geometric grid of ray parameters on which :func:`representable_level` finds the level
#: set along rays (up to 1e300: beyond, coordinates squared overflow).
_AXIS_T = np.geomspace(1e-150, 1e300, 1351)
#: Random directions (seeded) beside the axes in :func:`representable_level`.
_RAYS = 32


def representable_level(system: System, V: Lyapunov, level: float, what: str = "level") -> float:
    """``level``, or a :class:`RoaInputError` naming ``what`` when the level overflows double
    precision: not a finite number > 0, or, along rays from the equilibrium (the 2n coordinate
    axes and :data:`_RAYS` seeded random directions; a geometric grid of radii up to 1e300, then
    bisection), ``{V <= level}`` not left, or ``V`` or ``V'`` overflowing where it is left (a
    NaN, a field outside its natural domain, is not an overflow). Every program built for the level (the SOS program's
    data, the branch and bound's cover and enclosures, the level search) evaluates these
    numbers or larger ones, so it is refused before any is built."""
    if not (np.isfinite(level) and level > 0):
        raise RoaInputError(f"{what} must be a finite number > 0, got {level!r}")
    rays = np.random.default_rng(0).standard_normal((_RAYS, V.n))
    U = np.concatenate([np.eye(V.n), -np.eye(V.n), rays / np.linalg.norm(rays, axis=1)[:, None]])
    c = np.asarray(V.center, dtype=float)
    with np.errstate(all="ignore"):
        inside = V.value(c + _AXIS_T[None, :, None] * U[:, None, :]) <= level
        left = ~inside.all(axis=1)
        x = None
        if left.all():
            k = np.argmax(~inside, axis=1)
            lo = np.where(k > 0, _AXIS_T[np.maximum(k - 1, 0)], 0.0)
            hi = _AXIS_T[k]
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                out = ~(V.value(c + mid[:, None] * U) <= level)
                lo, hi = np.where(out, lo, mid), np.where(out, mid, hi)
            x = c + hi[:, None] * U
    overflow = x is None
    if x is not None:
        # overflow only: a NaN of a field outside its natural domain (sqrt, log) is not one
        with np.errstate(over="raise", invalid="ignore", divide="ignore", under="ignore"):
            try:
                vals = np.concatenate([V.value(x), V.derivative(system, x)])
                overflow = bool(np.any(np.isinf(vals)))
            except (FloatingPointError, OverflowError):
                overflow = True
    if overflow:
        reach = "is not left along a ray up to 1e300" if x is None else (
            "overflows in V or V' where it is left along a ray, "
            f"|x - x_eq| up to {float(np.max(np.abs(x - c))):.3g}")  # fmt: skip
        raise RoaInputError(f"{what} {level:.6g} overflows double precision: "
                            f"{{V <= {level:.6g}}} {reach}; give a smaller {what}")  # fmt: skip
    return float(level)


def quadratic_seed(system: System, V: Any, what: str) -> QuadraticLyapunov:
    """``V`` as a quadratic Lyapunov function of ``system``, or an error starting with ``what``."""
    given = as_lyapunov(system, V)
    seed = given.quadratic_view()
    if seed is None:
        raise RoaInputError(
            f"{what} {given.name!r} is {type(given).__name__}: give a matrix P or a "
            "QuadraticLyapunov (or none)"
        )
    return seed
