"""Quadratic Lyapunov candidates V(x) = (x - c)' P (x - c), evaluated for any system."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.system import System


def check_positive_definite(P: Any, *, what: str = "P") -> np.ndarray:
    """Return ``P`` as a symmetric float array; raise if not symmetric positive definite."""
    P = np.asarray(P, dtype=float)
    if P.ndim != 2 or P.shape[0] != P.shape[1]:
        raise RoaInputError(f"{what} must be a square matrix, got shape {P.shape}")
    if not np.all(np.isfinite(P)):
        raise RoaInputError(f"{what} must be finite")
    if not np.allclose(P, P.T, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(P).max())):
        raise RoaInputError(f"{what} must be symmetric")
    lam = np.linalg.eigvalsh(P)
    if lam[0] <= 0:
        raise RoaInputError(
            f"{what} is not positive definite (smallest eigenvalue {lam[0]:.3g} <= 0): "
            "a Lyapunov candidate must be positive definite"
        )
    return 0.5 * (P + P.T)


@dataclass(frozen=True)
class QuadraticLyapunov:
    """V(x) = (x - center)' P (x - center) in a system's own coordinates."""

    P: np.ndarray
    center: np.ndarray
    name: str = "V"

    def __post_init__(self) -> None:
        object.__setattr__(self, "P", check_positive_definite(self.P, what=f"{self.name}.P"))
        c = np.asarray(self.center, dtype=float).reshape(-1)
        if c.shape[0] != self.P.shape[0]:
            raise RoaInputError(f"{self.name}.center must have {self.P.shape[0]} components")
        object.__setattr__(self, "center", c)

    @classmethod
    def for_system(cls, system: System, P: Any, name: str = "V") -> QuadraticLyapunov:
        P = np.asarray(P, dtype=float)
        if P.shape != (system.n, system.n):
            raise RoaInputError(
                f"V: P must be {system.n}x{system.n} for system {system.name!r}, got {P.shape}"
            )
        return cls(P, system.x_eq, name)

    @property
    def n(self) -> int:
        return self.P.shape[0]

    def value(self, x: np.ndarray) -> np.ndarray:
        """V on states of shape ``(..., n)``."""
        d = np.asarray(x, dtype=float) - self.center
        return np.einsum("...i,ij,...j->...", d, self.P, d)

    def derivative(self, system: System, x: np.ndarray) -> np.ndarray:
        """V' = grad V . f on states of shape ``(..., n)`` (numpy)."""
        d = np.asarray(x, dtype=float) - self.center
        return 2.0 * np.einsum("...i,ij,...j->...", d, self.P, system.f(x))

    def symbolic(self, system: System, x: Any, xp: Any) -> tuple[Any, Any]:
        """``(V, V')`` as expressions of the components ``x`` in namespace ``xp`` (CasADi, sympy)."""
        d = [x[i] - self.center[i] for i in range(self.n)]
        f = system.field(0.0, x, xp)
        Pd = [sum(self.P[i, j] * d[j] for j in range(self.n)) for i in range(self.n)]
        V = sum(d[i] * Pd[i] for i in range(self.n))
        Vd = 2 * sum(Pd[i] * f[i] for i in range(self.n))
        return V, Vd


def as_lyapunov(system: System, V: Any = None) -> QuadraticLyapunov:
    """``V`` as a :class:`QuadraticLyapunov` of ``system``: ``None`` (the default candidate), a
    ``QuadraticLyapunov``, or an n x n matrix ``P``."""
    if V is None:
        return default_lyapunov(system)
    if isinstance(V, QuadraticLyapunov):
        if V.n != system.n:
            raise RoaInputError(f"V has {V.n} states, system {system.name!r} has {system.n}")
        return V
    return QuadraticLyapunov.for_system(system, V, name="P")


def default_lyapunov(system: System) -> QuadraticLyapunov:
    """The quadratic Lyapunov candidate of a system.

    ``system.lyapunov`` when the system comes with one (a paper's or a benchmark's matrix), else
    ``P`` solving ``A'P + PA = -I`` for the linearisation ``A`` at the equilibrium.

    Examples
    --------
    >>> import roa
    >>> from roa.systems.vanderpol import vanderpol
    >>> roa.default_lyapunov(vanderpol()).P.tolist()
    [[1.5, -0.5], [-0.5, 1.0]]
    """
    if system.equilibrium is None:
        raise RoaInputError(f"system {system.name!r} has no equilibrium: no Lyapunov candidate")
    if system.lyapunov is not None:
        return QuadraticLyapunov.for_system(system, system.lyapunov, name=f"{system.name} V")
    from roa.linearisation import lyapunov_matrix

    return QuadraticLyapunov.for_system(system, lyapunov_matrix(system), name="P from A'P + PA = -I")
