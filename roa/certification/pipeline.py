"""``roa.certify``: a pipeline of strategies, "find V, propose a level, prove it, refute above".

The stages, each an object of :mod:`roa.certification.strategies`:

1. **V**: the caller's candidate (default :func:`roa.default_lyapunov`), or candidates from a
   source of V (:class:`~roa.certification.strategies.VsIteration`,
   :class:`~roa.certification.strategies.CuttingPlanes`) seeded by a quadratic V.
2. **Level**: the first proposer that accepts V and finds a level (default: SOS for a quadratic V,
   else the sampled level search); each proposer owns its safety factor.
3. **Proof**: the validator (the interval branch and bound) decides the level. It alone can
   certify.
4. **Refinement**: a proposed level refuted by a confirmed witness (V' >= 0 at 50 digits, in the
   equilibrium's component) is chosen again below ``V(witness)``, which bounds the true optimum
   (``retries`` times at most; a level the caller gave is never changed).
5. **Refutation above**: with ``check_above``, ``check_above`` x the optimum is refuted, by a
   confirmed witness below it when there is one, else by the validator.

Every stage leaves an entry in ``Certificate.trace``.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from roa.certification.result import Certificate
from roa.certification.strategies import (
    DEGREES,
    AutoValidator,
    CandidateLevel,
    CuttingPlanes,
    GivenLevel,
    IntervalValidator,
    LevelProposer,
    Proposal,
    SampledLevel,
    SosLevel,
    SosValidator,
    Validator,
    VsIteration,
    WorstCase,
)
from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov, QuadraticLyapunov
from roa.model.checks import check_system
from roa.model.parameters import ParameterBox
from roa.model.system import System
from roa.options import BNB_DIM, IntervalOptions, SampledOptions, SosOptions, VsOptions
from roa.progress import step
from roa.proof.validation import Validation
from roa.search.candidate import as_lyapunov
from roa.search.levelset import LevelSearchResult, level_search
from roa.status import Verdict

METHODS = ("sos", "interval", "both")
#: Times a proposed level is chosen again below a confirmed witness.
RETRIES = 3
#: Factors of the levels tried after an inconclusive validation of a level proposed at sample
#: points of a parameter box (the worst case may lie between them).
BACKOFF = (0.98, 0.95, 0.9)


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
    retries: int = RETRIES,
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
        A box holding the level set, any ``V`` (see :func:`roa.proof.validate.validate_level`).
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
    retries : int
        Times a proposed level is chosen again below a confirmed refutation witness (0 to 10).

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
    if isinstance(retries, bool) or not isinstance(retries, int) or not 0 <= retries <= 10:
        raise RoaInputError(f"retries must be an integer in [0, 10], got {retries!r}")
    if check_above is not None and not (np.isfinite(check_above) and check_above > 1):
        raise RoaInputError(f"check_above must be a finite number > 1, got {check_above!r}")
    interval = IntervalOptions() if interval is None else interval
    if validator is not None and not isinstance(validator, str) and bounding_box is not None:
        raise RoaInputError("bounding_box belongs to the validator: give one or the other")
    check = _validator(validator, interval, bounding_box)
    source: VsIteration | CuttingPlanes | None = None
    if degree is not None:
        if level is not None or candidate is not None or method != "both":
            raise RoaInputError("degree= searches V and its level: drop level, candidate, method")
        if degree not in DEGREES:
            raise RoaInputError(f"degree must be one of {DEGREES}, got {degree!r}")
        vs = VsOptions() if vs is None else vs
        if vs.method == "sampled":
            from roa.options import SampleSearchOptions

            o = (SampleSearchOptions() if vs.sampled is None else vs.sampled).replace(degree=degree)
            source = CuttingPlanes(o)
        else:
            source = VsIteration(degree, vs)
    elif isinstance(V, VsIteration | CuttingPlanes):
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
        return _from_source(system, seed, source, check, sampled, interval, check_above,
                            retries, t0)  # fmt: skip
    lyap = as_lyapunov(system, V)
    if isinstance(level, int | float) and not isinstance(level, bool):
        representable_level(system, lyap, _positive_level(level))
        if check_above is not None:
            representable_level(system, lyap, check_above * level, what="check_above x level")
    proposers = _proposers(lyap, level, method, candidate, sos, interval, sampled)
    return run(system, lyap, proposers, check, check_above=check_above, retries=retries,
               t0=t0)  # fmt: skip


VALIDATORS = ("interval", "sos", "auto")


def _validator(validator: Any, interval: IntervalOptions, bounding_box: Any) -> Validator:
    """The validator object of ``certify``'s ``validator`` argument (an object or a name)."""
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
    return validator


def _check_system(system: System) -> None:
    if system.equilibrium is None or system.time_varying:
        raise RoaInputError(f"system {system.name!r} must be autonomous with an equilibrium")
    check_system(system, analysis=True)


def _proposers(
    lyap: Lyapunov,
    level: Any,
    method: str,
    candidate: Any,
    sos: SosOptions | None,
    interval: IntervalOptions,
    sampled: SampledOptions | None,
) -> list[LevelProposer]:
    """The level proposers of the shorthand arguments, in the order they are tried."""
    if method not in METHODS:
        raise RoaInputError(f"method must be one of {METHODS}, got {method!r}")
    if level is not None and not isinstance(level, int | float):
        if candidate is not None:
            raise RoaInputError("give either level or candidate, not both")
        if not isinstance(level, LevelProposer):
            raise RoaInputError(
                f"level must be a number > 0 or a level proposer, got {type(level).__name__}"
            )
        return [level]
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
        if lyap.as_quadratic() is None:
            raise RoaInputError(
                f"method='sos' needs a QuadraticLyapunov; V {lyap.name!r} is "
                f"{type(lyap).__name__}: use method='both' or 'interval' (sampled search, then "
                "the validator)"
            )
        return [SosLevel(sos, only=True)]
    sampled_level = SampledLevel(sampled, interval.sampled_safety)
    return [SosLevel(sos), sampled_level] if method == "both" else [sampled_level]


def run(
    system: System,
    V: Lyapunov,
    proposers: Sequence[LevelProposer],
    validator: Validator,
    *,
    check_above: float | None = None,
    retries: int = RETRIES,
    t0: float | None = None,
    choose: Any = None,
    fresh: bool = False,
) -> Certificate:
    """Propose a level for ``V``, prove it, refine below a witness, refute above.

    ``choose(opt)`` is the level validated for an optimum ``opt`` (default: the proposal's factor
    x ``opt``); ``fresh``: V was just found by a search (its level search's witness may refute
    the level above, whose cover is then taken from rays).
    """
    t0 = time.perf_counter() if t0 is None else t0
    trace: list[dict[str, Any]] = []
    if not validator.accepts(system, V):
        raise RoaInputError(f"validator {validator.name!r} does not accept V {V.name!r}")

    def done(**kw: Any) -> Certificate:
        return Certificate(seconds=time.perf_counter() - t0, system=system, V=V,
                           trace=tuple(trace), **kw)  # fmt: skip

    local = _not_locally_negative(system, V)
    if local is not None and not any(isinstance(p, GivenLevel) for p in proposers):
        trace.append({"stage": "linearisation", "parameters": local[0], "max_eig": local[1]})
        return done(status=Verdict.INCONCLUSIVE, level=None, method="linearisation",
                    level_source=None, message=local[2])  # fmt: skip
    if system.parameters:  # levels proposed at the box's sample points, the lowest first
        proposers = [p if isinstance(p, GivenLevel | CandidateLevel | WorstCase) else WorstCase(p)
                     for p in proposers]  # fmt: skip
    prop, sos_res, skipped = _propose(system, V, proposers, trace)
    if prop.final:
        return done(status=Verdict.INCONCLUSIVE, level=prop.candidate, method="sos",
                    level_source="sos" if prop.candidate is not None else None,
                    message=prop.message, sos=prop.sos, candidate=prop.candidate)  # fmt: skip
    if prop.level is None:
        return done(status=Verdict.INCONCLUSIVE, level=None, method="level search",
                    level_source=None, message=prop.message, sos=sos_res,
                    search=prop.search)  # fmt: skip
    assert prop.candidate is not None
    given = prop.source == "given"
    opt = prop.candidate
    factor = 1.0 if prop.factor is None else prop.factor

    def level_for(o: float) -> float:
        return float(choose(o)) if choose is not None else factor * o

    value = prop.level if given or choose is None else level_for(opt)
    from roa.certification.backoff import exact_first

    first = None if given else exact_first(system, V, validator, value, trace)
    backed_off = first is not None and first[1] != value
    if first is not None:  # the exact SOS route and its back-off decided (before any B&B)
        v, value = first
    else:
        v = _validate(system, V, validator, value, trace, "validate")
    notes: list[str] = []
    proof: tuple[Any, Any, float, Any] | None = None  # a confirmed witness below the optimum
    for _ in range(0 if given and not fresh else retries):
        w = v.witness
        confirmed = (v.witness_check or {}).get("confirmed")
        outside = v.meta.get("domain_level") if v.status is Verdict.REFUTED else None
        if outside is not None:  # the set leaves the domain at V = outside (50 digits)
            bound, why = float(outside), "a point outside the domain"
        else:
            if v.status is not Verdict.REFUTED or w is None or not confirmed:
                break
            from roa.proof.witness import lowest_confirmed_witness

            wp = v.witness_parameters
            at = system.at(**wp) if wp else system
            bound, x, check = lowest_confirmed_witness(at, V, np.asarray(w, dtype=float))
            if not bound > 0 or x is None:  # only a point proved in the component bounds c*
                break
            if bound <= opt:
                proof = (x, check, bound, wp)  # refutes every level >= V(x)
            why = "V' >= 0"
        opt = min(opt, bound)
        new = min(level_for(opt), factor * opt) if choose is not None else factor * opt
        if not 0 < new < value:
            break
        notes.append(f"refuted at {value:.7g} ({why} at V = {bound:.10g}, 50 digits)")
        trace.append({"stage": "refine", "witness_level": bound, "next_level": new})
        value = new
        v = _validate(system, V, validator, value, trace, "validate below the witness")
    backoff: list[str] = []
    if system.parameters and not given and v.status is Verdict.INCONCLUSIVE:
        # a level proposed at sample points of the box is no bound between them: back off
        for factor_back in BACKOFF[: max(retries, 0)]:
            if v.meta.get("precondition") == "domain" or "box cover" in v.message:
                break  # neither depends on where the level is below the worst case
            new = factor_back * value
            backoff.append(f"inconclusive at {value:.7g}, backed off to {new:.7g}")
            trace.append({"stage": "back off", "from": value, "next_level": new})
            value = new
            v = _validate(system, V, validator, value, trace, "validate below (back off)")
            if v.status is not Verdict.INCONCLUSIVE:
                break
    above = None
    if check_above is not None:
        try:
            representable_level(system, V, check_above * opt, what="check_above x the optimum")
        except RoaInputError as exc:  # refused before any program: no verdict above
            above = Validation(Verdict.INCONCLUSIVE, check_above * opt, 0, 0.0, message=str(exc))
        else:
            above = _refute_above(system, V, validator, check_above * opt, proof, prop, fresh,
                                  trace)  # fmt: skip
    message = v.message
    if notes:
        sampled_opt = prop.candidate
        message = (f"{message}; retried below confirmed witnesses (sampled optimum "
                   f"{sampled_opt:.7g}): " + "; ".join(notes))  # fmt: skip
    if backoff:
        message = (f"{message}; the proposal is the worst of the parameter box's sample points, "
                   "not a bound between them: " + "; ".join(backoff))  # fmt: skip
    if skipped and not given:
        why = (
            "to continuous-time systems only (this one is a map)"
            if system.time == "discrete"
            else f"to quadratic V only ({type(V).__name__})"
        )
        message = (f"SOS applies {why}: level from the sampled search, checked by the "
                   f"validator. {message}")  # fmt: skip
    if local is not None:  # a given level: the validator's verdict, and why
        message = f"{local[2]}. {message}"
    if given and not fresh:
        return done(status=v.status, level=value, method=v.meta.get("method", validator.name),
                    level_source="given", message=message, validation=v, above=above, candidate=value)  # fmt: skip
    source = "backoff" if backoff or backed_off else "witness" if notes else prop.source
    return done(status=v.status, level=value, method=v.meta.get("method", validator.name),
                level_source=source,
                message=message, candidate=opt,
                safety_factor=None if choose is not None else factor, validation=v,
                above=above, sos=sos_res, search=prop.search)  # fmt: skip


def _not_locally_negative(
    system: System, V: Lyapunov
) -> tuple[dict[str, float], float, str] | None:
    """For a parameter box: the first sample point where V' is not negative definite at the
    equilibrium (:func:`roa.search.candidate.worst_linearisation`), its eigenvalue and a message
    saying so (as ``roa khalil`` does); None when there is none or no box. At such a point no
    level > 0 holds for this V (V' >= 0 arbitrarily close to the equilibrium, or, for a zero
    eigenvalue, nothing from the linearisation)."""
    from roa.model.parameters import describe_point
    from roa.search.candidate import worst_linearisation

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
    system: System, V: Lyapunov, proposers: Sequence[LevelProposer], trace: list[dict[str, Any]]
) -> tuple[Proposal, Any, bool]:
    """The first proposal with a level (or the last one), the SOS result met on the way, and
    whether a proposer declined V."""
    prop: Proposal | None = None
    sos_res, skipped = None, False
    for proposer in proposers:
        if not proposer.accepts(system, V):
            skipped = True
            trace.append({"stage": "propose", "by": type(proposer).__name__, "accepted": False})
            continue
        prop = proposer.propose(system, V)
        trace.append({"stage": "propose", "by": type(proposer).__name__, "source": prop.source,
                      "candidate": prop.candidate, "level": prop.level})  # fmt: skip
        sos_res = prop.sos if prop.sos is not None else sos_res
        if prop.level is not None or prop.final:
            return prop, sos_res, skipped and isinstance(proposer, SampledLevel)
    if prop is None:
        raise RoaInputError(f"no level proposer accepts V {V.name!r}")
    return prop, sos_res, False


def _validate(system: System, V: Lyapunov, validator: Validator, level: float,
              trace: list[dict[str, Any]], stage: str) -> Validation:  # fmt: skip
    v = validator.check(system, V, level)
    trace.append({"stage": stage, "by": validator.name, "level": level, "status": v.status.value,
                  "boxes": v.boxes, "seconds": round(v.seconds, 3)})  # fmt: skip
    return v


def _refute_above(
    system: System,
    V: Lyapunov,
    validator: Validator,
    top: float,
    proof: tuple[Any, Any, float, Any] | None,
    prop: Proposal,
    fresh: bool,
    trace: list[dict[str, Any]],
) -> Validation:
    """``top`` refuted by a confirmed witness below it (a retry's, or for a freshly found V the
    level search's), else decided by the validator."""
    from roa.proof.witness import WITNESS_SLACK, lowest_confirmed_witness, refuted_by

    # the proposal's own witness (a freshly found V's search, or the worst sample point of a
    # parameter box), proved again here (50 digits, in the equilibrium's component)
    own = fresh or bool(system.parameters)
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
    if not getattr(validator, "refutes", True):  # an SOS check never refutes: the branch and
        validator = IntervalValidator()  # bound looks for a witness (checked at 50 digits)
    if fresh and isinstance(validator, IntervalValidator) and validator.bounding_box is None:
        from roa.proof.cover import ray_box

        half = ray_box(V, top)  # a cover from rays, proved by V > level on its faces
        validator = IntervalValidator(validator.options, None if half is None else 1.3 * half)
    # a witness of the level search refutes where the validator cannot: first above the
    # dimension the branch and bound covers (it would spend its whole budget before ending
    # inconclusive), else after an inconclusive validation; only where _searchable
    searchable = _searchable(system)
    v = None
    if not (searchable and V.n > getattr(validator, "max_bnb_dim", BNB_DIM)):
        with step(f"refutation check of {V.name} at level {top:.6g}"):
            v = _validate(system, V, validator, top, trace, "refute above")
        if v.status is not Verdict.INCONCLUSIVE or not searchable:
            return v
    found, note = witness_by_search(system, V, top, trace)
    if found is not None:
        return found
    if isinstance(validator, AutoValidator):  # the search just ran: not again inside it
        validator = dataclasses.replace(validator, witness_search=False)
    if v is None:
        with step(f"refutation check of {V.name} at level {top:.6g}"):
            v = _validate(system, V, validator, top, trace, "refute above")
    if note and v.status is Verdict.INCONCLUSIVE:
        v = dataclasses.replace(v, message=f"{v.message}; {note}")
    return v


def _searchable(system: System) -> bool:
    """Whether a witness of the level search may refute a level of ``system``: not for a
    parameter box, nor where the domain has a boundary (the witness's segment to the equilibrium
    is not checked to stay in the domain, and the branch and bound calls such levels
    inconclusive)."""
    return not system.parameters and system.margin is None


def witness_by_search(
    system: System, V: Lyapunov, top: float, trace: list[dict[str, Any]]
) -> tuple[Validation | None, str]:
    """``top`` refuted by a witness the validator could not find (the branch and bound in more
    dimensions than it covers, or an SOS check, which never refutes): Khalil's level search
    (CasADi) gives a point of ``{V' >= 0}``, from which :func:`lowest_confirmed_witness` finds a
    local minimum of V whose ``V' >= 0`` holds at 50 digits, in the equilibrium's component of
    its sublevel set; it refutes ``top`` when ``V(x) <= top``. Else ``(None, note)``, the note
    naming a confirmed witness above ``top`` (an upper bound of the largest level of V).
    ``(None, "")`` at once for a system that is not :func:`_searchable`."""
    from roa.proof.witness import WITNESS_SLACK, lowest_confirmed_witness, refuted_by

    if not _searchable(system):
        return None, ""
    try:
        with step(f"witness search for level {top:.6g} (CasADi level search)"):
            search = level_search(system, V, method="casadi")
        if search.witness is None:
            return None, ""
        w = np.asarray(search.witness, dtype=float)
        val, x, check = lowest_confirmed_witness(system, V, w)
    except (RoaInputError, RuntimeError, ValueError, ArithmeticError) as exc:
        trace.append({"stage": "refute above", "by": "level search", "error": str(exc)[:200]})
        return None, ""
    if x is None or check is None:
        return None, ""
    if not val * WITNESS_SLACK <= top:
        trace.append({"stage": "refute above", "by": "level search", "witness_value": val})
        return None, (f"a witness from the level search, V' >= 0 at 50 digits, lies at V = "
                      f"{val:.10g} ({val / top:.6g} x this level): no level at or above it can "
                      "be certified")  # fmt: skip
    trace.append({"stage": "refute above", "by": "witness (level search)", "level": top})
    how = f"local minimum of V on {{V' >= 0}} from the CasADi level search, V = {val:.10g}"
    return refuted_by(x, check, top, how), ""


def _from_source(
    system: System,
    seed: QuadraticLyapunov,
    source: VsIteration | CuttingPlanes,
    validator: Validator,
    sampled: SampledOptions | None,
    interval: IntervalOptions,
    check_above: float | None,
    retries: int,
    t0: float,
) -> Certificate:
    """Certify the candidates of a source of V (see :func:`certify`)."""
    res = source.search(system, seed)
    if isinstance(source, CuttingPlanes):
        return _cutting_planes(system, seed, source, res, validator, check_above, retries, t0)
    assert isinstance(source, VsIteration)
    if not res.candidates:
        return Certificate(status=Verdict.INCONCLUSIVE, level=None, method="sos",
                           level_source=None, seconds=time.perf_counter() - t0,
                           message=f"V-s iteration found no candidate: {res.message}", vs=res,
                           system=system, V=seed)  # fmt: skip
    last, tried = None, 0
    for i in np.argsort(res.betas)[::-1]:  # best shape level first
        cand = res.candidates[int(i)]
        with step(f"validation of {cand.name}"):
            cert = run(system, cand, [SampledLevel(sampled, interval.sampled_safety)], validator,
                       check_above=check_above, retries=retries)  # fmt: skip
        if cert.validation is None and last is not None:
            continue  # a candidate without a sampled level costs no proof
        last = dataclasses.replace(cert, vs=res, seconds=time.perf_counter() - t0)
        tried += cert.validation is not None
        if cert.certified or tried >= source.options.validate:
            return last
    assert last is not None
    return last


def _cutting_planes(
    system: System,
    seed: QuadraticLyapunov,
    source: CuttingPlanes,
    res: Any,
    validator: Validator,
    check_above: float | None,
    retries: int,
    t0: float,
) -> Certificate:
    """The candidate of the cutting-plane search, validated at its chosen level."""
    if res.V is None:
        return Certificate(status=Verdict.INCONCLUSIVE, level=None, method="sampled search",
                           level_source=None, seconds=time.perf_counter() - t0,
                           message=f"the sampled search found no candidate: {res.message}",
                           vs=res, system=system, V=seed)  # fmt: skip
    V = res.V
    with step("sampled level search of the candidate"):
        lv = level_search(system, V, shape="level", method="sampled")
    if lv.level is None:
        return Certificate(status=Verdict.INCONCLUSIVE, level=None, method="level search",
                           level_source=None, seconds=time.perf_counter() - t0,
                           message=f"no sampled level for the candidate: {lv.message}",
                           search=lv, vs=res, system=system, V=V)  # fmt: skip
    safety, chosen, found = source.options.level_safety, source.level, float(lv.level)
    if chosen is None:
        choose = lambda opt: min(1.0, safety * opt)  # noqa: E731 - 1: the search's target
    elif callable(chosen):
        choose = lambda opt: _positive_level(chosen(V, opt))  # noqa: E731
    else:
        fixed = _positive_level(chosen)
        choose = lambda opt: fixed if opt == found else safety * opt  # noqa: E731
    prop = CandidateLevel(lv, safety)
    cert = run(system, V, [prop], validator, check_above=check_above, retries=retries, t0=t0,
               choose=choose, fresh=True)  # fmt: skip
    source_name = cert.level_source
    if source_name != "witness":
        source_name = "given" if chosen is not None else "sampled"
    return dataclasses.replace(cert, vs=res, search=lv, level_source=source_name,
                               seconds=time.perf_counter() - t0)  # fmt: skip


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


def _positive_level(value: Any) -> float:
    if not (isinstance(value, int | float) and np.isfinite(value) and value > 0):
        raise RoaInputError(f"level must be a finite number > 0, got {value!r}")
    return float(value)


def quadratic_seed(system: System, V: Any, what: str) -> QuadraticLyapunov:
    """``V`` as a quadratic Lyapunov function of ``system``, or an error starting with ``what``."""
    given = as_lyapunov(system, V)
    seed = given.as_quadratic()
    if seed is None:
        raise RoaInputError(
            f"{what} {given.name!r} is {type(given).__name__}: give a matrix P or a "
            "QuadraticLyapunov (or none)"
        )
    return seed
