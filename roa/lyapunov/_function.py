"""A Lyapunov candidate written as any function of the state against the array namespace."""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov._base import Lyapunov, center_vector


class FunctionLyapunov(Lyapunov):
    """Any candidate ``V = func(x, xp)`` written against the array namespace ``xp``.

    ``func`` must use only the functions of :mod:`roa.model._backend` (``xp.log``, ``xp.sqrt``, ...) so
    that it runs on numpy, CasADi, sympy (its gradient is derived exactly) and intervals. It must
    vanish at ``center`` with a zero gradient there.

    Examples
    --------
    >>> from roa.lyapunov import FunctionLyapunov
    >>> V = FunctionLyapunov(lambda x, xp: xp.log(1 + x[0] ** 2 + x[1] ** 2), [0.0, 0.0], "log V")
    >>> round(float(V.value([[1.0, 0.0]])[0]), 6)
    0.693147
    """

    def __init__(self, func: Any, center: Any, name: str = "V") -> None:
        if not callable(func):
            raise RoaInputError(f"func must be callable V(x, xp), got {type(func).__name__}")
        self.func = func
        self.center = center_vector(center, None, "FunctionLyapunov")
        self.name = str(name)
        try:
            v0 = float(self.value(self.center[None, :])[0])
        except RoaInputError:
            raise
        except Exception as exc:  # noqa: BLE001 - a user function: report what it raised
            raise RoaInputError(f"func: V({self.center.tolist()}) raised {exc!r}") from None
        if not (np.isfinite(v0) and abs(v0) <= 1e-12):
            raise RoaInputError(f"func: V must vanish at center, V(center) = {v0!r}")

    def expr(self, x: Any, xp: Any) -> Any:
        return self.func(x, xp)

    def __repr__(self) -> str:
        return f"FunctionLyapunov({self.name!r}, center={self.center.tolist()})"
