"""The strategies :func:`roa.certify` is built from: sources of V, level proposers, validators.

Each is a small object with ``accepts(system, V)`` and one action, as cvxpy's reductions are:

* **Validators** decide a level (:class:`Validator`): :class:`IntervalValidator`, the interval
  branch and bound of :func:`roa.proof._validate.validate_level`, and :class:`SosValidator`, an
  SOS certificate checked in exact rationals (polynomial fields and V, any dimension).
* **Level proposers** find a candidate level and own the safety factor it is validated at
  (:class:`LevelProposer`): :class:`GivenLevel`, :class:`CandidateLevel` (a level found
  elsewhere), :class:`SosLevel` (quadratic V), :class:`SampledLevel` (any V).
* **Sources of V** propose candidates (:class:`VSource`): :class:`VsIteration` (SOS V-s
  iteration), :class:`CuttingPlanes` (sampled cutting planes), each as :class:`Candidates`, pairs
  of a V and the proposer of its level; a given V is its own source.

Each declares what it can do as fields and methods (:class:`ValidatorBase`: ``refutes``,
``max_bnb_dim``, ``backoff``, ``exact_only``, ``exact_route``, ``refuter``, ``with_cover``;
:class:`ProposerBase`: ``given``, ``fallback``, ``over_box``), which the pipeline reads instead of
their classes. Proposers and sources prove nothing; only a validator's verdict reaches
``certified``.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol, cast, runtime_checkable

import numpy as np

from roa.certification._backoff import check_tries
from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.model._system import System
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
from roa.proof._preconditions import Preconditions, Route, check_preconditions
from roa.proof._putinar import check_level
from roa.proof._recast import Recast, level_scale
from roa.proof._reductions import IndependentBlocks, Rescale
from roa.proof._sos_stored import part_json
from roa.proof._validate import validate_level
from roa.proof._validation import Validation
from roa.search._levelset import LevelSearchResult, level_search
from roa.search._rays import ray_box
from roa.search._sos_program import ROUTES, default_eps, route_for
from roa.status import LevelStatus, SosStatus, Verdict


# -- validators ------------------------------------------------------------------------------------
@runtime_checkable
class Validator(Protocol):
    """Decides ``V' < 0`` on ``{V <= level}`` minus the equilibrium: certified, refuted (with a
    witness) or inconclusive; and declares what it can do, which the pipeline reads instead of
    its class:

    * ``refutes``: whether it looks for a witness (an SOS check never refutes);
    * ``max_bnb_dim``: the states plus uncertain parameters its branch and bound decides within
      its budget (above, a witness of the level search refutes first);
    * ``backoff``: lower levels its exact route tries when the exact check fails;
    * ``exact_only``: whether its exact route is all it has (no branch and bound behind it).

    :class:`ValidatorBase` gives every member a default; an object with only ``name``,
    ``accepts`` and ``check`` is taken with those defaults (:func:`as_validator`)."""

    @property
    def name(self) -> str: ...

    @property
    def refutes(self) -> bool: ...

    @property
    def max_bnb_dim(self) -> int: ...

    @property
    def backoff(self) -> int: ...

    @property
    def exact_only(self) -> bool: ...

    def accepts(self, system: System, V: Lyapunov) -> bool: ...

    def check(self, system: System, V: Lyapunov, level: float) -> Validation: ...

    def exact_route(self, system: System, V: Lyapunov) -> SosValidator | None: ...

    def refuter(self) -> Validator: ...

    def with_cover(self, half: Callable[[], np.ndarray | None]) -> Validator: ...

    def without_witness_search(self) -> Validator: ...


class ValidatorBase:
    """Defaults of the :class:`Validator` capabilities: it refutes, its branch and bound covers
    :data:`roa.options.BNB_DIM` states and parameters, it has no exact route tried first, no
    cover of its own to take and no witness search to turn off."""

    refutes: bool = True
    max_bnb_dim: int = BNB_DIM
    backoff: int = 5
    exact_only: bool = False

    def exact_route(self, system: System, V: Lyapunov) -> SosValidator | None:
        """The exact SOS validator tried first (with its back-off) before this one decides, or
        None (:mod:`roa.certification._backoff`)."""
        return None

    def refuter(self) -> Validator:
        """The validator that decides a level above the optimum: this one when it refutes, else
        the branch and bound (which looks for a witness, checked at 50 digits)."""
        return cast(Validator, self) if self.refutes else IntervalValidator()

    def with_cover(self, half: Callable[[], np.ndarray | None]) -> Validator:
        """This validator with the box of half-widths ``half()`` (found along rays, proved by
        ``V > level`` on its faces) as the cover of a freshly found V, where it takes one
        (``half`` is called only then)."""
        return cast(Validator, self)

    def without_witness_search(self) -> Validator:
        """This validator without the level search's witness (just run by the caller)."""
        return cast(Validator, self)


@dataclass(frozen=True)
class Declared(ValidatorBase):
    """A validator object with only ``name``, ``accepts`` and ``check``, taken with the default
    capabilities of :class:`ValidatorBase`."""

    inner: Any

    @property
    def name(self) -> str:
        return str(self.inner.name)

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return bool(self.inner.accepts(system, V))

    def check(self, system: System, V: Lyapunov, level: float) -> Validation:
        return cast(Validation, self.inner.check(system, V, level))


def as_validator(obj: Any) -> Validator:
    """``obj`` as a :class:`Validator`: itself when it declares its capabilities (a
    :class:`ValidatorBase`), else with the defaults (:class:`Declared`)."""
    return cast(Validator, obj) if isinstance(obj, ValidatorBase) else Declared(obj)


def _preconditions(system: System, V: Lyapunov, level: float, route: Route) -> Preconditions:
    """:func:`roa.proof._preconditions.check_preconditions` for a fresh certificate (a Putinar
    candidate of the domain containment proposed by :mod:`roa.search._sos_program`)."""
    from roa.search._outside import domain_witness
    from roa.search._sos_program import propose_domain_certificate

    with step(f"preconditions of level {level:.6g} ({route.name})"):
        return check_preconditions(system, V, level, route, propose=propose_domain_certificate,
                                   find_outside=domain_witness,
                                   cover_estimate=ray_box)  # fmt: skip


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


#: What the interval branch and bound proves by itself (:class:`roa.proof._preconditions.Route`).
INTERVAL_ROUTE = Route("interval", parameters=True, cover=True, domain_by_boxes=True)
#: What the exact SOS routes prove by themselves (a box of parameters: the recast route).
SOS_ROUTE = Route("sos-exact", parameters=True)


@dataclass(frozen=True)
class IntervalValidator(ValidatorBase):
    """Interval branch and bound with outward rounding (:func:`roa.proof._validate.validate_level`).

    Accepts every autonomous system with an equilibrium and every V, continuous-time (``V' < 0``)
    or discrete-time (``V(F(x)) - V(x) < 0``, the whole sublevel set then proved invariant);
    ``bounding_box`` (any V) is a box holding the level set, proved by ``V > level`` on its
    faces (a map needs the whole sublevel set: the ``invariant`` precondition). For a system with
    uncertain parameters the level is proved for every parameter of the box
    (:func:`roa.proof._robust.validate_robust`).
    """

    options: IntervalOptions = field(default_factory=IntervalOptions)
    bounding_box: Any = None
    name: str = "interval"

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return system.equilibrium is not None and not system.time_varying

    def with_cover(self, half: Callable[[], np.ndarray | None]) -> Validator:
        if self.bounding_box is not None:
            return self
        h = half()
        return IntervalValidator(self.options, None if h is None else 1.3 * h)

    def check(self, system: System, V: Lyapunov, level: float) -> Validation:
        pre = _preconditions(system, V, level, INTERVAL_ROUTE)
        if pre.refusal is not None:
            return pre.refusal
        if system.parameters:
            from roa.proof._robust import validate_robust
            from roa.search._robust_witness import sampled_witness

            with step(f"robust interval validation of level {level:.6g}", own_budget=True):
                x, worst, _ = sampled_witness(system, V, level)
                return validate_robust(system, V, level, proposal=(x, worst),
                                       max_boxes=self.options.max_boxes,
                                       batch=self.options.batch,
                                       bounding_box=self.bounding_box,
                                       time_limit=self.options.seconds(),
                                       cover_estimate=ray_box)  # fmt: skip
        with step(f"interval validation of level {level:.6g}", own_budget=True):
            return validate_level(system, V, level, max_boxes=self.options.max_boxes,
                                  batch=self.options.batch, bounding_box=self.bounding_box,
                                  time_limit=self.options.seconds(),
                                  cover_estimate=ray_box)  # fmt: skip


@dataclass(frozen=True)
class SosValidator(ValidatorBase):
    """Exact SOS certificate of the level (:mod:`roa.proof._sos_check`): polynomial V.

    The numerical SOS program (:class:`roa.search._sos_program.FixedLevel`) proposes
    Gram matrices; their rounding and exact projection (Peyrl-Parrilo, python-flint) proves
    ``V' < 0`` on ``{V <= level}`` minus the equilibrium, or the verdict is inconclusive (with the
    reason). It never refutes (the pipeline refutes above with the branch and bound or a
    confirmed witness of the level search). Its
    cost grows polynomially with the dimension (the Gram basis), not exponentially as the branch
    and bound's boxes do.

    A system with uncertain parameters is proved for every parameter of its box: the parameters
    are indeterminates of the certificate, constrained to the box by Putinar multipliers
    (:class:`roa.proof._reductions.ParameterBox`, through the recast route even for a polynomial
    field).

    A non-polynomial field (sin/cos of states, rational terms, square roots) is recast exactly
    (:mod:`roa.proof._recast`) and proved by a constrained certificate
    (:func:`roa.proof._putinar.check_level`, proposed by the same program); a field that
    cannot be recast (the term is named), or one with a domain, is decided by the interval branch
    and bound instead (``fallback=True``, the certificate's method is then ``interval``) or is
    inconclusive (``fallback=False``, and :meth:`accepts` refuses it).

    When ``V`` and ``V'`` of a polynomial field split over independent blocks of variables
    (:mod:`roa.proof._reductions`: decoupled subsystems), each block gets its own certificate at the
    same level, which proves the whole. A coupled system whose dense program does not fit the
    memory budget (``route="auto"``; ``"sparse"`` forces it) gets the correlative-sparsity
    program instead (:func:`roa.search._sos_program.clique_pattern`: one Gram block per maximal clique of a chordal
    extension of the variables' interaction graph), proved by the same exact identity over the sum
    of its blocks (:func:`roa.proof._putinar.check_level`); its ``meta`` reports the cliques' and blocks' sizes,
    the solver's and the check's seconds and the process's peak memory (``peak_mib``). A dense
    coupled system with neither gets the sign-symmetry blocks and, for those too large for the
    interior point, scaled diagonally dominant blocks (``route="sdsos"``,
    :func:`roa.search._sos_program.sdsos`), proved by exact scaled diagonal dominance.

    When the exact check fails at a proposed level (not one the caller gave), up to ``backoff``
    lower levels are tried on this route before any branch and bound
    (:mod:`roa.certification._backoff`; each try in the trace and in ``meta["backoff"]``).
    ``solver_options`` may name the solver (``"solver"``: ``"clarabel"``, ``"scs"`` or
    ``"auto"``) and its tolerances (:func:`roa.search._sdp.settings`).

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
    backoff: int = 5  # lower levels tried when the exact check fails (roa.certification._backoff)
    exact_only: bool = True  # its exact route is all it has (the back-off's failure is its verdict)

    def __post_init__(self) -> None:
        if self.route not in ROUTES:
            raise RoaInputError(f"SosValidator route must be one of {ROUTES}, got {self.route!r}")
        check_tries(self.backoff, "SosValidator backoff")

    def exact_route(self, system: System, V: Lyapunov) -> SosValidator | None:
        sos = dataclasses.replace(self, fallback=False)
        return sos if sos.accepts(system, V) else None

    def accepts(self, system: System, V: Lyapunov) -> bool:
        if not V.is_polynomial or system.equilibrium is None:
            return False
        if system.time_varying:
            return False
        return self.fallback or self.recast_error(system, V) is None

    @staticmethod
    def recast_error(system: System, V: Lyapunov) -> str | None:
        """None if the field is polynomial or can be recast exactly, else why not (naming the
        term)."""
        from roa.proof._recast import recast_exact
        from roa.proof._sos_check import NotPolynomial, exact_data

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
        :mod:`roa.proof._preconditions` (the domain containment stored with the certificate)."""
        if self.fallback and self._needs_fallback(system, V):
            return self._prove(system, V, level)  # the branch and bound checks its own
        pre = _preconditions(system, V, level, SOS_ROUTE)
        if pre.refusal is not None:
            return pre.refusal
        return _with_domain(self._prove(system, V, level), pre)

    def _needs_fallback(self, system: System, V: Lyapunov) -> bool:
        from roa.proof._sos_check import NotPolynomial, exact_data

        if not getattr(system, "parameters", None):
            try:
                exact_data(system, V)
                return False
            except NotPolynomial:
                pass
        return self.recast_error(system, V) is not None

    def _prove(self, system: System, V: Lyapunov, level: float) -> Validation:
        from roa.proof._sos_check import NotPolynomial, exact_data, preconditions

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

    def _prove_data(self, data: Any, V: Lyapunov, level: float, out: Any,
                    recast: Any = None) -> Validation:  # fmt: skip
        """The certificate of the exact data ``data`` (in ``d`` or in rescaled variables; a
        recast's with ``recast`` its reduction and inverse): one part per independent block of
        variables of a polynomial field (:func:`roa.proof._reductions.blocks`), each proposed by
        the program chosen once for it (:func:`roa.search._sos_program.route_for`) and proved by
        :func:`roa.proof._putinar.check_level`."""
        import resource

        split = IndependentBlocks()
        subs, parts = ([data], [tuple(range(V.n))]) if recast else split.apply(data)
        whole = len(parts) == 1
        stored: list[dict[str, Any]] = []
        statuses: list[str] = []
        margins: list[float | None] = []
        sizes: list[int] = []
        figures: dict[str, Any] = {"recast": data.description} if recast else {}
        sdp_seconds = 0.0
        res: Any = None
        plan: Any = None
        for block, sub in zip(parts, subs, strict=True):
            where = "" if whole else f" (block {list(block)})"
            chosen = route_for(sub, self.multiplier_degree, self.route, self.solver_options)
            route, plan, why = chosen.kind, chosen.plan, chosen.why
            if route == "too_large":
                return out(Verdict.INCONCLUSIVE, f"SOS program too large, not built{where}: {why}",
                           route=route)  # fmt: skip
            eps = default_eps(sub, self.eps)
            cand = chosen.propose(level, eps)
            if route != "dense":  # the clique or the SDSOS pattern
                figures.update(route=route, why_sparse=why, blocks=plan.sizes, **cand.sizes)
                sizes += [len(b) for b in plan.sigma] if whole else [plan.largest]
            else:
                sizes.append(max(cand.sizes.get("gram_sizes", [0])))
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
            if route != "dense":
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
            if route == "sdsos":
                what = (f"SDSOS certificate (sign blocks {[len(b) for b in plan.sigma]}, scaled "
                        f"diagonally dominant {plan.sizes['sdd_blocks']})")  # fmt: skip
            elif route == "sparse":
                what = (f"sparse SOS certificate ({len(plan.cliques)} cliques of sizes <= "
                        f"{max(map(len, plan.cliques))})")  # fmt: skip
            cert = {"parts": stored}
            if recast:
                what = f"{what} of the recast field ({data.description})"
                cert = recast[0].invert(stored, recast[1])
            return out(Verdict.CERTIFIED, f"{what} checked exactly: {res.reason}",
                       certificate=cert, M=np.eye(V.n).tolist(), **figures,
                       residual=res.residual, min_pivot=res.min_pivot, **res.meta)  # fmt: skip
        # the whole of {V <= level} is proved (not one component): any frame bounds it
        reason = (f"{len(parts)} independent blocks of variables (sizes "
                  f"{[len(b) for b in parts]}), each: {res.reason}")  # fmt: skip
        return out(Verdict.CERTIFIED, f"SOS certificate checked exactly: {reason}",
                   certificate=split.invert(stored, parts), M=np.eye(V.n).tolist(),
                   **figures)  # fmt: skip

    def _check_recast(self, system: System, V: Lyapunov, level: float, out: Any) -> Validation:
        """The recast field's (or parameter box's) constrained certificate, by the program of
        :meth:`_prove_data` with the recast's constraints."""
        from roa.proof._sos_check import NotPolynomial
        from roa.search._sos_program import dense_fits

        with step(f"SOS exact validation (recast field) of level {level:.6g}"):
            recast = Recast(self.taylor)
            try:
                (data,), inverse = recast.apply(system, V, level)
            except NotPolynomial as exc:
                return out(Verdict.INCONCLUSIVE, str(exc))
            first = self._prove_data(data, V, level, out, (recast, inverse))
        if (first.status is Verdict.CERTIFIED or self.route != "auto"
                or first.meta.get("route") != "sparse"
                or not dense_fits(data, self.multiplier_degree)):  # fmt: skip
            return first
        # the auto route took the components of a disconnected interaction graph as cliques; the
        # dense program (stronger: one multiplier over all variables) fits, so it is tried too
        with step(f"SOS exact validation (recast field, dense) of level {level:.6g}"):
            dense = dataclasses.replace(self, route="dense")
            again = dense._prove_data(data, V, level, out, (recast, inverse))
        return again if again.status is Verdict.CERTIFIED else first


@dataclass(frozen=True)
class AutoValidator(ValidatorBase):
    """The route that certifies, chosen from the problem's form.

    Where the branch and bound's dimension allows it (states plus uncertain parameters at most
    ``max_bnb_dim``) it decides first (it also refutes, with a 50-digit witness) and the exact SOS
    certificate is tried when it is inconclusive; above, the exact SOS certificate (polynomial or
    exactly recast fields, decoupled blocks) is tried first and the branch and bound decides when
    it does not certify. Either way only a validator's own proof certifies; the verdict's
    ``method`` names the one that decided. Above ``max_bnb_dim``, when the SOS route does not
    certify, the level search's witness (``witness_search``:
    :func:`roa.certification._strategies.witness_by_search`, a 50-digit point of ``{V' >= 0}`` with
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

    def exact_route(self, system: System, V: Lyapunov) -> SosValidator | None:
        if self.bounding_box is not None or V.n + len(system.uncertain) <= self.max_bnb_dim:
            return None
        sos = SosValidator(fallback=False)
        return sos if sos.accepts(system, V) else None

    def without_witness_search(self) -> Validator:
        return dataclasses.replace(self, witness_search=False)

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
            found, note = witness_by_search(system, V, level, [])
            if found is not None:
                return dataclasses.replace(found, meta={**found.meta, "method": "witness search"})
        backup = IntervalValidator(self.options.replace(
            time_limit=self.options.seconds(BNB_SECONDS_BACKUP)), self.bounding_box)  # fmt: skip
        return by_interval(backup.check(system, V, level), f"SOS route: {s.message}; "
                           + (f"{note}; " if note else "") + "branch and bound: ")  # fmt: skip


def searchable(system: System) -> bool:
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
    (CasADi) gives a point of ``{V' >= 0}``, from which :func:`lowest_confirmed_witness
    <roa.search._witness.lowest_confirmed_witness>` finds a local minimum of V whose ``V' >= 0``
    holds at 50 digits, in the equilibrium's component of its sublevel set; it refutes ``top``
    when ``V(x) <= top``. Else ``(None, note)``, the note naming a confirmed witness above
    ``top`` (an upper bound of the largest level of V). ``(None, "")`` at once for a system
    that is not :func:`searchable`."""
    from roa.proof._witness import WITNESS_SLACK, refuted_by
    from roa.search._witness import lowest_confirmed_witness

    if not searchable(system):
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


class ProposerBase:
    """What the pipeline asks of a level proposer beyond :class:`LevelProposer`, with defaults:

    * ``given``: the caller's level, validated as it is (no linearisation refusal, no retry, no
      back-off);
    * ``fallback``: a search that takes over when an earlier proposer declines V (the
      certificate's message then says why the earlier one did not apply);
    * :meth:`over_box`: the proposer for a system with a parameter box (default: run at the
      box's sample points, the lowest level wins, :class:`WorstCase`);
    * ``label``: its name in the trace."""

    given: bool = False
    fallback: bool = False

    def accepts(self, system: System, V: Lyapunov) -> bool:
        raise NotImplementedError

    def propose(self, system: System, V: Lyapunov) -> Proposal:
        raise NotImplementedError

    def over_box(self) -> ProposerBase:
        return WorstCase(self)

    @property
    def label(self) -> str:
        return type(self).__name__


@dataclass(frozen=True)
class ForeignProposer(ProposerBase):
    """A :class:`LevelProposer` object that is no :class:`ProposerBase`, with its defaults."""

    inner: Any

    @property
    def label(self) -> str:
        return type(self.inner).__name__

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return bool(self.inner.accepts(system, V))

    def propose(self, system: System, V: Lyapunov) -> Proposal:
        return cast(Proposal, self.inner.propose(system, V))


def as_proposer(obj: Any) -> ProposerBase:
    """``obj`` (a :class:`LevelProposer`) with the capabilities of :class:`ProposerBase`."""
    return obj if isinstance(obj, ProposerBase) else ForeignProposer(obj)


def _positive(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
        raise RoaInputError(f"{what} must be a finite number > 0, got {value!r}")
    if not value > 0:
        raise RoaInputError(f"{what} must be a finite number > 0, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class GivenLevel(ProposerBase):
    """The caller's level, validated as it is (no safety factor, no retry below it)."""

    level: float
    given = True

    def over_box(self) -> ProposerBase:
        return self

    def __post_init__(self) -> None:
        object.__setattr__(self, "level", _positive(self.level, "level"))

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return True

    def propose(self, system: System, V: Lyapunov) -> Proposal:
        return Proposal("given", self.level, None)


@dataclass(frozen=True)
class CandidateLevel(ProposerBase):
    """A largest level found elsewhere (a number, or a :class:`roa.LevelSearchResult`),
    validated at ``safety`` x it."""

    candidate: LevelSearchResult | float
    safety: float = 0.999

    def over_box(self) -> ProposerBase:
        return self

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
class SosLevel(ProposerBase):
    """The SOS level search's largest level (:func:`roa.search._sos_bisection.level_search`: the
    max-level program, quadratic V; bisection for independent blocks of variables or a patterned
    program, each block's route chosen once); validated at
    ``options.safety_factor`` x it. ``only=True``: the SOS level is the answer
    (never certified: no independent check)."""

    options: SosOptions = field(default_factory=SosOptions)
    only: bool = False

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return V.is_quadratic and system.time == "continuous"

    def propose(self, system: System, V: Lyapunov) -> Proposal:
        from roa.search._sos_bisection import level_search

        quad = V.quadratic_view()
        assert quad is not None
        o = self.options
        res = level_search(system, V if V.is_polynomial else quad,
                           recast_mode=o.recast, multiplier_degree=o.multiplier_degree,
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


@dataclass(frozen=True)
class SampledLevel(ProposerBase):
    """The sampled level search's optimum (:func:`roa.level_search`, any V), validated at
    ``safety`` x it."""

    options: SampledOptions | None = None
    safety: float = 0.999
    fallback = True

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
class WorstCase(ProposerBase):
    """A proposer run at each sample point of an uncertain system's parameter box
    (:func:`roa.model._parameters.sample_points`: nominal value, vertices and ``per_axis`` points along
    each axis); the lowest level wins.
    A proposal only: the robust validator decides for every parameter of the box."""

    inner: LevelProposer
    per_axis: int = 3  # interior points along each parameter's axis, beside the vertices

    def over_box(self) -> ProposerBase:
        return self

    def accepts(self, system: System, V: Lyapunov) -> bool:
        return self.inner.accepts(system.nominal(), V)

    def propose(self, system: System, V: Lyapunov) -> Proposal:
        from roa.model._parameters import describe_point, sample_points

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
@dataclass(frozen=True)
class Candidate:
    """A candidate V of a source with the proposer of its level (proves nothing).

    ``choose(opt)``: the level validated for an optimum ``opt`` (default: the proposal's factor x
    ``opt``); ``fresh``: V was just found by a search whose witness may refute the level above;
    ``search``: the candidate's level search (kept in the certificate); ``level_source``: the
    certificate's level source unless a witness chose the level; ``label``: the progress step of
    its validation."""

    V: Lyapunov
    proposer: LevelProposer
    choose: Callable[[float], float] | None = None
    fresh: bool = False
    search: LevelSearchResult | None = None
    level_source: str | None = None
    label: str | None = None


@dataclass(frozen=True)
class Candidates:
    """What a source of V found: ``pairs`` in the order they are tried (at most ``validate`` of
    them validated), the search's own ``result`` (``Certificate.vs``); when there is none, why
    (``message``), the certificate's ``method``, and its ``V`` and ``search`` when the search
    got that far."""

    pairs: tuple[Candidate, ...]
    result: Any
    validate: int
    message: str = ""
    method: str = "sos"
    V: Lyapunov | None = None
    search: LevelSearchResult | None = None


@runtime_checkable
class VSource(Protocol):
    """Proposes candidates V from a quadratic seed (never proves them)."""

    @property
    def seed(self) -> Any: ...

    @property
    def degree(self) -> int: ...

    def search(self, system: System, seed: Any, proposer: LevelProposer) -> Candidates:
        """The candidates found from ``seed``; ``proposer`` proposes the level of a candidate
        that brings no proposer of its own."""
        ...


DEGREES = (2, 4, 6, 8)


def positive_level(value: Any) -> float:
    """``value`` as a level: a finite number > 0, else a :class:`RoaInputError`."""
    if not (isinstance(value, int | float) and np.isfinite(value) and value > 0):
        raise RoaInputError(f"level must be a finite number > 0, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class VsIteration:
    """SOS V-s iteration (:func:`roa.search._vs_iteration.vs_search`): one candidate per round,
    tried best shape level first; ``options.validate`` of them are validated at most."""

    degree: int = 4
    options: VsOptions = field(default_factory=VsOptions)
    seed: Any = None  # the quadratic seed (default: the system's quadratic V)

    def __post_init__(self) -> None:
        if self.degree not in DEGREES:
            raise RoaInputError(f"degree must be one of {DEGREES}, got {self.degree!r}")

    def search(self, system: System, seed: Any, proposer: LevelProposer) -> Candidates:
        from roa.search._vs_iteration import vs_search

        vs = self.options
        with step(f"SOS V-s iteration, degree {self.degree}", own_budget=True):
            res = vs_search(system, seed, degree=self.degree,
                            shape=None if vs.shape is None else np.asarray(vs.shape),
                            rounds=vs.rounds, multiplier_degree=vs.multiplier_degree,
                            symmetry=vs.symmetry, aux_degree=vs.aux_degree, recast_mode=vs.recast,
                            tol=vs.tol, solver_options=vs.solver_options(),
                            solver=vs.solver, budget=vs.budget, objective=vs.objective,
                            reach=vs.reach)  # fmt: skip
        if not res.candidates:
            return Candidates((), res, vs.validate,
                              f"V-s iteration found no candidate: {res.message}", "sos")  # fmt: skip
        order = res.ranked()  # best first (the objective's score)
        return Candidates(tuple(Candidate(V, proposer, label=f"validation of {V.name}")
                                for V in order), res, vs.validate)  # fmt: skip


@dataclass(frozen=True)
class CuttingPlanes:
    """Sampled cutting planes (:func:`roa.search._cutting_planes.sample_search`): one candidate,
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

    def search(self, system: System, seed: Any, proposer: LevelProposer) -> Candidates:
        """The candidate with its own proposer (its sampled level, validated at the chosen
        level); ``proposer`` is not used."""
        from roa.search._cutting_planes import sample_search

        with step(f"sampled search of V, degree {self.options.degree}"):
            res = sample_search(system, seed, hard=self.hard, soft=self.soft,
                                options=self.options)  # fmt: skip
        if res.V is None:
            return Candidates((), res, 1, f"the sampled search found no candidate: {res.message}",
                              "sampled search")  # fmt: skip
        V = res.V
        with step("sampled level search of the candidate"):
            lv = level_search(system, V, shape="level", method="sampled")
        if lv.level is None:
            return Candidates((), res, 1, f"no sampled level for the candidate: {lv.message}",
                              "level search", V=V, search=lv)  # fmt: skip
        safety, chosen, found = self.options.level_safety, self.level, float(lv.level)
        if chosen is None:
            choose = lambda opt: min(1.0, safety * opt)  # noqa: E731 - 1: the search's target
        elif callable(chosen):
            choose = lambda opt: positive_level(chosen(V, opt))  # noqa: E731
        else:
            fixed = positive_level(chosen)
            choose = lambda opt: fixed if opt == found else safety * opt  # noqa: E731
        cand = Candidate(V, CandidateLevel(lv, safety), choose=choose, fresh=True, search=lv,
                         level_source="given" if chosen is not None else "sampled")  # fmt: skip
        return Candidates((cand,), res, 1)
