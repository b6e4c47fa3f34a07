"""Validation in whitened coordinates: boxes in ``y`` with ``x = x_eq + M y`` (``V ~ |y|^2``).

A candidate whose Hessian at the equilibrium is badly conditioned (the IPC's flat V: condition
number ~ 10^3) makes axis-aligned boxes in ``x`` a poor fit for its level sets. The branch and bound
of :mod:`roa.proof._validate` then runs on boxes in ``y`` instead: :class:`Whitened` is the
candidate ``W(y) = V(x_eq + M y)`` and :func:`whitened_system` the system seen through the same
map. ``x(y)`` is evaluated in the namespace at hand (interval, jet, mpmath), so every enclosure is
of the exact composition, and the derivative proved negative is ``V'(x(y)) = grad V(x) . f(x)`` at
``x = x(y)``, the same number in both coordinates (the map is linear and one-to-one: ``{W <= c}``
is the image of ``{V <= c}``). Nothing depends on ``M`` being accurate: any invertible ``M`` gives
a valid proof, a good one only fewer boxes.

**Expanded polynomials** (a :class:`~roa.lyapunov.PolynomialLyapunov` base): evaluating
``V(c + M y)`` through ``x`` loses the correlation of the ``x_i`` (each is a linear form in the
same ``y``) and a badly conditioned ``V`` cancels large terms, so its interval enclosures on a
``y``-box are wide (the IPC's degree-4 V: Hessian enclosures of ``V'`` ~27x the true range on the
boxes the branch and bound splits most). :class:`Expanded` therefore writes, in exact rational
arithmetic (the float coefficients of V and the float entries of ``M`` taken exactly, Python
:class:`~fractions.Fraction`, nothing rounded):

* ``W(y) = V(c + M y)`` and ``dW/dy_j`` as polynomials in ``y``;
* ``G_i(y) = dV/dx_i (c + M y)``, so that ``W' = sum_i G_i(y) f_i(c + M y)`` (the same number as
  ``grad V . f`` at ``x = c + M y``: the identity is exact);
* for each component ``f_i`` that is **affine** (its second-order jet over the whole space
  ``[-inf, inf]^n`` has only exact-zero Hessian entries, the symbolic zeros of
  :mod:`roa.proof._jet`; a kink or any nonlinear operation on a variable leaves a nonzero entry):
  ``f_i(x) = f_i(c) + sum_j a_ij (x_j - c_j)`` with ``a_ij`` in the jet's gradient enclosure and
  ``f_i(c)`` in the interval value at the point ``c``, so ``G_i(y) f_i(c + M y)`` is a polynomial
  in ``y`` whose coefficients are enclosed (interval products of the exact ones); the affine
  components are summed into one polynomial ``P(y)``, the others stay ``G_i(y) f_i(x(y))``.

Intervals and jets (:data:`~roa.proof.INTERVAL`, :data:`~roa.proof.JET`) evaluate
these polynomials in monomials of ``y`` with each coefficient a double when it is exactly one,
else its outward enclosure, so every enclosure is one of the exact ``V(c + M y)``, its gradient and
``V'`` (on the IPC's boxes: V 3.8x and V' 2.4x tighter, Hessians of V' 2-11x). numpy uses the
nearest doubles (float values steer the search only); every other namespace (mpmath for the
50-digit re-checks, sympy) evaluates the composition through ``x`` as before.
"""

from __future__ import annotations

import itertools
from fractions import Fraction
from typing import Any, cast

import numpy as np

from roa.lyapunov import Lyapunov
from roa.model._system import System
from roa.proof._interval import Interval

_FAST = ("numpy", "interval", "interval-jet")  # namespaces that use the expanded polynomials
Coef = Fraction | Interval


class Polynomial:
    """``sum_k q_k y^a_k`` with exact rational coefficients (Fractions) or scalar enclosures
    (Intervals) of them; built by exact arithmetic, evaluated in a namespace (module doc)."""

    def __init__(self, n: int, terms: dict[tuple[int, ...], Coef] | None = None) -> None:
        self.n = n
        self.coefs = {a: q for a, q in (terms or {}).items() if not _is_zero(q)}
        self._ready: dict[bool, list[tuple[tuple[int, ...], Any]]] = {}

    @classmethod
    def linear(cls, coefs: list[Coef], const: Coef = Fraction(0)) -> Polynomial:
        n = len(coefs)
        terms: dict[tuple[int, ...], Coef] = {(0,) * n: const}
        for j, q in enumerate(coefs):
            terms[tuple(int(i == j) for i in range(n))] = q
        return cls(n, terms)

    def __add__(self, other: Polynomial) -> Polynomial:
        out = dict(self.coefs)
        for a, q in other.coefs.items():
            out[a] = _add(out[a], q) if a in out else q
        return Polynomial(self.n, out)

    def __mul__(self, other: Polynomial) -> Polynomial:
        out: dict[tuple[int, ...], Coef] = {}
        for (a, p), (b, q) in itertools.product(self.coefs.items(), other.coefs.items()):
            key = tuple(i + j for i, j in zip(a, b, strict=True))
            pq = _mul(p, q)
            out[key] = _add(out[key], pq) if key in out else pq
        return Polynomial(self.n, out)

    def scaled(self, q: Coef) -> Polynomial:
        return Polynomial(self.n, {a: _mul(p, q) for a, p in self.coefs.items()})

    def diff(self, j: int) -> Polynomial:
        out: dict[tuple[int, ...], Coef] = {}
        for a, q in self.coefs.items():
            if a[j]:
                b = tuple(k - (i == j) for i, k in enumerate(a))
                out[b] = _mul(q, Fraction(a[j]))
        return Polynomial(self.n, out)

    def _coefficients(self, exact: bool) -> list[tuple[tuple[int, ...], Any]]:
        """The terms with each coefficient as evaluated: a double when it is exactly one, else its
        enclosure (``exact``, intervals and jets) or the nearest double (numpy)."""
        if exact not in self._ready:
            out = []
            for a, q in self.coefs.items():
                if isinstance(q, Interval):
                    lo, hi = float(q.lo), float(q.hi)
                    c: Any = lo if lo == hi else (q if exact else 0.5 * (lo + hi))
                else:
                    f = float(q)
                    c = f if Fraction(f) == q or not exact else Interval.of(q)
                out.append((a, c))
            self._ready[exact] = out
        return self._ready[exact]

    def __call__(self, y: Any, xp: Any, memo: dict[Any, Any] | None = None) -> Any:
        """The polynomial at the components ``y`` (``memo`` shares monomials between calls)."""
        from roa.lyapunov import PolynomialLyapunov

        exact = getattr(xp, "name", "") != "numpy"
        memo = {} if memo is None else memo
        out: Any = 0.0
        for a, c in self._coefficients(exact):
            out = (PolynomialLyapunov._mono(y, a, memo) * c if any(a) else 0.0 * y[0] + c) + out
        return out


def _is_zero(q: Coef) -> bool:
    if isinstance(q, Interval):
        return bool(q.lo == 0.0 and q.hi == 0.0)
    return q == 0


def _add(p: Coef, q: Coef) -> Coef:
    if isinstance(p, Fraction) and isinstance(q, Fraction):
        return p + q
    return Interval.of(p) + Interval.of(q)


def _mul(p: Coef, q: Coef) -> Coef:
    if isinstance(p, Fraction) and isinstance(q, Fraction):
        return p * q
    return Interval.of(p) * Interval.of(q)


class Expanded:
    """The polynomials of the module doc for ``V``, ``M`` and (optionally) a system."""

    def __init__(self, base: Any, system: System | None, M: np.ndarray) -> None:
        n = base.n
        Mq = [[Fraction(float(M[i, j])) for j in range(n)] for i in range(n)]
        d = [Polynomial.linear([Mq[i][j] for j in range(n)]) for i in range(n)]  # x - c = M y
        powers: dict[tuple[int, int], Polynomial] = {}

        def power(i: int, k: int) -> Polynomial:
            if (i, k) not in powers:
                powers[i, k] = d[i] if k == 1 else power(i, k - 1) * d[i]
            return powers[i, k]

        def compose(terms: dict[tuple[int, ...], Fraction]) -> Polynomial:
            out = Polynomial(n)
            for a, q in terms.items():
                t = Polynomial(n, {(0,) * n: q})
                for i, k in enumerate(a):
                    if k:
                        t = t * power(i, k)
                out = out + t
            return out

        terms = {a: Fraction(float(q)) for a, q in (base.polynomial_view() or {}).items()}
        self.compose = compose
        self.W = compose(terms)
        self.dW = [self.W.diff(j) for j in range(n)]
        self.affine: Polynomial | None = None
        self.rest: list[tuple[int, Polynomial]] = []
        if system is None:
            return
        G = []
        for i in range(n):  # dV/dx_i as exact terms, then at x = c + M y
            gi: dict[tuple[int, ...], Fraction] = {}
            for a, q in terms.items():
                if a[i]:
                    b = tuple(k - (j == i) for j, k in enumerate(a))
                    gi[b] = gi.get(b, Fraction(0)) + q * a[i]
            G.append(compose(gi))
        affine = affine_components(system, base.center)
        P = Polynomial(n)
        for i in range(n):
            if i in affine:
                const, a = affine[i]
                coefs = [_sum_products([a[j] for j in range(n)], [Mq[j][k] for j in range(n)])
                         for k in range(n)]  # fmt: skip
                P = P + G[i] * Polynomial.linear(coefs, const)
            else:
                self.rest.append((i, G[i]))
        self.affine = P


def _sum_products(a: list[Any], m: list[Fraction]) -> Coef:
    """``sum_j a_j m_j`` with ``a_j`` enclosed (float or Interval) and ``m_j`` exact."""
    out: Coef = Fraction(0)
    for aj, mj in zip(a, m, strict=True):
        if mj == 0:
            continue
        term = Fraction(aj) * mj if type(aj) is float else _mul(Interval.of(aj), mj)
        out = _add(out, term)
    return out


def affine_components(system: System, center: np.ndarray) -> dict[int, tuple[Coef, list[Any]]]:
    """``{i: (f_i(c), [a_i1, ..])}`` for the components of the field proved affine (module doc):
    ``f_i(c)`` an enclosure, ``a_ij`` the gradient enclosures of the jet over ``[-inf, inf]^n``."""
    from roa.proof._interval import INTERVAL
    from roa.proof._jet import Jet
    from roa.proof._jet_net import JET

    n = len(center)
    try:
        inf = np.full((1, n), np.inf)
        with np.errstate(all="ignore"):
            f = system.field(0.0, Jet.variables(-inf, inf, order=2, centred=False), JET)
            c = np.asarray(center, dtype=float)
            fc = system.field(0.0, [Interval(np.array([v])) for v in c], INTERVAL)
    except (ArithmeticError, ValueError, TypeError):
        return {}
    out: dict[int, tuple[Coef, list[Any]]] = {}
    for i, fi in enumerate(f):
        if isinstance(fi, Jet):
            if fi.h is None or not all(type(e) is float and e == 0.0 for r in fi.h for e in r):
                continue  # a nonzero Hessian entry somewhere: not proved affine
            grads = [_scalar(g) for g in fi.g]
        elif type(fi) is float:
            grads = [0.0] * n  # a constant component
        else:
            continue
        v = Interval.of(fc[i])
        lo, hi = float(np.ravel(v.lo)[0]), float(np.ravel(v.hi)[0])
        if any(g is None for g in grads) or not (np.isfinite(lo) and np.isfinite(hi)):
            continue
        out[i] = (Fraction(lo) if lo == hi else Interval(lo, hi), grads)
    return out


def _scalar(g: Any) -> Any:
    """A gradient entry of an affine jet as a float or a finite scalar Interval (None if not)."""
    if type(g) is float:
        return g if np.isfinite(g) else None
    iv = Interval.of(g)
    lo, hi = np.ravel(iv.lo), np.ravel(iv.hi)
    if lo.size != 1 or not (np.isfinite(lo[0]) and np.isfinite(hi[0])):
        return None
    return float(lo[0]) if lo[0] == hi[0] else Interval(lo[0], hi[0])


class Whitened(Lyapunov):
    """``W(y) = V(c + M y)`` with ``W' = grad V · f`` evaluated at ``x = c + M y``."""

    def __init__(self, base: Lyapunov, system: System, M: np.ndarray) -> None:

        self.base, self.system = base, system
        self.M = np.asarray(M, dtype=float)
        self.c = np.asarray(base.center, dtype=float)
        self.center = np.zeros(base.n)
        self.name = f"{base.name} (whitened)"
        #: the exact polynomials in ``y`` (module doc), or None (the composition through ``x``)
        # the affine-field expansion of W' is for a flow; a map's W(F) - W goes through x
        flow = system if system is not None and system.time == "continuous" else None
        self.expanded = Expanded(base, flow, self.M) if base.is_polynomial else None
        #: ``(basis, T' Q T)`` and the exact coefficients of ``W`` for a global cover
        #: (:func:`roa.proof.gram_cover`), when V has a Gram matrix ``Q`` over a basis
        #: ``m`` with ``m(M y) = T m(y)`` (each degree's monomials all in it, e.g. quadratic V)
        #: Only for a quadratic V: for a higher degree the Gram bound's cube is far larger than
        #: the level set, and the box found along rays (proved on its faces) is the cover
        quadratic = base.degree == 2
        self.gram = (
            _gram_in_y(base, self.expanded) if quadratic and self.expanded is not None else None
        )
        exact = None if self.gram is None or self.expanded is None else self.expanded.W.coefs
        self.terms = None if exact is None else cast(dict[tuple[int, ...], float], dict(exact))

    def unwhitened(self) -> tuple[Lyapunov, System, np.ndarray]:
        return self.base, self.system, self.M

    def x_of(self, y: Any) -> list[Any]:
        """``x = c + M y`` in the namespace of ``y`` (exact products where ``M`` has zeros)."""
        n = self.base.n
        out = []
        for i in range(n):
            acc: Any = None
            for j in range(n):
                m = float(self.M[i, j])
                if m != 0.0:
                    t = y[j] * m if m != 1.0 else y[j]
                    acc = t if acc is None else acc + t
            acc = 0.0 * y[0] if acc is None else acc
            out.append(acc + float(self.c[i]) if self.c[i] != 0.0 else acc)
        return out

    def _fast(self, xp: Any) -> Expanded | None:
        return self.expanded if getattr(xp, "name", "") in _FAST else None

    def expr(self, y: Any, xp: Any) -> Any:
        e = self._fast(xp)
        if e is not None:
            return e.W(y, xp)
        return self.base.expr(self.x_of(y), xp)

    def gradient_expr(self, y: Any, xp: Any) -> list[Any]:
        e = self._fast(xp)
        if e is not None:
            memo: dict[Any, Any] = {}
            return [p(y, xp, memo) for p in e.dW]
        g = self.base.gradient_expr(self.x_of(y), xp)
        n = self.base.n
        out = []
        for j in range(n):
            acc: Any = 0.0
            for i in range(n):
                m = float(self.M[i, j])
                if m != 0.0:
                    acc = g[i] * m + acc
            out.append(acc)
        return out

    def vdot_expr(self, system: System, y: Any, xp: Any) -> Any:  # noqa: ARG002 - see class doc
        e = self._fast(xp)
        if e is None or e.affine is None:
            return self.base.vdot_expr(self.system, self.x_of(y), xp)
        memo: dict[Any, Any] = {}
        out = e.affine(y, xp, memo)
        if e.rest:
            f = self.system.field(0.0, self.x_of(y), xp)
            for i, G in e.rest:
                out = G(y, xp, memo) * f[i] + out
        return out

    def derivative(self, system: System, y: np.ndarray) -> np.ndarray:  # noqa: ARG002
        return self.base.derivative(self.system, self.to_x(y))

    def to_x(self, y: np.ndarray) -> np.ndarray:
        return self.c + np.asarray(y, dtype=float) @ self.M.T

    def hessian_at_center(self) -> np.ndarray:
        return self.M.T @ self.base.hessian_at_center() @ self.M


def _gram_in_y(base: Any, e: Expanded) -> tuple[list[tuple[int, ...]], np.ndarray] | None:
    """``(basis, T' Q T)`` with ``m(M y) = T m(y)`` (exact expansions; None if ``m(M y)`` leaves
    the span of the basis or V has no Gram matrix). Floats suffice: :func:`gram_cover` adjusts the
    matrix to reproduce ``W``'s exact coefficients and proves it positive definite exactly."""
    gram = base.gram_view()
    if gram is None:
        return None
    basis, Q = gram
    where = {b: k for k, b in enumerate(basis)}
    T = np.zeros((len(basis), len(basis)))
    for k, b in enumerate(basis):
        for a, q in e.compose({b: Fraction(1)}).coefs.items():
            if a not in where:
                return None
            T[k, where[a]] = float(cast(Fraction, q))
    return list(basis), T.T @ np.asarray(Q, dtype=float) @ T


def whitened_system(system: System, W: Whitened) -> System:
    """The system in ``y``: ``y' = M^-1 f(c + M y)``, or ``y+ = M^-1 (F(c + M y) - c)`` for a
    map (float ``M^-1``: used for the equilibrium and domain tests only; the proved ``W'`` never
    uses it), its margin composed with ``x(y)``."""
    Minv = np.linalg.inv(W.M)
    discrete = system.time == "discrete"

    def field(t: Any, y: Any, xp: Any) -> list[Any]:
        f = list(system.dynamics(t, W.x_of(y), xp))
        if discrete:
            f = [f[i] - float(W.c[i]) if W.c[i] != 0.0 else f[i] for i in range(len(f))]
        n = len(f)
        out = []
        for i in range(n):
            acc: Any = 0.0
            for j in range(n):
                if Minv[i, j] != 0.0:
                    acc = f[j] * float(Minv[i, j]) + acc
            out.append(acc)
        return out

    margin = None
    if system.margin is not None:
        base_margin = system.margin

        def margin(y: Any, xp: Any) -> Any:
            return base_margin(W.x_of(y), xp)

    common: dict[str, Any] = {"equilibrium": tuple(0.0 for _ in range(system.n)),
              "state_names": tuple(f"y{i}" for i in range(system.n)), "margin": margin,
              "domain_description": system.domain_description}  # fmt: skip
    if discrete:
        return System.discrete(field, name=f"{system.name} (whitened)",
                               sample_time=system.sample_time, **common)  # fmt: skip
    return System(name=f"{system.name} (whitened)", field=field, **common)


def whitening_for(lyap: Lyapunov) -> np.ndarray | None:
    """``M`` from the Hessian of V at the centre, or None when it is not positive definite or
    already diagonal (nothing to gain)."""
    H = lyap.hessian_at_center()
    if not np.all(np.isfinite(H)) or np.linalg.eigvalsh(0.5 * (H + H.T))[0] <= 0:
        return None
    if np.count_nonzero(H - np.diag(np.diag(H))) == 0:
        return None
    return lyap.whitening()
