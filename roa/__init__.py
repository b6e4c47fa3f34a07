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

from __future__ import annotations

import importlib
import importlib.util
from typing import TYPE_CHECKING, Any

#: Public name -> the module defining it. Each is imported on first use (PEP 562), so that
#: ``import roa`` and ``roa --help`` stay fast: cvxpy, CasADi, numba, sympy, matplotlib and
#: scipy.optimize are imported only by the analyses that need them.
_LAZY: dict[str, str] = {
    "AutoValidator": "roa.certification",
    "CandidateLevel": "roa.certification",
    "Certificate": "roa.certification",
    "CuttingPlanes": "roa.certification",
    "GivenLevel": "roa.certification",
    "IntervalValidator": "roa.certification",
    "SampledLevel": "roa.certification",
    "SosLevel": "roa.certification",
    "SosValidator": "roa.certification",
    "VsIteration": "roa.certification",
    "certify": "roa.certification",
    "ResultsError": "roa.errors",
    "RoaError": "roa.errors",
    "RoaInputError": "roa.errors",
    "SolverError": "roa.errors",
    "SystemDefinitionError": "roa.errors",
    "LevelSearchResult": "roa.search.levelset",
    "level_search": "roa.search.levelset",
    "FunctionLyapunov": "roa.lyapunov",
    "Lyapunov": "roa.lyapunov",
    "PolynomialLyapunov": "roa.lyapunov",
    "QuadraticLyapunov": "roa.lyapunov",
    "default_lyapunov": "roa.search.candidate",
    "BasinResult": "roa.montecarlo.basin",
    "basin": "roa.montecarlo.basin",
    "RobustBasinResult": "roa.montecarlo.robust_basin",
    "parameter_samples": "roa.montecarlo.robust_basin",
    "box_sample": "roa.montecarlo.sampling",
    "grid_slice": "roa.montecarlo.sampling",
    "region_sample": "roa.montecarlo.sampling",
    "CasadiOptions": "roa.options",
    "IntegratorOptions": "roa.options",
    "IntervalOptions": "roa.options",
    "RunOptions": "roa.options",
    "SampledOptions": "roa.options",
    "SampleSearchOptions": "roa.options",
    "SosOptions": "roa.options",
    "VsOptions": "roa.options",
    "Trajectory": "roa.integration.simulation",
    "simulate": "roa.integration.simulation",
    "BasinStatus": "roa.status",
    "LevelStatus": "roa.status",
    "RegionStatus": "roa.status",
    "RunStatus": "roa.status",
    "SosStatus": "roa.status",
    "StopRules": "roa.status",
    "Verdict": "roa.status",
    "System": "roa.model.system",
    "closed_loop": "roa.model.system",
    "load_system": "roa.systems",
}

if TYPE_CHECKING:  # static checkers and IDEs see the eager imports
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
    from roa.integration.simulation import Trajectory, simulate
    from roa.lyapunov import (
        FunctionLyapunov,
        Lyapunov,
        PolynomialLyapunov,
        QuadraticLyapunov,
    )
    from roa.model.system import System, closed_loop
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
    from roa.search.candidate import default_lyapunov
    from roa.search.levelset import LevelSearchResult, level_search
    from roa.status import (
        BasinStatus,
        LevelStatus,
        RegionStatus,
        RunStatus,
        SosStatus,
        StopRules,
        Verdict,
    )
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
    "closed_loop",
    "default_lyapunov",
    "grid_slice",
    "level_search",
    "load_system",
    "region_sample",
    "simulate",
]
__version__ = "0.1.0"


def __getattr__(name: str) -> Any:
    """Import the public name ``name`` from its module on first access and cache it here; a
    submodule (``roa.io``) is imported as ``import roa.io`` would."""
    module = _LAZY.get(name)
    if module is None:
        if importlib.util.find_spec(f"{__name__}.{name}") is None:
            raise AttributeError(f"module 'roa' has no attribute {name!r}")
        return importlib.import_module(f"{__name__}.{name}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
