"""The system abstraction: a vector field written once for every array namespace."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from roa.backend import NP
from roa.errors import RoaInputError

Field = Callable[[Any, Any, Any], Sequence[Any]]
Margin = Callable[[Any, Any], Any]


@dataclass(frozen=True)
class System:
    """A (possibly time-varying) ODE ``x' = f(t, x)`` with an equilibrium and a domain.

    Parameters
    ----------
    name : str
        Short identifier.
    field : callable
        ``field(t, x, xp) -> sequence of n components``. ``x`` is indexable by component (numpy
        arrays of any common shape, CasADi or sympy symbols); ``xp`` is a namespace from
        :mod:`roa.backend`. Use only ``xp`` functions and arithmetic.
    equilibrium : sequence of float
        The equilibrium studied (``None`` for a time-varying run without one).
    state_names, state_units : tuple of str
        Names and units of the states, for CLI parsing and axis labels.
    margin : callable, optional
        ``margin(x, xp) -> array``: positive inside the domain, zero on its boundary. ``None`` means
        the whole space.
    domain_description : str
        Human-readable description of the domain, used in error messages.
    time_varying : bool
        True for a run that tracks a reference (no equilibrium analysis).
    lyapunov : n x n matrix, optional
        The quadratic Lyapunov candidate ``(x - x_eq)' P (x - x_eq)`` that comes with the system (a
        paper's or a benchmark's); :func:`roa.default_lyapunov` uses it, else solves
        ``A'P + PA = -I``.
    norm : n x n matrix, optional
        Positive-definite ``S`` of the system's natural norm ``(x - x_eq)' S (x - x_eq)``: the
        ``"ball"`` shape of :func:`roa.level_search` (default: the identity).
    meta : dict
        Anything else (e.g. a numba kernel under ``"numba"``); not compared.
    """

    name: str
    field: Field
    equilibrium: tuple[float, ...] | None
    state_names: tuple[str, ...]
    state_units: tuple[str, ...] = ()
    margin: Margin | None = None
    domain_description: str = "R^n"
    time_varying: bool = False
    lyapunov: Any = None  # stored as a tuple of rows
    norm: Any = None  # stored as a tuple of rows
    meta: dict[str, Any] = dataclasses.field(default_factory=dict, compare=False, hash=False)

    def __post_init__(self) -> None:
        for name in ("lyapunov", "norm"):
            value = getattr(self, name)
            if value is not None:
                arr = np.asarray(value, dtype=float)
                if arr.shape != (self.n, self.n) or not np.all(np.isfinite(arr)):
                    raise RoaInputError(
                        f"System.{name} must be a finite {self.n}x{self.n} matrix, got shape "
                        f"{arr.shape}"
                    )
                object.__setattr__(self, name, tuple(tuple(float(v) for v in row) for row in arr))

    @property
    def n(self) -> int:
        return len(self.state_names)

    @property
    def x_eq(self) -> np.ndarray:
        if self.equilibrium is None:
            raise RoaInputError(f"system {self.name!r} has no equilibrium (time-varying run)")
        return np.asarray(self.equilibrium, dtype=float)

    def f(self, x: np.ndarray, t: float | np.ndarray = 0.0) -> np.ndarray:
        """Evaluate the field with numpy on states of shape ``(..., n)``; returns ``(..., n)``."""
        x = np.asarray(x, dtype=float)
        if x.shape[-1] != self.n:
            raise RoaInputError(
                f"state must have {self.n} components {self.state_names}, got shape {x.shape}"
            )
        comps = [x[..., i] for i in range(self.n)]
        out = self.field(t, comps, NP)
        return np.stack(np.broadcast_arrays(*out), axis=-1)

    def inside(self, x: np.ndarray) -> np.ndarray:
        """Boolean mask of states (``(..., n)``) strictly inside the domain."""
        x = np.asarray(x, dtype=float)
        if self.margin is None:
            return np.all(np.isfinite(x), axis=-1)
        comps = [x[..., i] for i in range(self.n)]
        return np.asarray(self.margin(comps, NP) > 0) & np.all(np.isfinite(x), axis=-1)

    def check_state(self, x: Sequence[float] | np.ndarray, *, what: str = "state") -> np.ndarray:
        """Validate one or many states; raise ``ValueError`` naming the problem."""
        arr = np.asarray(x, dtype=float)
        if arr.ndim == 0 or arr.shape[-1] != self.n:
            raise RoaInputError(
                f"{what} must have {self.n} components {', '.join(self.state_names)}; "
                f"got shape {arr.shape}"
            )
        bad = ~np.isfinite(arr)
        if bad.any():
            idx = np.argwhere(bad)[0]
            raise RoaInputError(
                f"{what}: component {self.state_names[idx[-1]]} is not finite (NaN/inf)"
            )
        if self.margin is not None and not np.all(self.inside(arr)):
            raise RoaInputError(
                f"{what} outside the domain of {self.name}: {self.domain_description}"
            )
        return arr
