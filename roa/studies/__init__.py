"""Studies: case studies that live beside the library and are driven by its CLI.

A study (such as the IPC paper reproduction beside this package) is a Python package registered under the entry
point group ``roa.studies`` whose object is a :class:`Study`: where its experiment configs are, the
reference values ``roa check`` recomputes, how its report is rendered, any extra CLI commands and
the systems it adds to the built-in ones (``load_system`` and every ``--system``).
The library itself never imports a study; ``roa run``, ``roa reproduce``, ``roa report``,
``roa check`` and :func:`roa.systems.load_system` look them up here by name.
"""

import lazy_loader as _lazy

# The public names are listed once, in __init__.pyi: it gives __all__, the lazy imports and the types.
__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
