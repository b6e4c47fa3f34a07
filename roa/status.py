"""Statuses of every kind of answer, and the stop rules of a trajectory.

One :class:`enum.StrEnum` per kind of answer; every member carries a one-line ``meaning``::

    >>> from roa.status import Verdict
    >>> Verdict.CERTIFIED.meaning
    'proved by a check independent of the solver that proposed it'
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from roa.errors import RoaInputError


class _Status(enum.StrEnum):
    """A string-valued status whose members carry a one-line ``meaning``."""

    meaning: str

    def __new__(cls, value: str, meaning: str = "") -> _Status:
        obj = str.__new__(cls, value)
        obj._value_ = value
        obj.meaning = meaning
        return obj

    @classmethod
    def describe(cls) -> dict[str, str]:
        """``{value: meaning}`` of every member, in definition order."""
        return {m.value: m.meaning for m in cls}


class RunStatus(_Status):
    """How one trajectory ended. Never merged: each is counted on its own."""

    CONVERGED = "converged", "entered the ball ||x - x_eq|| <= converge_tol around the equilibrium"
    CONVERGED_ELSEWHERE = (
        "converged_elsewhere",
        "settled within converge_tol of another equilibrium (the point is reported)",
    )
    LEFT_DOMAIN = "left_domain", "crossed the boundary of the system's domain"
    DIVERGED = (
        "diverged",
        "norm above diverge_bound, a non-finite state, or growing exponentially at t_final "
        "(see StopRules.diverge_growth)",
    )
    UNDECIDED = "undecided", "none of the above by t_final (or the step size collapsed)"
    COMPLETED = "completed", "time-varying run (tracking) that reached t_final inside the domain"


class LevelStatus(_Status):
    """Outcome of Khalil's level-set search (:func:`roa.level_search`)."""

    FOUND = "found", "a largest level with a witness on V' = 0 or on the domain boundary"
    AGREE = "agree", "both methods found a level and agree within the tolerance"
    DISAGREE = "disagree", "both methods found a level but they differ: the smaller is reported"
    PARTIAL = "partial", "one method found a level, the other did not (see per_method)"
    UNBOUNDED = (
        "unbounded",
        "no point with V' >= 0 on the rays searched up to their radius (an estimate, not a bound)",
    )
    NOT_LOCALLY_NEGATIVE = (
        "not_locally_negative",
        "V' is not negative definite at the equilibrium: no level > 0 exists for this V",
    )
    FAILED = "failed", "no admissible point was found (solver failures)"

    @property
    def ok(self) -> bool:
        """Whether the reported level is a found upper bound of the largest level."""
        return self in (LevelStatus.FOUND, LevelStatus.AGREE)


class Verdict(_Status):
    """Verdict on a level set of a Lyapunov candidate: the only names used for certificates."""

    CERTIFIED = "certified", "proved by a check independent of the solver that proposed it"
    REFUTED = "refuted", "a counterexample exists, checked at 50 digits"
    INCONCLUSIVE = "inconclusive", "neither proved nor refuted (budget, domain, or no candidate)"


class SosStatus(_Status):
    """Outcome of the SOS program (a candidate level, not a certificate)."""

    SOLVED = "solved", "the SDP solver reports an optimal solution"
    INACCURATE = "inaccurate", "the solver stopped with reduced accuracy: the level is unreliable"
    INFEASIBLE = "infeasible", "the SOS program is infeasible at this degree"
    FAILED = "failed", "the solver failed (iterations, time limit, numerical trouble)"
    NOT_POLYNOMIAL = (
        "not_polynomial",
        (
            "V' is not polynomial with half-integer powers recast: the SOS proposer does not apply "
            "(the exact SOS validator recasts sin, cos and rational terms itself)"
        ),
    )
    TOO_LARGE = "too_large", "the program's Gram blocks exceed the size solved here: not built"
    STOPPED = (
        "stopped",
        "the time budget ran out: the candidates of the rounds completed are kept (best first)",
    )


class RegionStatus(_Status):
    """How much an estimate of the region of attraction is worth."""

    CLAIMED = "claimed", "stated by a paper, not checked"
    SAMPLED = "sampled", "largest level found by sampling or optimisation, no proof"
    CERTIFIED = "certified", "proved, checked independently of the solver that produced it"
    REFUTED = "refuted", "a counterexample exists"
    INCONCLUSIVE = "inconclusive", "neither proved nor refuted"


class BasinStatus(_Status):
    """Summary of a Monte Carlo basin run."""

    ALL_CONVERGED = "all_converged", "every initial condition converged to the equilibrium"
    PARTLY_CONVERGED = "partly_converged", "some initial conditions did not converge (see counts)"
    NONE_CONVERGED = "none_converged", "no initial condition converged"
    INCONCLUSIVE = "inconclusive", "the time limit ran out first (counts['not_run']); resumable"


@dataclass(frozen=True)
class StopRules:
    """When a trajectory stops and with which status.

    Parameters
    ----------
    t_final : float
        Final time; a run still running then is ``undecided`` (``completed`` for tracking runs).
    converge_tol : float
        Radius of the ball around the equilibrium that counts as converged.
    diverge_bound : float
        Norm above which a run is ``diverged``.
    diverge_growth : float or None
        Factor ``G > 1`` of the growth rule (:func:`roa.integration._divergence.blows_up`): a run still going
        at ``t_final`` is ``diverged`` when ``||x - x_eq||`` is then at least ``diverge_bound / G``,
        at least ``G`` times its largest value over ``[0, t_final / 2]``, and still growing at
        no less than half its mean exponential rate over ``[t_final / 2, t_final]``. ``None``: no
        growth rule (only ``diverge_bound`` makes a run ``diverged``).
    """

    t_final: float = 60.0
    converge_tol: float = 1e-3
    diverge_bound: float = 1e6
    diverge_growth: float | None = 100.0

    def __post_init__(self) -> None:
        for name in ("t_final", "converge_tol", "diverge_bound"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and 0 < value < math.inf):
                raise RoaInputError(f"rules.{name} must be a finite number > 0, got {value!r}")
        if self.converge_tol >= self.diverge_bound:
            raise RoaInputError(
                f"rules.converge_tol ({self.converge_tol:g}) must be smaller than "
                f"rules.diverge_bound ({self.diverge_bound:g})"
            )
        g = self.diverge_growth
        if g is not None and not (
            isinstance(g, int | float) and not isinstance(g, bool) and 1 < g < math.inf
        ):
            raise RoaInputError(
                f"rules.diverge_growth must be a finite factor > 1 or None (no growth rule), "
                f"got {g!r}"
            )
