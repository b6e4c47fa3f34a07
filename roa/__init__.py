"""roa: region-of-attraction verification toolkit.

Every analysis is one call returning a frozen result with a ``status``::

    import roa
    from roa.systems.vanderpol import vanderpol

    system = vanderpol()
    roa.simulate(system, [0.5, 0.5])                  # Trajectory, RunStatus
    roa.level_search(system, shape="level")           # LevelSearchResult, LevelStatus
    roa.certify(system)                               # Certificate, Verdict
    roa.basin(system, roa.grid_slice(system, ("x1", "x2"), [(-3, 3), (-3, 3)], (50, 50)))

Systems are small frozen dataclasses (:class:`roa.System`) whose vector field is written once
against an array namespace (numpy, CasADi, sympy, intervals), so that simulation, level-set search,
certification and Monte Carlo all work on the same definition.
"""

from roa.certification import (
    AutoValidator,
    CandidateLevel,
    Certificate,
    CuttingPlanes,
    GivenLevel,
    IntervalValidator,
    SampledLevel,
    SosLevel,
    SosValidator,
    VsIteration,
    certify,
)
from roa.errors import ResultsError, RoaError, RoaInputError, SolverError, SystemDefinitionError
from roa.levelset import LevelSearchResult, level_search
from roa.lyapunov import (
    FunctionLyapunov,
    Lyapunov,
    PolynomialLyapunov,
    QuadraticLyapunov,
    default_lyapunov,
)
from roa.montecarlo.basin import BasinResult, basin
from roa.montecarlo.robust_basin import RobustBasinResult, parameter_samples
from roa.montecarlo.sampling import box_sample, grid_slice, region_sample
from roa.options import (
    CasadiOptions,
    IntegratorOptions,
    IntervalOptions,
    RunOptions,
    SampledOptions,
    SampleSearchOptions,
    SosOptions,
    VsOptions,
)
from roa.simulation import Trajectory, simulate
from roa.status import (
    BasinStatus,
    LevelStatus,
    RegionStatus,
    RunStatus,
    SosStatus,
    StopRules,
    Verdict,
)
from roa.system import System
from roa.systems import load_system

__all__ = [
    "BasinResult",
    "RobustBasinResult",
    "CandidateLevel",
    "CuttingPlanes",
    "GivenLevel",
    "AutoValidator",
    "IntervalValidator",
    "SampledLevel",
    "SosLevel",
    "SosValidator",
    "VsIteration",
    "BasinStatus",
    "CasadiOptions",
    "Certificate",
    "IntegratorOptions",
    "IntervalOptions",
    "LevelSearchResult",
    "LevelStatus",
    "FunctionLyapunov",
    "Lyapunov",
    "PolynomialLyapunov",
    "QuadraticLyapunov",
    "RegionStatus",
    "ResultsError",
    "RoaError",
    "RoaInputError",
    "RunOptions",
    "RunStatus",
    "SampledOptions",
    "SolverError",
    "SosOptions",
    "SampleSearchOptions",
    "VsOptions",
    "SosStatus",
    "StopRules",
    "System",
    "SystemDefinitionError",
    "Trajectory",
    "Verdict",
    "basin",
    "parameter_samples",
    "box_sample",
    "certify",
    "default_lyapunov",
    "grid_slice",
    "level_search",
    "load_system",
    "region_sample",
    "simulate",
]
__version__ = "0.1.0"
