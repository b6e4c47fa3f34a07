"""What proves or refutes: interval arithmetic and jets, the branch-and-bound validation, box covers, local proofs, containment, certified sectors, 50-digit witness checks and the re-verification of certificate files. Candidates come from :mod:`roa.search`; only what this package proves is ever called certified."""

import lazy_loader as _lazy

# The public names are listed once, in __init__.pyi: it gives __all__, the lazy imports and the types.
__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
