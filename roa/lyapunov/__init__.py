"""Lyapunov candidates: one abstraction for every V.

:class:`Lyapunov` is the protocol (``expr``, ``gradient_expr``, ``value``, ``derivative``, the
whitening frame, ``describe``); what a candidate offers beyond it is told by attributes (``P``,
``terms``, ``degree``), never by its class. :class:`PolynomialLyapunov` is any polynomial of even
degree, :class:`QuadraticLyapunov` the degree-2 one (with ``P`` and closed-form numpy paths),
:class:`FunctionLyapunov` any function written against the array namespace. :func:`from_json`
reads every JSON form the toolkit writes, :func:`certificate_fields` writes a certificate's.
"""

from roa.lyapunov.base import Lyapunov, check_positive_definite
from roa.lyapunov.function import FunctionLyapunov
from roa.lyapunov.polynomial import PolynomialLyapunov, QuadraticLyapunov
from roa.lyapunov.serial import certificate_fields, from_json
from roa.lyapunov.symbolic import symbolic_gradient
from roa.model.sympy_eval import exact_rationals, sympy_eval

__all__ = [
    "FunctionLyapunov",
    "Lyapunov",
    "PolynomialLyapunov",
    "QuadraticLyapunov",
    "certificate_fields",
    "check_positive_definite",
    "exact_rationals",
    "from_json",
    "symbolic_gradient",
    "sympy_eval",
]
