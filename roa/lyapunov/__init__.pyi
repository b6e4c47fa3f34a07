from ._base import Lyapunov as Lyapunov, check_positive_definite as check_positive_definite
from ._function import FunctionLyapunov as FunctionLyapunov
from ._polynomial import (
    PolynomialLyapunov as PolynomialLyapunov,
    QuadraticLyapunov as QuadraticLyapunov,
)
from ._regions import Region as Region, symmetric_extent as symmetric_extent
from ._serial import certificate_fields as certificate_fields, from_json as from_json
from ._symbolic import symbolic_gradient as symbolic_gradient
