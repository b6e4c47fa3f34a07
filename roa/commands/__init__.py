"""CLI subcommands: each module defines ``register(subparsers)``."""

import lazy_loader as _lazy

# The public names are listed once, in __init__.pyi: it gives __all__, the lazy imports and the types.
__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
