from ._cache import SearchCache as SearchCache
from ._candidate import as_lyapunov as as_lyapunov, default_lyapunov as default_lyapunov
from ._conditioned import conditioned_lyapunov as conditioned_lyapunov
from ._levelset import LevelSearchResult as LevelSearchResult, level_search as level_search
from ._levelset_casadi import casadi_level as casadi_level
from ._levelset_core import inner_level as inner_level
from ._levelset_sampled import sampled_level as sampled_level
from ._quadratic import optimise_quadratic as optimise_quadratic, sector as sector
from ._rays import component_candidates as component_candidates, ray_box as ray_box
from ._sdp import MAX_SDP_BYTES as MAX_SDP_BYTES, choose_solver as choose_solver
from ._sos import sos_level as sos_level
from ._vs_iteration import vs_search as vs_search
