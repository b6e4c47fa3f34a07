from .certification import (
    AutoValidator as AutoValidator,
    CandidateLevel as CandidateLevel,
    Certificate as Certificate,
    CuttingPlanes as CuttingPlanes,
    GivenLevel as GivenLevel,
    IntervalValidator as IntervalValidator,
    SampledLevel as SampledLevel,
    SosLevel as SosLevel,
    SosValidator as SosValidator,
    VsIteration as VsIteration,
    certify as certify,
)
from .errors import (
    ResultsError as ResultsError,
    RoaError as RoaError,
    RoaInputError as RoaInputError,
    SolverError as SolverError,
    SystemDefinitionError as SystemDefinitionError,
)
from .integration import Trajectory as Trajectory, simulate as simulate
from .lyapunov import (
    FunctionLyapunov as FunctionLyapunov,
    Lyapunov as Lyapunov,
    PolynomialLyapunov as PolynomialLyapunov,
    QuadraticLyapunov as QuadraticLyapunov,
)
from .model import System as System, closed_loop as closed_loop
from .montecarlo import (
    BasinResult as BasinResult,
    RobustBasinResult as RobustBasinResult,
    basin as basin,
    box_sample as box_sample,
    grid_slice as grid_slice,
    parameter_samples as parameter_samples,
    region_sample as region_sample,
)
from .options import (
    CasadiOptions as CasadiOptions,
    IntegratorOptions as IntegratorOptions,
    IntervalOptions as IntervalOptions,
    RunOptions as RunOptions,
    SampledOptions as SampledOptions,
    SampleSearchOptions as SampleSearchOptions,
    SosOptions as SosOptions,
    VsOptions as VsOptions,
)
from .search import (
    LevelSearchResult as LevelSearchResult,
    default_lyapunov as default_lyapunov,
    level_search as level_search,
)
from .status import (
    BasinStatus as BasinStatus,
    LevelStatus as LevelStatus,
    RegionStatus as RegionStatus,
    RunStatus as RunStatus,
    SosStatus as SosStatus,
    StopRules as StopRules,
    Verdict as Verdict,
)
from .systems import load_system as load_system

__version__: str
