"""Lyapunov candidates: any ``V(x)`` written once against an array namespace, evaluated for any system.

:class:`Lyapunov` is the protocol every candidate follows: ``expr(x, xp)`` writes ``V`` against the
array namespace ``xp`` (numpy, CasADi, sympy, the interval namespace and interval jets of
:mod:`roa.proof.interval`, mpmath), ``gradient_expr(x, xp)`` its gradient, and ``value`` /
``derivative`` evaluate them with numpy on rows of states. :class:`QuadraticLyapunov`
(``(x - c)' P (x - c)``) is the special case the SOS program and the closed-form paths know;
:class:`roa.lyapunov_general.PolynomialLyapunov` and :class:`roa.lyapunov_general.FunctionLyapunov`
are the general ones.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from roa.backend import NP
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


def _components(x: np.ndarray, n: int, what: str) -> list[np.ndarray]:
    x = np.asarray(x, dtype=float)
    if x.shape[-1] != n:
        raise RoaInputError(f"{what}: states must have {n} components, got shape {x.shape}")
    return [x[..., i] for i in range(n)]


class Lyapunov:
    """A Lyapunov candidate ``V(x)`` centred at an equilibrium (the protocol of every candidate).

    Subclasses define ``center`` (ndarray), ``name`` (str) and :meth:`expr`; :meth:`gradient_expr`
    defaults to an exact symbolic gradient (sympy) of :meth:`expr`. ``x`` is indexable by
    component (a list of arrays, CasADi symbols, sympy symbols, intervals or jets).
    """

    center: np.ndarray
    name: str

    @property
    def n(self) -> int:
        return int(np.asarray(self.center).shape[0])

    # -- to be written by each candidate ---------------------------------------------------------
    def expr(self, x: Any, xp: Any) -> Any:
        """V as an expression of the components ``x`` in namespace ``xp``."""
        raise NotImplementedError

    def gradient_expr(self, x: Any, xp: Any) -> list[Any]:
        """grad V as expressions of ``x`` in ``xp`` (default: exact sympy gradient of :meth:`expr`)."""
        from roa.lyapunov_general import symbolic_gradient

        return symbolic_gradient(self)(x, xp)

    # -- derived ---------------------------------------------------------------------------------
    def vdot_expr(self, system: System, x: Any, xp: Any) -> Any:
        """V' = grad V . f as an expression of ``x`` in ``xp``."""
        g = self.gradient_expr(x, xp)
        f = system.field(0.0, x, xp)
        out: Any = 0.0
        for i in range(self.n):
            out = g[i] * f[i] + out
        return out

    def symbolic(self, system: System, x: Any, xp: Any) -> tuple[Any, Any]:
        """``(V, V')`` as expressions of the components ``x`` in namespace ``xp`` (CasADi, sympy)."""
        return self.expr(x, xp), self.vdot_expr(system, x, xp)

    def value(self, x: np.ndarray) -> np.ndarray:
        """V on states of shape ``(..., n)`` (numpy)."""
        x = np.asarray(x, dtype=float)
        v = self.expr(_components(x, self.n, self.name), NP)
        return np.broadcast_to(np.asarray(v, dtype=float), x.shape[:-1]).copy()

    def gradient(self, x: np.ndarray) -> np.ndarray:
        """grad V on states of shape ``(..., n)``; returns ``(..., n)``."""
        x = np.asarray(x, dtype=float)
        g = self.gradient_expr(_components(x, self.n, self.name), NP)
        return np.stack([np.broadcast_to(np.asarray(gi, float), x.shape[:-1]) for gi in g], -1)

    def derivative(self, system: System, x: np.ndarray) -> np.ndarray:
        """V' = grad V . f on states of shape ``(..., n)`` (numpy)."""
        x = np.asarray(x, dtype=float)
        return np.einsum("...i,...i->...", self.gradient(x), system.f(x))

    def hessian_at_center(self) -> np.ndarray:
        """The Hessian of V at its centre (central differences of the gradient; exact overrides)."""
        n, c = self.n, np.asarray(self.center, dtype=float)
        h = 1e-5 * np.maximum(1.0, np.abs(c))
        H = np.empty((n, n))
        for j in range(n):
            e = np.zeros(n)
            e[j] = h[j]
            H[:, j] = (self.gradient(c + e) - self.gradient(c - e)) / (2 * h[j])
        return 0.5 * (H + H.T)

    def whitening(self) -> np.ndarray:
        """``M`` with ``x = c + M y`` making V ~ |y|^2 near the centre (identity if not definite)."""
        H = 0.5 * self.hessian_at_center()
        try:
            return np.linalg.inv(np.linalg.cholesky(H).T)
        except np.linalg.LinAlgError:
            return np.eye(self.n)

    def describe(self) -> dict[str, Any]:
        """A JSON-able description (what ``--json`` prints for the candidate)."""
        return {"lyapunov": self.name, "kind": type(self).__name__}


@dataclass(frozen=True)
class QuadraticLyapunov(Lyapunov):
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

    def gradient(self, x: np.ndarray) -> np.ndarray:
        d = np.asarray(x, dtype=float) - self.center
        return 2.0 * d @ self.P

    def derivative(self, system: System, x: np.ndarray) -> np.ndarray:
        """V' = grad V . f on states of shape ``(..., n)`` (numpy)."""
        d = np.asarray(x, dtype=float) - self.center
        return 2.0 * np.einsum("...i,ij,...j->...", d, self.P, system.f(x))

    def expr(self, x: Any, xp: Any) -> Any:
        d = [x[i] - float(self.center[i]) for i in range(self.n)]
        out: Any = 0.0
        for i in range(self.n):
            for j in range(self.n):
                if self.P[i, j] != 0.0:
                    out = d[i] * d[j] * float(self.P[i, j]) + out
        return out

    def gradient_expr(self, x: Any, xp: Any) -> list[Any]:
        d = [x[i] - float(self.center[i]) for i in range(self.n)]
        out = []
        for i in range(self.n):
            g: Any = 0.0
            for j in range(self.n):
                if self.P[i, j] != 0.0:
                    g = d[j] * float(self.P[i, j]) + g
            out.append(g * 2.0)
        return out

    def symbolic(self, system: System, x: Any, xp: Any) -> tuple[Any, Any]:
        """``(V, V')`` as expressions of the components ``x`` in namespace ``xp`` (CasADi, sympy)."""
        d = [x[i] - self.center[i] for i in range(self.n)]
        f = system.field(0.0, x, xp)
        Pd = [sum(self.P[i, j] * d[j] for j in range(self.n)) for i in range(self.n)]
        V = sum(d[i] * Pd[i] for i in range(self.n))
        Vd = 2 * sum(Pd[i] * f[i] for i in range(self.n))
        return V, Vd

    def hessian_at_center(self) -> np.ndarray:
        return 2.0 * self.P

    def whitening(self) -> np.ndarray:
        return np.linalg.inv(np.linalg.cholesky(self.P).T)

    def describe(self) -> dict[str, Any]:
        return {"lyapunov": self.name, "kind": "QuadraticLyapunov", "P": self.P.tolist()}


def as_lyapunov(system: System, V: Any = None) -> Lyapunov:
    """``V`` as a Lyapunov candidate of ``system``: ``None`` (the default candidate), any
    :class:`Lyapunov` (e.g. ``QuadraticLyapunov``, ``PolynomialLyapunov``, ``FunctionLyapunov``),
    or an n x n matrix ``P``."""
    if V is None:
        return default_lyapunov(system)
    if isinstance(V, Lyapunov):
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
    from roa.checks import check_system

    check_system(system)  # a malformed field or a false equilibrium: a clear error first
    if system.lyapunov is not None:
        return QuadraticLyapunov.for_system(system, system.lyapunov, name=f"{system.name} V")
    from roa.linearisation import lyapunov_matrix

    return QuadraticLyapunov.for_system(
        system, lyapunov_matrix(system), name="P from A'P + PA = -I"
    )


def __getattr__(name: str) -> Any:  # the general candidates live in roa.lyapunov_general
    if name in ("PolynomialLyapunov", "FunctionLyapunov"):
        import roa.lyapunov_general as g

        return getattr(g, name)
    raise AttributeError(name)
