from ._pipeline import (
    METHODS as METHODS,
    Plan as Plan,
    RetryPolicy as RetryPolicy,
    WitnessRefuter as WitnessRefuter,
    certify as certify,
    plan as plan,
    run as run,
)
from ._result import Certificate as Certificate
from ._strategies import (
    AutoValidator as AutoValidator,
    Candidate as Candidate,
    CandidateLevel as CandidateLevel,
    Candidates as Candidates,
    CuttingPlanes as CuttingPlanes,
    GivenLevel as GivenLevel,
    IntervalValidator as IntervalValidator,
    LevelProposer as LevelProposer,
    Proposal as Proposal,
    ProposerBase as ProposerBase,
    SampledLevel as SampledLevel,
    SosLevel as SosLevel,
    SosValidator as SosValidator,
    Validator as Validator,
    ValidatorBase as ValidatorBase,
    VsIteration as VsIteration,
    VSource as VSource,
)
