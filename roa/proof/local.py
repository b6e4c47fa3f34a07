"""Local negativity of V' at a degenerate equilibrium, from its lowest-order homogeneous part.

When the linearisation is degenerate (e.g. a zero Jacobian), the Hessian of V' at the equilibrium is
not negative definite and the second-order proof of :func:`roa.proof.validate.local_proof` fails.
For a field whose V' is a polynomial in ``d = x - x_eq``, write ``V'(d) = h_m(d) + R(d)`` with
``h_m`` homogeneous of the lowest (even) degree ``m`` and ``R`` the terms of degree > m. Then, with
``|d| = max_i |d_i|``:

* ``h_m(d) = |d|^m h_m(d / |d|) <= -mu |d|^m`` where ``-mu`` bounds ``h_m`` on the faces of the cube
  ``[-1, 1]^n`` (interval branch and bound, outward rounding);
* ``|R(d)| <= |d|^(m+1) K`` for ``|d| <= rho0 <= 1`` with ``K = sum |r_a| rho0^(|a| - m - 1)``
  (exact rationals);

so ``V' < 0`` for ``0 < |d| < min(rho0, mu / K)``, and ``{V <= eps}`` lies in that cube when
``eps <= rho^2 / max_i (P^-1)_ii`` (exact rationals). Coefficients are the exact rationals of the
float data (sympy), so the argument is a proof, not an estimate. For a non-quadratic candidate
(:func:`higher_order_cube`) ``V' = grad V . f`` is formed from the exact sympy gradient and the
cube itself is returned (the validation then discards the boxes inside it).
"""

from __future__ import annotations

import itertools
from fractions import Fraction
from typing import Any

import numpy as np

from roa.lyapunov import Lyapunov, QuadraticLyapunov
from roa.proof.interval import Interval
from roa.system import System


def _poly(system: System, lyap: Lyapunov) -> tuple[Any, list[Any]] | None:
    """V' as a sympy Poly in d (exact rational coefficients), or None if it is not polynomial."""
    import sympy as sp

    from roa.backend import namespace

    n = lyap.n
    d = sp.symbols(f"d0:{n}")
    c = [sp.Rational(float(v)) for v in lyap.center]
    x = [c[i] + d[i] for i in range(n)]
    try:
        f = system.field(0.0, x, namespace("sympy"))
        if lyap.P is not None:
            P = [[sp.Rational(float(lyap.P[i, j])) for j in range(n)] for i in range(n)]
            vd = 2 * sum(d[i] * P[i][j] * f[j] for i in range(n) for j in range(n))
        else:
            from roa.lyapunov import exact_rationals

            g = lyap.gradient_expr(x, namespace("sympy"))
            vd = sum(exact_rationals(sp.sympify(g[i])) * f[i] for i in range(n))
            vd = exact_rationals(sp.sympify(vd))
        poly = sp.Poly(sp.expand(vd), *d)
    except (sp.PolynomialError, TypeError, ValueError):
        return None
    if not poly.domain.is_QQ and not poly.domain.is_ZZ:
        return None
    return poly, list(d)


def _face_max(terms: list[tuple[tuple[int, ...], Fraction]], n: int, budget: int) -> float | None:
    """An upper bound of max h(u) over the faces of [-1, 1]^n (None if the budget runs out
    before it is proved negative); h = sum c_a u^a."""
    coeffs = [(a, float(cf), cf) for a, cf in terms]

    def upper(lo: np.ndarray, hi: np.ndarray) -> float:
        total = Interval(0.0)
        for a, _cf_float, cf in coeffs:
            term = Interval.of(cf)
            for i, k in enumerate(a):
                if k:
                    term = term * Interval(lo[i], hi[i]) ** k
            total = total + term
        return float(np.atleast_1d(total.hi)[0])

    worst = -np.inf
    boxes = 0
    for k, sign in itertools.product(range(n), (-1.0, 1.0)):
        lo0, hi0 = -np.ones(n), np.ones(n)
        lo0[k] = hi0[k] = sign
        stack = [(lo0, hi0)]
        while stack:
            lo, hi = stack.pop()
            boxes += 1
            if boxes > budget:
                return None
            ub = upper(lo, hi)
            if ub < 0:
                worst = max(worst, ub)
                continue
            widths = np.where(np.arange(n) == k, 0.0, hi - lo)
            j = int(np.argmax(widths))
            if widths[j] < 1e-6:
                return None  # h_m >= 0 somewhere on the sphere (or too close to 0 to tell)
            mid = 0.5 * (lo[j] + hi[j])
            a_hi, b_lo = hi.copy(), lo.copy()
            a_hi[j] = mid
            b_lo[j] = mid
            stack += [(lo, a_hi), (b_lo, hi)]
    return worst


def higher_order_cube(
    system: System, lyap: Lyapunov, *, rho0: float = 0.5, budget: int = 20000
) -> tuple[float, dict[str, Any]] | None:
    """A cube radius ``rho`` (exact, rounded down) with ``V' < 0`` proved for
    ``0 < max_i |x_i - x_eq_i| <= rho``, or None. Returns ``(rho, info)``."""
    found = _cube(system, lyap, rho0=rho0, budget=budget)
    if found is None:
        return None
    rho, info = found
    r = float(rho)
    if Fraction(r) > rho:
        r = float(np.nextafter(r, 0.0))
    return r, info


def _cube(
    system: System, lyap: Lyapunov, *, rho0: float, budget: int
) -> tuple[Fraction, dict[str, Any]] | None:
    out = _poly(system, lyap)
    if out is None:
        return None
    poly, _ = out
    terms = [(tuple(int(v) for v in a), Fraction(int(c.p), int(c.q))) for a, c in poly.terms()]
    if not terms:
        return None
    m = min(sum(a) for a, _ in terms)
    if m < 2 or m % 2:
        return None  # a linear term (f(x_eq) != 0) or an odd lowest order: not negative definite
    low = [(a, c) for a, c in terms if sum(a) == m]
    high = [(a, c) for a, c in terms if sum(a) > m]
    top = _face_max(low, lyap.n, budget)
    if top is None or not top < 0:
        return None
    mu = Fraction(-top)
    r0 = Fraction(rho0)
    K = sum((abs(c) * r0 ** (sum(a) - m - 1) for a, c in high), Fraction(0))
    rho = r0 if K == 0 else min(r0, mu / (2 * K))
    return rho, {"degree": m, "mu": float(mu), "K": float(K), "cube_radius": float(rho)}


def higher_order_eps(
    system: System, lyap: QuadraticLyapunov, *, rho0: float = 0.5, budget: int = 20000
) -> tuple[float, dict[str, Any]] | None:
    """An ``eps > 0`` with ``V' < 0`` proved on ``{V <= eps}`` minus the equilibrium, or None.

    Returns ``(eps, info)``; ``info`` records the degree ``m``, ``mu``, ``K`` and the cube radius.
    """
    found = _cube(system, lyap, rho0=rho0, budget=budget)
    if found is None:
        return None
    rho, info = found
    import sympy as sp

    P = sp.Matrix(lyap.n, lyap.n, lambda i, j: sp.Rational(float(lyap.P[i, j])))
    Pinv = P.inv()
    diag = max(Fraction(int(v.p), int(v.q)) for v in (Pinv[i, i] for i in range(lyap.n)))
    eps_exact = rho**2 / diag
    eps = float(eps_exact)
    if Fraction(eps) > eps_exact:  # round down
        eps = float(np.nextafter(eps, 0.0))
    return eps, info
