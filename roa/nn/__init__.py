"""Neural networks as parts of vector fields: :class:`MLP` (numpy arrays, ONNX files).

See :mod:`roa.nn._mlp` for what a network computes in each namespace and what a certificate of a
closed loop with a network controller claims.
"""

import lazy_loader as _lazy

# The public names are listed once, in __init__.pyi: it gives __all__, the lazy imports and the types.
__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
