from ._dopri import (
    CODE_STATUS as CODE_STATUS,
    CONVERGED as CONVERGED,
    DIVERGED as DIVERGED,
    LEFT_DOMAIN as LEFT_DOMAIN,
    UNDECIDED as UNDECIDED,
)
from ._integrator import (
    COORDS_SIGNATURE as COORDS_SIGNATURE,
    FIELD_SIGNATURE as FIELD_SIGNATURE,
    MARGIN_SIGNATURE as MARGIN_SIGNATURE,
    compile_kernel as compile_kernel,
    no_margin as no_margin,
    no_margin_njit as no_margin_njit,
)
from ._lazy_cfunc import LazyCfuncs as LazyCfuncs
from ._simulation import Trajectory as Trajectory, simulate as simulate
from ._terminal import (
    REL_MARGIN as REL_MARGIN,
    TerminalSet as TerminalSet,
    coords_map as coords_map,
)
