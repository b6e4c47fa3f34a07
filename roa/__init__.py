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

#: The public API, written once: module -> the public names it defines. ``__all__`` and the lazy
#: table are built from it; the type-checking imports below list the same pairs for static
#: checkers (``tests/api/test_api.py`` keeps them equal). Each name is imported on first use
#: (PEP 562), so that ``import roa`` and ``roa --help`` stay fast: cvxpy, CasADi, numba, sympy,
#: matplotlib and scipy.optimize are imported only by the analyses that need them.
PUBLIC: dict[str, tuple[str, ...]] = {
    "roa.certification": (
        "AutoValidator",
        "CandidateLevel",
        "Certificate",
        "CuttingPlanes",
        "GivenLevel",
        "IntervalValidator",
        "SampledLevel",
        "SosLevel",
        "SosValidator",
        "VsIteration",
        "certify",
    ),
    "roa.errors": (
        "ResultsError",
        "RoaError",
        "RoaInputError",
        "SolverError",
        "SystemDefinitionError",
    ),
    "roa.integration.simulation": (
        "Trajectory",
        "simulate",
    ),
    "roa.lyapunov": (
        "FunctionLyapunov",
        "Lyapunov",
        "PolynomialLyapunov",
        "QuadraticLyapunov",
    ),
    "roa.model.system": (
        "System",
        "closed_loop",
    ),
    "roa.montecarlo.basin": (
        "BasinResult",
        "basin",
    ),
    "roa.montecarlo.robust_basin": (
        "RobustBasinResult",
        "parameter_samples",
    ),
    "roa.montecarlo.sampling": (
        "box_sample",
        "grid_slice",
        "region_sample",
    ),
    "roa.options": (
        "CasadiOptions",
        "IntegratorOptions",
        "IntervalOptions",
        "RunOptions",
        "SampleSearchOptions",
        "SampledOptions",
        "SosOptions",
        "VsOptions",
    ),
    "roa.search.candidate": ("default_lyapunov",),
    "roa.search.levelset": (
        "LevelSearchResult",
        "level_search",
    ),
    "roa.status": (
        "BasinStatus",
        "LevelStatus",
        "RegionStatus",
        "RunStatus",
        "SosStatus",
        "StopRules",
        "Verdict",
    ),
    "roa.systems": ("load_system",),
}
_LAZY: dict[str, str] = {name: module for module, names in PUBLIC.items() for name in names}

if TYPE_CHECKING:  # static checkers and IDEs see PUBLIC as eager imports
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
    from roa.lyapunov import FunctionLyapunov, Lyapunov, PolynomialLyapunov, QuadraticLyapunov
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

__all__ = sorted(_LAZY)
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
