"""``roa.certify``: find a level of a Lyapunov candidate and prove it, as a pipeline of strategies.

:func:`certify` returns a :class:`Certificate`. The strategies (:mod:`.strategies`) are objects:
validators (:class:`IntervalValidator`, :class:`SosValidator`, :class:`AutoValidator`), level proposers (:class:`GivenLevel`,
:class:`CandidateLevel`, :class:`SosLevel`, :class:`SampledLevel`) and sources of V
(:class:`VsIteration`, :class:`CuttingPlanes`, yielding :class:`Candidate` pairs of V and its
proposer); :mod:`.pipeline` chains them with a :class:`RetryPolicy` and a :class:`WitnessRefuter`,
and :func:`plan` maps :func:`certify`'s arguments (names, numbers, shorthands) to those objects.
A validator or proposer declares what it can do (:class:`ValidatorBase`, :class:`ProposerBase`).
"""

from roa.certification.pipeline import (
    METHODS,
    Plan,
    RetryPolicy,
    WitnessRefuter,
    certify,
    plan,
    run,
)
from roa.certification.result import Certificate
from roa.certification.strategies import (
    AutoValidator,
    Candidate,
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
    ValidatorBase,
    VsIteration,
    VSource,
)

__all__ = [
    "METHODS",
    "Candidate",
    "CandidateLevel",
    "Candidates",
    "Certificate",
    "CuttingPlanes",
    "GivenLevel",
    "AutoValidator",
    "IntervalValidator",
    "LevelProposer",
    "Plan",
    "Proposal",
    "ProposerBase",
    "RetryPolicy",
    "SampledLevel",
    "SosLevel",
    "SosValidator",
    "Validator",
    "ValidatorBase",
    "VSource",
    "VsIteration",
    "WitnessRefuter",
    "certify",
    "plan",
    "run",
]
