from ._backend import (
    FUNCTIONS as FUNCTIONS,
    NP as NP,
    PIECEWISE as PIECEWISE,
    namespace as namespace,
)
from ._checks import check_system as check_system
from ._discrete import discretise as discretise
from ._linearisation import (
    jacobian as jacobian,
    linearise as linearise,
    lyapunov_matrix as lyapunov_matrix,
)
from ._sympy_eval import exact_rationals as exact_rationals, sympy_eval as sympy_eval
from ._system import System as System, closed_loop as closed_loop
