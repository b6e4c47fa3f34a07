"""Proofs that ``V' < 0`` near the equilibrium (minus the point itself), for any candidate.

The validation (:func:`roa.proof.validate.validate_level`) discards the boxes inside a box ``L``
around the equilibrium ``x_eq`` proved here (:func:`local_box`), by one of two arguments:

1. **Hessian** (:func:`local_box_proof`): with ``f(x_eq) = 0`` exactly
   (:func:`roa.proof.exact.exact_equilibrium`) and ``grad V(x_eq) = 0`` (:func:`gradient_vanishes`),
   ``V'(x_eq) = 0`` and ``grad V'(x_eq) = 0``, so by Taylor with integral remainder
   ``V'(x) = d' H~ d`` on ``L`` with ``d = x - x_eq`` and ``H~`` in the convex hull of the Hessians
   of ``V'`` on ``L``. Their enclosure ``[H]`` comes from second-order interval jets; every matrix in
   it is negative definite (:func:`hessian_negative_definite`: ``-H_mid - t I`` positive definite
   with ``t >= ||rad H||_F``, exact rationals), so ``V' < 0`` on ``L \\ {x_eq}``. ``L`` is the
   largest ``x_eq + 2^-k (B - x_eq)`` of the cover ``B`` that passes.
2. **Lowest-order homogeneous part** (:func:`higher_order_cube`), when the linearisation is
   degenerate (e.g. a zero Jacobian) and the Hessian of ``V'`` at the equilibrium is not negative
   definite. For a field whose V' is a polynomial in ``d = x - x_eq``, write
   ``V'(d) = h_m(d) + R(d)`` with ``h_m`` homogeneous of the lowest (even) degree ``m`` and ``R``
   the terms of degree > m. Then, with ``|d| = max_i |d_i|``:

   * ``h_m(d) = |d|^m h_m(d / |d|) <= -mu |d|^m`` where ``-mu`` bounds ``h_m`` on the faces of the
     cube ``[-1, 1]^n`` (interval branch and bound, outward rounding);
   * ``|R(d)| <= |d|^(m+1) K`` for ``|d| <= rho0 <= 1`` with ``K = sum |r_a| rho0^(|a| - m - 1)``
     (exact rationals);

   so ``V' < 0`` for ``0 < |d| < min(rho0, mu / K)``: that cube is ``L``. ``V' = grad V . f`` is
   formed from the exact sympy gradient (``2 P d`` for a quadratic V) and the coefficients are the
   exact rationals of the float data (sympy), so the argument is a proof, not an estimate.
"""

from __future__ import annotations

import itertools
from fractions import Fraction
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.proof.exact import exact_equilibrium, interval_negative_definite
from roa.proof.interval import Interval
from roa.proof.jet import JET, Jet
from roa.system import System


def hessian_negative_definite(vd: Jet, n: int) -> bool:
    """Every matrix in the interval Hessian of the second-order jet ``vd`` (one box) is negative
    definite (exact rationals)."""
    h = vd.h
    assert h is not None, "a second-order jet is needed"

    def bound(e: Any, side: str) -> float:
        return float(np.atleast_1d(getattr(Interval.of(e), side))[0])

    H_lo = np.array([[bound(h[min(i, j)][max(i, j)], "lo") for j in range(n)] for i in range(n)])
    H_hi = np.array([[bound(h[min(i, j)][max(i, j)], "hi") for j in range(n)] for i in range(n)])
    return interval_negative_definite(H_lo, H_hi)


def gradient_vanishes(lyap: Lyapunov) -> bool:
    """``grad V(x_eq) = 0`` exactly (sympy, the float centre and constants as exact rationals)."""
    cached = getattr(lyap, "_gradient_vanishes", None)
    if cached is not None:
        return bool(cached)
    import sympy as sp

    from roa.backend import namespace
    from roa.lyapunov import exact_rationals

    if lyap.terms is not None:
        ok = True  # every term has degree >= 2 in d = x - x_eq
    else:
        x = [sp.Rational(float(c)) for c in lyap.center]
        try:
            g = lyap.gradient_expr(x, namespace("sympy"))
            ok = all(sp.simplify(exact_rationals(sp.sympify(gi))) == 0 for gi in g)
        except (TypeError, ValueError, RoaInputError):
            ok = False
    try:
        object.__setattr__(lyap, "_gradient_vanishes", ok)
    except AttributeError:
        pass
    return ok


def local_box_proof(
    system: System, lyap: Lyapunov, lo: np.ndarray, hi: np.ndarray, *, exact: bool | None = None
) -> bool:
    """Prove ``V' < 0`` on the box ``[lo, hi]`` (holding ``x_eq``) minus the equilibrium.
    ``exact``: the result of :func:`hessian_preconditions` when the caller has it."""
    if exact is None:
        exact = hessian_preconditions(system, lyap)
    if not exact:
        return False
    vd = lyap.vdot_expr(system, Jet.variables(lo[None, :], hi[None, :], order=2), JET)
    return hessian_negative_definite(vd, lyap.n)


def hessian_preconditions(system: System, lyap: Lyapunov) -> bool:
    """``grad V(x_eq) = 0`` and ``f(x_eq) = 0`` exactly (the Hessian argument's premises)."""
    return gradient_vanishes(lyap) and exact_equilibrium(system, lyap.center)


def local_box(
    system: System,
    lyap: Lyapunov,
    lo0: np.ndarray,
    hi0: np.ndarray,
    *,
    exact: bool | None = None,
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]] | None:
    """``(lo, hi, info)``: a box around the equilibrium inside ``[lo0, hi0]`` (or the cube of the
    lowest-order part, which may reach past it) on which ``V' < 0`` is proved minus the
    equilibrium (module doc), or None. ``info`` names the proof (``local_proof``); ``exact``: the
    result of :func:`hessian_preconditions` when the caller has it (checked here otherwise)."""
    c = np.asarray(lyap.center, dtype=float)
    if exact is None:
        exact = hessian_preconditions(system, lyap)
    for k in range(1, 41 if exact else 1):
        a, b = c + (lo0 - c) / 2.0**k, c + (hi0 - c) / 2.0**k
        if local_box_proof(system, lyap, a, b, exact=True):
            return a, b, {"local_proof": "hessian", "local_scale": 2.0**-k}
    found = higher_order_cube(system, lyap)
    if found is None:
        return None
    rho, info = found
    return c - rho, c + rho, {"local_proof": "lowest-order homogeneous part", **info}


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

            # V' as the candidate writes it (a whitened V: grad V . f at x = c + M y with the
            # system's own field, never the float inverse of M)
            vd = exact_rationals(sp.sympify(lyap.vdot_expr(system, x, namespace("sympy"))))
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
