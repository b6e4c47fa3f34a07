"""Polynomial Lyapunov candidates; the quadratic V is the degree-2 polynomial.

* :class:`PolynomialLyapunov`: ``V = sum_k c_k d^a_k`` with ``d = x - x_eq``, from exponent tuples
  and coefficients, or from a Gram matrix over a monomial basis (``V = m(d)' Q m(d)``).
* :class:`QuadraticLyapunov`: ``V = d' P d``, the polynomial of degree 2 whose Gram matrix over the
  linear monomials is ``P``; it keeps closed-form numpy paths (value, gradient, V') as overrides
  and exposes ``P``, which the quadratic fast paths (SOS level, whitened validation, ellipsoid
  terminal sets) take.

Both run on every namespace of :mod:`roa.model._backend` and on the interval namespace and jets of
:mod:`roa.proof._interval`.
"""

from __future__ import annotations

import itertools
from fractions import Fraction
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov._base import Lyapunov, center_vector, check_positive_definite
from roa.model._system import System

#: Largest total degree of a term of a polynomial V (higher ones are refused before any work).
MAX_DEGREE = 40
#: Most terms of a polynomial V.
MAX_TERMS = 100_000


class PolynomialLyapunov(Lyapunov):
    """``V(x) = sum_k coefficients[k] * prod_i d_i^monomials[k][i]``, ``d = x - center``.

    Every term has degree >= 2 (``V(center) = 0``, ``grad V(center) = 0``) and the largest degree
    is even. :meth:`from_gram` builds ``V = m(d)' Q m(d)`` over a monomial basis ``m``; with
    ``Q`` positive definite and the linear monomials in ``m``, the validation proves
    ``V >= lambda |d|^2`` (so every sublevel set is bounded) from ``Q`` in exact arithmetic.

    Examples
    --------
    >>> from roa.lyapunov import PolynomialLyapunov
    >>> V = PolynomialLyapunov([[2], [4]], [1.0, 1.0], center=[0.0])
    >>> float(V.value([[1.0]])[0]), V.degree
    (2.0, 4)
    """

    terms: dict[tuple[int, ...], float]
    degree: int

    def __init__(
        self, monomials: Any, coefficients: Any, center: Any, name: str = "polynomial V"
    ) -> None:
        try:
            a = np.asarray(monomials, dtype=float)
        except (TypeError, ValueError):
            raise RoaInputError("monomials must be a list of exponent tuples") from None
        if a.ndim != 2 or a.shape[0] == 0:
            raise RoaInputError(
                f"monomials must be a non-empty list of tuples, got shape {a.shape}"
            )
        if not np.all((a >= 0) & (a == np.round(a))):
            raise RoaInputError("monomials: exponents must be non-negative integers")
        if a.shape[0] > MAX_TERMS:
            raise RoaInputError(
                f"monomials: at most {MAX_TERMS} terms, got {a.shape[0]} (allowed range 1 to "
                f"{MAX_TERMS})"
            )
        top = float(a.sum(axis=1).max())
        if top > MAX_DEGREE:
            raise RoaInputError(
                f"monomials: the degree of a term must be at most {MAX_DEGREE}, got {top:.6g}"
            )
        try:
            c = np.asarray(coefficients, dtype=float).reshape(-1)
        except (TypeError, ValueError, OverflowError):
            raise RoaInputError("coefficients must be a list of finite numbers") from None
        if c.shape[0] != a.shape[0]:
            raise RoaInputError(
                f"coefficients must have one number per monomial ({a.shape[0]}), got {c.shape[0]}"
            )
        if not np.all(np.isfinite(c)):
            raise RoaInputError("coefficients must be finite")
        self.center = center_vector(center, a.shape[1], "PolynomialLyapunov")
        self.name = str(name)
        terms: dict[tuple[int, ...], float] = {}
        for row, cf in zip(a.astype(int), c, strict=True):
            key = tuple(int(v) for v in row)
            terms[key] = terms.get(key, 0.0) + float(cf)
        terms = {k: v for k, v in terms.items() if v != 0.0}
        if not terms:
            raise RoaInputError("coefficients: all zero (V = 0 is no Lyapunov candidate)")
        low = [k for k in terms if sum(k) < 2]
        if low:
            raise RoaInputError(
                f"monomials: every term must have degree >= 2 (V(x_eq) = 0 and grad V(x_eq) = 0), "
                f"got {low[0]}"
            )
        self.degree = max(sum(k) for k in terms)
        if self.degree % 2:
            raise RoaInputError(f"monomials: the largest degree must be even, got {self.degree}")
        self.terms = terms
        self.gram = None

    @classmethod
    def from_gram(
        cls, basis: Any, Q: Any, center: Any, name: str = "polynomial V (Gram)"
    ) -> PolynomialLyapunov:
        """``V = m(d)' Q m(d)`` with ``m`` the monomials ``basis`` (exponent tuples) and ``Q``
        symmetric (positive definite for a proved lower bound)."""
        B = [tuple(int(v) for v in b) for b in np.asarray(basis, dtype=int).reshape(len(basis), -1)]
        Q = np.asarray(Q, dtype=float)
        if Q.shape != (len(B), len(B)) or not np.all(np.isfinite(Q)):
            raise RoaInputError(f"Q must be a finite {len(B)}x{len(B)} matrix, got {Q.shape}")
        if not np.allclose(Q, Q.T, rtol=0, atol=1e-12 * max(1.0, np.abs(Q).max())):
            raise RoaInputError("Q must be symmetric")
        if any(sum(b) < 1 for b in B):
            raise RoaInputError("basis: every monomial must have degree >= 1")
        terms: dict[tuple[int, ...], Fraction] = {}
        for (i, bi), (j, bj) in itertools.product(enumerate(B), enumerate(B)):
            key = tuple(p + q for p, q in zip(bi, bj, strict=True))
            terms[key] = terms.get(key, Fraction(0)) + Fraction(float(Q[i, j]))
        keys = list(terms)
        V = cls(keys, [float(terms[k]) for k in keys], center, name)
        V.gram = (B, 0.5 * (Q + Q.T))
        return V

    @property
    def monomials(self) -> list[tuple[int, ...]]:
        return list(self.terms)

    @property
    def coefficients(self) -> list[float]:
        return list(self.terms.values())

    def _d(self, x: Any) -> list[Any]:
        return [x[i] - float(self.center[i]) for i in range(self.n)]

    @staticmethod
    def _mono(d: list[Any], a: tuple[int, ...], memo: dict[Any, Any] | None = None) -> Any:
        """``prod_i d_i^a_i`` multiplied left to right (``d_i^k`` by ``**``, tight for intervals).

        ``memo`` shares the powers and the left-to-right partial products between the monomials of
        one evaluation (the same operations in the same order, so the same numbers and
        enclosures, computed once).
        """
        if memo is None:
            memo = {}
        if a in memo:
            return memo[a]
        last = max((i for i, k in enumerate(a) if k), default=-1)
        if last < 0:
            return 1.0
        k = a[last]
        key = ("power", last, k)
        if key not in memo:
            memo[key] = d[last] ** k if k > 1 else d[last]
        p = memo[key]
        head = tuple(v if i < last else 0 for i, v in enumerate(a))
        out = p if not any(head) else PolynomialLyapunov._mono(d, head, memo) * p
        memo[a] = out
        return out

    def expr(self, x: Any, xp: Any) -> Any:
        d = self._d(x)
        out: Any = 0.0
        memo: dict[Any, Any] = {}
        for a, c in self.terms.items():
            out = self._mono(d, a, memo) * c + out
        return out

    def gradient_expr(self, x: Any, xp: Any) -> list[Any]:
        d = self._d(x)
        grads = []
        memo: dict[Any, Any] = {}
        for i in range(self.n):
            g: Any = 0.0
            for a, c in self.terms.items():
                if a[i]:
                    b = tuple(k - (j == i) for j, k in enumerate(a))
                    term = self._mono(d, b, memo) * c
                    g = (term * a[i] if a[i] > 1 else term) + g
            grads.append(g)
        return grads

    def hessian_at_center(self) -> np.ndarray:
        H = np.zeros((self.n, self.n))
        for a, c in self.terms.items():
            if sum(a) == 2:
                idx = [i for i, k in enumerate(a) for _ in range(k)]
                i, j = idx
                if i == j:
                    H[i, i] += 2 * c
                else:
                    H[i, j] += c
                    H[j, i] += c
        return H

    def describe(self) -> dict[str, Any]:
        """V's JSON form; with its Gram matrix, when it has one (so that a stored certificate's V
        is proved bounded again, :func:`roa.proof.gram_cover`, without a solver)."""
        out: dict[str, Any] = {
            "lyapunov": self.name,
            "kind": "PolynomialLyapunov",
            "degree": self.degree,
            "monomials": [list(a) for a in self.terms],
            "coefficients": self.coefficients,
        }
        if self.gram is not None:
            basis, Q = self.gram
            out["gram"] = {"basis": [list(b) for b in basis], "Q": np.asarray(Q).tolist()}
        return out

    def __repr__(self) -> str:
        return f"PolynomialLyapunov({self.name!r}, degree {self.degree}, {len(self.terms)} terms)"


class QuadraticLyapunov(PolynomialLyapunov):
    """``V(x) = (x - center)' P (x - center)``: the polynomial of degree 2 whose Gram matrix over
    the linear monomials ``d_1, ..., d_n`` is ``P`` (symmetric positive definite).

    It is a :class:`PolynomialLyapunov` (its ``terms``, ``degree`` and ``gram`` are those of the
    polynomial) with closed-form overrides of the numpy paths and of its expressions, and ``P``.

    Examples
    --------
    >>> from roa.lyapunov import QuadraticLyapunov
    >>> V = QuadraticLyapunov([[2.0, 0.5], [0.5, 1.0]], [0.0, 0.0])
    >>> V.degree, V.terms
    (2, {(2, 0): 2.0, (1, 1): 1.0, (0, 2): 1.0})
    """

    P: np.ndarray

    def quadratic_view(self) -> QuadraticLyapunov:
        return self

    def __init__(self, P: Any, center: Any, name: str = "V") -> None:
        P = check_positive_definite(P, what=f"{name}.P")
        n = P.shape[0]
        c = np.asarray(center, dtype=float).reshape(-1)
        if c.shape[0] != n:
            raise RoaInputError(f"{name}.center must have {n} components")
        monomials, coefficients = [], []
        for i in range(n):
            for j in range(i, n):
                e = [0] * n
                e[i] += 1
                e[j] += 1
                monomials.append(e)
                coefficients.append(P[i, i] if i == j else 2.0 * P[i, j])
        super().__init__(monomials, coefficients, c, name)
        P.setflags(write=False)
        self.P = P
        self.gram = ([tuple(int(i == j) for j in range(n)) for i in range(n)], P)

    @classmethod
    def for_system(cls, system: System, P: Any, name: str = "V") -> QuadraticLyapunov:
        from roa import numparse

        P = numparse.array(P, f"V {name}: P")
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
        """V' = grad V . f on states of shape ``(..., n)`` (numpy; ``V(F(x)) - V(x)`` for a
        discrete-time system)."""
        if system.time == "discrete":
            return system.decrease(self, x)
        d = np.asarray(x, dtype=float) - self.center
        return 2.0 * np.sum((d @ self.P) * system.f(x), axis=-1)

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
        if system.time == "discrete":
            return self.expr(x, xp), system.decrease_expr(self, x, xp)
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

    def __repr__(self) -> str:
        return f"QuadraticLyapunov({self.name!r}, P={self.P.tolist()!r}, center={self.center.tolist()!r})"
