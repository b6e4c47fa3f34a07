"""Lyapunov candidates beyond quadratic: polynomials of even degree and any user function.

* :class:`PolynomialLyapunov`: ``V = sum_k c_k d^a_k`` with ``d = x - x_eq``, from exponent tuples
  and coefficients, or from a Gram matrix over a monomial basis (``V = m(d)' Q m(d)``).
* :class:`FunctionLyapunov`: any ``V(x, xp)`` written against the array namespace (like a system's
  field), with its gradient derived exactly by sympy (float constants taken as exact rationals).

Both run on every namespace of :mod:`roa.backend` and on the interval namespace and jets of
:mod:`roa.proof.interval`, so the level search and the interval validation accept them.
"""

from __future__ import annotations

import itertools
from fractions import Fraction
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov

_EXACT = ("interval", "interval-jet")


def _const(p: int, q: int, xp: Any) -> Any:
    """The rational p/q as a constant of namespace ``xp`` (enclosed, or at working precision)."""
    name = getattr(xp, "name", "")
    if q == 1:
        return float(p) if abs(p) <= 2**53 and name != "mpmath" else _big(p, xp)
    if name in _EXACT:
        return Fraction(p, q)
    if name == "mpmath":
        import mpmath as mp

        return mp.mpf(p) / q
    return p / q


def _big(p: int, xp: Any) -> Any:
    if getattr(xp, "name", "") in _EXACT:
        return Fraction(p)
    if getattr(xp, "name", "") == "mpmath":
        import mpmath as mp

        return mp.mpf(p)
    return float(p)


_FUNCS = {
    "sin": "sin",
    "cos": "cos",
    "tan": "tan",
    "exp": "exp",
    "log": "log",
    "atan": "arctan",
    "asinh": "arcsinh",
    "atanh": "arctanh",
    "Abs": "abs",
}


def sympy_eval(e: Any, env: dict[Any, Any], xp: Any) -> Any:
    """Evaluate a sympy expression (exact rationals, the functions of :mod:`roa.backend`) in ``xp``."""
    import sympy as sp

    if e.is_Symbol:
        return env[e]
    if e.is_Rational:
        return _const(int(e.p), int(e.q), xp)
    if e.is_Add:
        out: Any = 0.0
        for a in e.args:
            out = sympy_eval(a, env, xp) + out
        return out
    if e.is_Mul:
        num = [a for a in e.args if a.is_Rational]
        out = None
        for a in e.args:
            if not a.is_Rational:
                v = sympy_eval(a, env, xp)
                out = v if out is None else out * v
        for a in num:
            c = sympy_eval(a, env, xp)
            out = c if out is None else out * c
        return out
    if e.is_Pow:
        b, k = e.args
        base = sympy_eval(b, env, xp)
        if k.is_Integer:
            return base ** int(k) if int(k) > 0 else 1.0 / base ** (-int(k))
        if k.is_Rational and int(k.q) == 2:
            r = xp.sqrt(base)
            p = int(k.p)
            return r**p if p > 0 else 1.0 / r ** (-p)
        raise RoaInputError(f"V: unsupported power {e} (integer and half-integer powers only)")
    if isinstance(e, sp.Function) and type(e).__name__ in _FUNCS:
        return getattr(xp, _FUNCS[type(e).__name__])(sympy_eval(e.args[0], env, xp))
    if e.is_Number:  # an irrational sympy number (pi, E, ...)
        raise RoaInputError(f"V: unsupported constant {e} (write it as a float)")
    raise RoaInputError(f"V: unsupported expression {type(e).__name__} {e}")


def _exact(expr: Any) -> Any:
    """``expr`` with every float replaced by the exact rational of the double."""
    import sympy as sp

    return expr.xreplace({f: sp.Rational(f) for f in expr.atoms(sp.Float)})


def symbolic_gradient(lyap: Lyapunov) -> Any:
    """A function ``(x, xp) -> [dV/dx_i]`` from an exact sympy differentiation of ``lyap.expr``."""
    cached = getattr(lyap, "_gradient_cache", None)
    if cached is not None:
        return cached
    import sympy as sp

    from roa.backend import namespace

    xs = sp.symbols(f"x0:{lyap.n}", real=True)
    try:
        V = _exact(sp.sympify(lyap.expr(list(xs), namespace("sympy"))))
    except (TypeError, ValueError, AttributeError) as exc:
        raise RoaInputError(
            f"V {lyap.name!r} must be written against the array namespace xp (sympy failed: {exc})"
        ) from None
    grads = [sp.diff(V, s) for s in xs]
    if any(g.has(sp.sign, sp.Heaviside, sp.DiracDelta, sp.Derivative) for g in grads):
        raise RoaInputError(f"V {lyap.name!r} is not differentiable (abs or a kink): no gradient")

    def fn(x: Any, xp: Any) -> list[Any]:
        env = dict(zip(xs, [x[i] for i in range(lyap.n)], strict=True))
        return [sympy_eval(g, env, xp) for g in grads]

    object.__setattr__(lyap, "_gradient_cache", fn)
    return fn


def _center(center: Any, n: int | None, what: str) -> np.ndarray:
    c = np.asarray(center, dtype=float).reshape(-1)
    if (n is not None and c.shape[0] != n) or not np.all(np.isfinite(c)) or c.size == 0:
        raise RoaInputError(f"{what}: center must be {n or 'n'} finite numbers, got {center!r}")
    return c


class PolynomialLyapunov(Lyapunov):
    """``V(x) = sum_k coefficients[k] * prod_i d_i^monomials[k][i]``, ``d = x - center``.

    Every term has degree >= 2 (``V(center) = 0``, ``grad V(center) = 0``) and the largest degree
    is even. :meth:`from_gram` builds ``V = m(d)' Q m(d)`` over a monomial basis ``m``; with
    ``Q`` positive definite and the linear monomials in ``m``, the validation proves
    ``V >= lambda |d|^2`` (so every sublevel set is bounded) from ``Q`` in exact arithmetic.

    Examples
    --------
    >>> from roa.lyapunov_general import PolynomialLyapunov
    >>> V = PolynomialLyapunov([[2], [4]], [1.0, 1.0], center=[0.0])
    >>> float(V.value([[1.0]])[0]), V.degree
    (2.0, 4)
    """

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
        c = np.asarray(coefficients, dtype=float).reshape(-1)
        if c.shape[0] != a.shape[0]:
            raise RoaInputError(
                f"coefficients must have one number per monomial ({a.shape[0]}), got {c.shape[0]}"
            )
        if not np.all(np.isfinite(c)):
            raise RoaInputError("coefficients must be finite")
        self.center = _center(center, a.shape[1], "PolynomialLyapunov")
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
        self.gram: tuple[list[tuple[int, ...]], np.ndarray] | None = None

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
        return {
            "lyapunov": self.name,
            "kind": "PolynomialLyapunov",
            "degree": self.degree,
            "monomials": [list(a) for a in self.terms],
            "coefficients": self.coefficients,
        }

    def __repr__(self) -> str:
        return f"PolynomialLyapunov({self.name!r}, degree {self.degree}, {len(self.terms)} terms)"


class FunctionLyapunov(Lyapunov):
    """Any candidate ``V = func(x, xp)`` written against the array namespace ``xp``.

    ``func`` must use only the functions of :mod:`roa.backend` (``xp.log``, ``xp.sqrt``, ...) so
    that it runs on numpy, CasADi, sympy (its gradient is derived exactly) and intervals. It must
    vanish at ``center`` with a zero gradient there.

    Examples
    --------
    >>> from roa.lyapunov_general import FunctionLyapunov
    >>> V = FunctionLyapunov(lambda x, xp: xp.log(1 + x[0] ** 2 + x[1] ** 2), [0.0, 0.0], "log V")
    >>> round(float(V.value([[1.0, 0.0]])[0]), 6)
    0.693147
    """

    def __init__(self, func: Any, center: Any, name: str = "V") -> None:
        if not callable(func):
            raise RoaInputError(f"func must be callable V(x, xp), got {type(func).__name__}")
        self.func = func
        self.center = _center(center, None, "FunctionLyapunov")
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
