"""Lyapunov candidates: one abstraction for every V.

:class:`Lyapunov` is the protocol (``expr``, ``gradient_expr``, ``value``, ``derivative``, the
whitening frame, ``describe``); what a candidate offers beyond it is told by attributes (``P``,
``terms``, ``degree``), never by its class. :class:`PolynomialLyapunov` is any polynomial of even
degree, :class:`QuadraticLyapunov` the degree-2 one (with ``P`` and closed-form numpy paths),
:class:`FunctionLyapunov` any function written against the array namespace. :func:`from_json`
reads every JSON form the toolkit writes, :func:`certificate_fields` writes a certificate's.
"""

import lazy_loader as _lazy

# The public names are listed once, in __init__.pyi: it gives __all__, the lazy imports and the types.
__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
