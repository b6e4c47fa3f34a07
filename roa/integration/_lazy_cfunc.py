"""numba cfuncs compiled on first use instead of at import.

``numba.cfunc(signature)`` compiles (or loads from its disk cache) when the decorator runs, which
made importing a module of cfuncs cost up to a second. :class:`LazyCfuncs` serves as a module's
``__getattr__`` (PEP 562): ``module.NAME`` compiles the plain Python function registered for
``NAME`` with ``numba.cfunc(signature, cache=True, error_model="numpy")`` on first access and
returns the same object afterwards. The body, signature and options are those the decorator used,
so the compiled code (and every trajectory) is the same; only the time of compilation moves.

Assumption: the registered functions are module-level (numba's disk cache locates them by
qualified name) and are never called as Python functions by the module itself.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from typing import Any


class LazyCfuncs:
    """A module ``__getattr__`` compiling registered cfuncs on first access.

    Parameters
    ----------
    module : str
        The module's ``__name__`` (for the AttributeError of an unknown name).
    specs : mapping of str to (signature, function)
        Public name -> the numba signature and the plain Python function to compile.
    """

    def __init__(self, module: str, specs: Mapping[str, tuple[Any, Callable[..., Any]]]) -> None:
        self.module = module
        self.specs = dict(specs)
        self._compiled: dict[str, Any] = {}
        self._lock = threading.Lock()

    def __call__(self, name: str) -> Any:
        spec = self.specs.get(name)
        if spec is None:
            raise AttributeError(f"module {self.module!r} has no attribute {name!r}")
        with self._lock:
            if name not in self._compiled:
                import numba

                signature, fn = spec
                self._compiled[name] = numba.cfunc(signature, cache=True, error_model="numpy")(fn)
            return self._compiled[name]

    def names(self) -> list[str]:
        """The public names served (for the module's ``__dir__``)."""
        return list(self.specs)
