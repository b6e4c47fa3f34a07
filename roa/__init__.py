"""roa: region-of-attraction verification toolkit.

Systems are small frozen dataclasses (:class:`roa.system.System`) whose vector field is written once
against an array namespace (numpy, CasADi, sympy, intervals), so that simulation, level-set search,
certification and Monte Carlo all work on the same definition.
"""

from roa.status import RunStatus, StopRules
from roa.system import System

__all__ = ["System", "RunStatus", "StopRules"]
__version__ = "0.1.0"
