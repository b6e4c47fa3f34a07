"""Back-off of a proposed level on the exact SOS route, before any branch and bound.

A proposed level (the sampled optimum x 0.999, the SOS optimum x (1 - 1e-4)) sits where the
numerical program is nearly infeasible: the solver returns an inaccurate point, or the relaxation
itself stops just below the true optimum (a negative margin), and the exact check (rounding,
projection, exact LDL') fails. A slightly lower level usually passes. :func:`back_off` tries a few
lower levels with the exact SOS validator only, each a full solve and exact check:

* while nothing is certified, a step below the lowest failed level, ``(1 - 1e-3)``, then
  ``(1 - 1e-2)``, ... of the proposal, or, once two failed solves report the program's margin
  (the least eigenvalue of its Gram blocks, negative where the relaxation is infeasible), the
  level where the line through those margins crosses zero, less 0.5 % of the proposal;
* once a level is certified, bisection between the largest certified level and the lowest
  failed one (the point where the line through their margins crosses zero when both margins are
  known, kept inside the middle 80 % of the bracket).

Every try is reported (level, outcome, seconds, margin, reason). The certified level is the
largest level the exact check passed; only that check certifies, so the back-off cannot certify
above the true optimum whatever it tries. It never changes a level the caller gave.

:func:`exact_route` names the validator that runs first: the :class:`SosValidator` itself (its
fallback to the branch and bound turned off), or the SOS route of an :class:`AutoValidator`
where that route is tried first (states plus parameters above its ``max_bnb_dim``).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.model._system import System
from roa.proof._validation import Validation
from roa.status import Verdict

if TYPE_CHECKING:
    from roa.certification._strategies import Validator

#: Relative steps below the proposal tried while no level is certified.
STEPS = (1e-3, 1e-2, 3e-2, 1e-1)
#: Default number of tries after the proposal's own check.
TRIES = 5
#: The bracket is closed when its width is below this fraction of the proposal.
REL_TOL = 1e-3


@dataclass(frozen=True)
class BackoffTry:
    """One exact check of the back-off: the level, its verdict, the seconds, the solver's margin
    (None when not reported) and the validator's message."""

    level: float
    status: str
    seconds: float
    margin: float | None
    message: str

    def to_json(self) -> dict[str, Any]:
        return {"level": self.level, "status": self.status, "seconds": round(self.seconds, 3),
                "margin": self.margin, "message": self.message[:200]}  # fmt: skip


@dataclass(frozen=True)
class Backoff:
    """Outcome of :func:`back_off`: the largest certified level (None when no try certified),
    its validation, and every try in order (the proposal's own check first)."""

    level: float | None
    validation: Validation | None
    tries: tuple[BackoffTry, ...]
    first: Validation | None = None  # the proposal's own validation

    def describe(self) -> str:
        parts = [f"{t.level:.7g} {t.status} ({t.seconds:.1f} s)" for t in self.tries]
        return "exact SOS back-off: " + "; ".join(parts)


def exact_route(validator: Validator, system: System, V: Lyapunov) -> Any:
    """The exact SOS validator the back-off runs, or None when the validator does not try the
    SOS route first (the branch and bound decides first, or the field is neither polynomial nor
    exactly recast): :meth:`Validator.exact_route
    <roa.certification.Validator.exact_route>`."""
    return validator.exact_route(system, V)


def can_back_off(v: Validation) -> bool:
    """Whether a lower level may pass where ``v`` did not: the SOS program was built and solved
    (or failed in the solver) and the exact check or the solver failed; not a refused
    precondition, a program too large to build, or a field that cannot be recast."""
    if v.status is not Verdict.INCONCLUSIVE or v.meta.get("precondition"):
        return False
    return "solver_status" in v.meta


def _margin(v: Validation) -> float | None:
    m = v.meta.get("margin")
    if isinstance(m, list):  # per block: the least decides
        m = min((x for x in m if x is not None), default=None)
    return None if m is None else float(m)


def _zero(a: tuple[float, float], b: tuple[float, float]) -> float | None:
    """Where the line through ``(level, margin)`` points ``a`` and ``b`` crosses margin 0."""
    (x0, m0), (x1, m1) = a, b
    if m0 == m1:
        return None
    return x0 - m0 * (x1 - x0) / (m1 - m0)


def _next_level(proposal: float, tried: list[tuple[float, bool, float | None]], step: int
                ) -> float | None:  # fmt: skip
    """The next level to try (module docstring), None when the bracket is closed."""
    good = [(c, m) for c, ok, m in tried if ok]
    bad = [(c, m) for c, ok, m in tried if not ok]
    hi, m_hi = min(bad, key=lambda t: t[0])
    if good:
        lo, m_lo = max(good, key=lambda t: t[0])
        if hi - lo <= REL_TOL * proposal:
            return None
        guess = 0.5 * (lo + hi)
        if m_lo is not None and m_hi is not None and m_lo > 0 > m_hi:
            z = _zero((lo, m_lo), (hi, m_hi))
            if z is not None:
                guess = min(max(z, lo + 0.1 * (hi - lo)), hi - 0.1 * (hi - lo))
        return guess
    negatives = sorted((c, m) for c, m in bad if m is not None and m < 0)
    if len(negatives) >= 2:
        z = _zero(negatives[0], negatives[1])
        if z is not None and 0 < z < hi:
            return max(z - 0.005 * proposal, 0.5 * hi)
    frac = STEPS[min(step, len(STEPS) - 1)]
    return min(hi, proposal) * (1 - frac) if step < len(STEPS) else 0.5 * hi


def check_tries(tries: Any, field: str) -> int:
    """``tries`` when it is an integer in [0, 20], else an input error naming ``field``."""
    if isinstance(tries, bool) or not isinstance(tries, int) or not 0 <= tries <= 20:
        raise RoaInputError(f"{field} must be an integer in [0, 20], got {tries!r}")
    return tries


def back_off(system: System, V: Lyapunov, sos: Any, proposal: float, *,
             first: Validation | None = None, tries: int = TRIES,
             seconds: float | None = None) -> Backoff:  # fmt: skip
    """Largest level the exact SOS validator ``sos`` certifies among the proposal and at most
    ``tries`` lower levels (module docstring), within ``seconds`` (None: no limit; a try
    started before the limit runs to its end). ``first``: the proposal's own validation when
    it was already run."""
    check_tries(tries, "back-off tries")
    t0 = time.perf_counter()
    log: list[BackoffTry] = []
    tried: list[tuple[float, bool, float | None]] = []
    best: tuple[float, Validation] | None = None

    def run(level: float, v: Validation | None = None) -> Validation:
        nonlocal best
        s0 = time.perf_counter()
        v = sos.check(system, V, level) if v is None else v
        dt = v.seconds if v.seconds else time.perf_counter() - s0
        ok = v.status is Verdict.CERTIFIED
        margin = _margin(v)
        log.append(BackoffTry(float(level), v.status.value, dt, margin, v.message))
        tried.append((float(level), ok, margin))
        if ok and (best is None or level > best[0]):
            best = (float(level), v)
        return v

    v = first = run(proposal, first)
    step = 0
    while v.status is not Verdict.CERTIFIED or (best is not None and best[0] < proposal):
        if len(log) > tries or not (v.status is Verdict.CERTIFIED or can_back_off(v)):
            break
        if seconds is not None and time.perf_counter() - t0 >= seconds:
            break
        if not any(not ok for _, ok, _ in tried):
            break
        nxt = _next_level(proposal, tried, step)
        if nxt is None or not 0 < nxt < proposal:
            break
        if best is None:
            step += 1
        v = run(nxt)
    if best is None:
        return Backoff(None, None, tuple(log), first)
    level, val = best
    out = Backoff(level, None, tuple(log), first)
    meta = {**val.meta, "backoff": [t.to_json() for t in log]}
    message = val.message if len(log) == 1 else f"{val.message}; {out.describe()}"
    return dataclasses.replace(out, validation=dataclasses.replace(val, meta=meta, message=message))


def exact_first(system: System, V: Lyapunov, validator: Validator, level: float,
                trace: list[dict[str, Any]]) -> tuple[Validation, float] | None:  # fmt: skip
    """The exact SOS route and its back-off (:func:`back_off`) run before the validator
    ``validator`` when it tries that route first (:func:`exact_route`): ``(validation, level)``
    of the largest certified level, or, for a :class:`SosValidator` (which has no other route),
    the proposal's failed validation with every try in its message and ``meta["backoff"]``
    (``validator.exact_only``);
    None when the route does not apply or the back-off certified nothing and the validator
    decides the proposal itself (the branch and bound backs the SOS route up). Each try is a
    ``trace`` entry."""
    from roa.progress import step

    sos = exact_route(validator, system, V)
    if sos is None:
        return None
    tries = validator.backoff
    with step(f"exact SOS check of level {level:.6g}, backing off when it fails"):
        bo = back_off(system, V, sos, level, tries=tries)
    for k, t in enumerate(bo.tries):
        trace.append({"stage": "validate" if k == 0 else "validate below (exact back-off)",
                      "by": sos.name, "level": t.level, "status": t.status, "boxes": 0,
                      "seconds": round(t.seconds, 3), "margin": t.margin})  # fmt: skip
    if bo.validation is not None and bo.level is not None:
        return bo.validation, bo.level
    if validator.exact_only and bo.first is not None:
        v = bo.first
        if len(bo.tries) > 1:
            meta = {**v.meta, "backoff": [t.to_json() for t in bo.tries]}
            v = dataclasses.replace(v, meta=meta, message=f"{v.message}; {bo.describe()}")
        return v, level
    return None
