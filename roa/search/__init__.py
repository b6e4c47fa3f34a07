"""Solvers that only propose: candidates for V and for its level, never a verdict.

Every module here returns a *candidate* (an SOS level, a V found by V-s iteration or by cutting
planes on samples, an optimised quadratic V); :mod:`roa.proof` decides whether it holds. Nothing in
this package may call a result certified.
"""

import lazy_loader as _lazy

# The public names are listed once, in __init__.pyi: it gives __all__, the lazy imports and the types.
__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
