"""The Lyapunov protocol: any ``V(x)`` written once against an array namespace.

:class:`Lyapunov` is what every candidate follows: ``expr(x, xp)`` writes ``V`` against the array
namespace ``xp`` (numpy, CasADi, sympy, the interval namespace and interval jets of
:mod:`roa.proof._interval`, mpmath), ``gradient_expr(x, xp)`` its gradient, and ``value`` /
``derivative`` evaluate them with numpy on rows of states. What a candidate can offer beyond that
is told by its methods, never by its class nor by testing its attributes:
:meth:`Lyapunov.quadratic_view` (V as a quadratic form ``d' P d``, else None),
:meth:`Lyapunov.polynomial_view` (the exponents and coefficients of a polynomial, else None),
:meth:`Lyapunov.gram_view` (a Gram matrix over a monomial basis, else None) and the predicates
built on them; code outside :mod:`roa.lyapunov` asks these, never ``P``, ``terms`` or ``gram``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from roa.errors import RoaInputError
from roa.model._backend import NP
from roa.model._system import System

if TYPE_CHECKING:
    from roa.lyapunov._polynomial import QuadraticLyapunov


#: The largest entry of a quadratic candidate's ``P`` must lie in ``[1 / MAX_SCALE, MAX_SCALE]``:
#: ``P`` scaled by it, and ``V`` on states and levels of moderate size, stay finite doubles.
MAX_SCALE = 1e150


def check_positive_definite(P: Any, *, what: str = "P") -> np.ndarray:
    """Return ``P`` as a symmetric float array; raise if not symmetric positive definite, or if
    its largest entry is outside ``[1 / MAX_SCALE, MAX_SCALE]`` (entries: :func:`roa.numparse.array`,
    finite doubles, none subnormal)."""
    from roa import numparse

    if not isinstance(P, np.ndarray):
        try:
            P = np.asarray(P, dtype=float)
        except (TypeError, ValueError, OverflowError):
            P = numparse.array(P, what)  # names the entry that is no finite number
    P = numparse.array(P, what)
    if P.ndim != 2 or P.shape[0] != P.shape[1]:
        raise RoaInputError(f"{what} must be a square matrix, got shape {P.shape}")
    scale = float(np.abs(P).max()) if P.size else 0.0
    if not 1 / MAX_SCALE <= scale <= MAX_SCALE:
        raise RoaInputError(
            f"{what}: its largest entry {scale:.3g} must be in [{1 / MAX_SCALE:g}, "
            f"{MAX_SCALE:g}] (scale P so that V and its programs stay finite)"
        )
    if not np.allclose(P, P.T, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(P).max())):
        raise RoaInputError(f"{what} must be symmetric")
    lam = np.linalg.eigvalsh(P)
    if lam[0] <= 0:
        raise RoaInputError(
            f"{what} is not positive definite (smallest eigenvalue {lam[0]:.3g} <= 0): "
            "a Lyapunov candidate must be positive definite"
        )
    return 0.5 * (P + P.T)


def center_vector(center: Any, n: int | None, what: str) -> np.ndarray:
    """``center`` as a vector of ``n`` finite floats (any ``n`` when None)."""
    c = np.asarray(center, dtype=float).reshape(-1)
    if (n is not None and c.shape[0] != n) or not np.all(np.isfinite(c)) or c.size == 0:
        raise RoaInputError(f"{what}: center must be {n or 'n'} finite numbers, got {center!r}")
    return c


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
    #: The matrix of ``V = (x - c)' P (x - c)`` when V is that quadratic form, else None.
    P: np.ndarray | None = None
    #: ``{exponents: coefficient}`` of a polynomial V in ``d = x - c``, else None.
    terms: dict[tuple[int, ...], float] | None = None
    #: The degree of a polynomial V, else None.
    degree: int | None = None
    #: ``(basis, Q)`` with ``V = m(d)' Q m(d)`` over the monomials ``basis``, else None.
    gram: tuple[list[tuple[int, ...]], np.ndarray] | None = None

    # -- capabilities: what this V offers beyond its expressions -----------------------------------
    def quadratic_view(self) -> QuadraticLyapunov | None:
        """This V as a :class:`~roa.lyapunov.QuadraticLyapunov` (its matrix ``P`` and closed-form
        paths) when it is one, else None."""
        return None

    @property
    def is_quadratic(self) -> bool:
        """Whether :meth:`quadratic_view` gives V as a quadratic form ``d' P d``."""
        return self.quadratic_view() is not None

    def quadratic_matrix(self) -> np.ndarray | None:
        """``P`` of ``V = (x - c)' P (x - c)`` when V is that quadratic form, else None."""
        q = self.quadratic_view()
        return None if q is None else q.P

    def ellipsoid_matrix(self) -> np.ndarray | None:
        """``P`` when V is ``x' P x`` (a quadratic form centred at the origin), else None."""
        q = self.quadratic_view()
        return None if q is None or np.asarray(q.center).any() else q.P

    def polynomial_view(self) -> dict[tuple[int, ...], Any] | None:
        """``{exponents: coefficient}`` of V as a polynomial in ``d = x - center`` (floats, or
        exact rationals of a whitened V), else None."""
        return self.terms

    @property
    def is_polynomial(self) -> bool:
        """Whether :meth:`polynomial_view` gives V's terms."""
        return self.polynomial_view() is not None

    def gram_view(self) -> tuple[list[tuple[int, ...]], np.ndarray] | None:
        """``(basis, Q)`` with ``V = m(d)' Q m(d)`` over the monomial ``basis``, else None."""
        return self.gram

    def with_gram(self, gram: tuple[list[tuple[int, ...]], np.ndarray] | None) -> None:
        """Attach (or with None remove) a Gram matrix ``(basis, Q)`` of this polynomial V; the
        caller proves it (:func:`roa.proof.gram_cover`) before relying on it."""
        if self.polynomial_view() is None:
            raise RoaInputError(f"V {self.name!r} is not polynomial: no Gram matrix to attach")
        self.gram = gram

    def unwhitened(self) -> tuple[Lyapunov, System, np.ndarray] | None:
        """``(V, system, M)`` when this candidate is ``W(y) = V(c + M y)`` written in a whitened
        frame of ``system`` (:class:`roa.proof.Whitened`), else None."""
        return None

    def has_exact_description(self) -> bool:
        """Whether :meth:`describe` determines V exactly (a quadratic or polynomial V; not a
        function V, whose code it does not hold)."""
        return self.is_quadratic or self.is_polynomial

    @property
    def n(self) -> int:
        return int(np.asarray(self.center).shape[0])

    # -- to be written by each candidate ---------------------------------------------------------
    def expr(self, x: Any, xp: Any) -> Any:
        """V as an expression of the components ``x`` in namespace ``xp``."""
        raise NotImplementedError

    def gradient_expr(self, x: Any, xp: Any) -> list[Any]:
        """grad V as expressions of ``x`` in ``xp`` (default: exact sympy gradient of :meth:`expr`)."""
        from roa.lyapunov._symbolic import symbolic_gradient

        return symbolic_gradient(self)(x, xp)

    # -- derived ---------------------------------------------------------------------------------
    def vdot_expr(self, system: System, x: Any, xp: Any) -> Any:
        """The decrease of V along the system as an expression of ``x`` in ``xp``:
        ``V' = grad V · f``, or ``V(F(x)) - V(x)`` for a discrete-time system
        (:meth:`roa.System.decrease_expr`)."""
        return system.decrease_expr(self, x, xp)

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
        """The decrease of V on states of shape ``(..., n)`` (numpy): ``V' = grad V · f``, or
        ``V(F(x)) - V(x)`` for a discrete-time system (:meth:`roa.System.decrease`)."""
        return system.decrease(self, x)

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
        """``M`` with ``x = c + M y`` making ``V ~ |y|^2`` near the centre (identity if not definite)."""
        H = 0.5 * self.hessian_at_center()
        try:
            return np.linalg.inv(np.linalg.cholesky(H).T)
        except np.linalg.LinAlgError:
            return np.eye(self.n)

    def describe(self) -> dict[str, Any]:
        """A JSON-able description (what ``--json`` prints for the candidate)."""
        return {"lyapunov": self.name, "kind": type(self).__name__}
