"""``roa.certify``: find a level of a Lyapunov candidate and prove it, as a pipeline of strategies.

:func:`certify` returns a :class:`Certificate`. The strategies (:mod:`.strategies`) are objects:
validators (:class:`IntervalValidator`, :class:`SosValidator`, :class:`AutoValidator`), level proposers (:class:`GivenLevel`,
:class:`CandidateLevel`, :class:`SosLevel`, :class:`SampledLevel`) and sources of V
(:class:`VsIteration`, :class:`CuttingPlanes`); :mod:`.pipeline` chains them.
"""

from roa.certification.pipeline import METHODS, certify, run
from roa.certification.result import Certificate
from roa.certification.strategies import (
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
    VSource,
)

__all__ = [
    "METHODS",
    "CandidateLevel",
    "Certificate",
    "CuttingPlanes",
    "GivenLevel",
    "AutoValidator",
    "IntervalValidator",
    "LevelProposer",
    "Proposal",
    "SampledLevel",
    "SosLevel",
    "SosValidator",
    "Validator",
    "VSource",
    "VsIteration",
    "certify",
    "run",
]
