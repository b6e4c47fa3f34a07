"""Exact polynomial recast of a non-polynomial field for the SOS check (:func:`roa.proof._putinar.check_level`).

**Claim.** :func:`recast_exact` returns, for a field with ``sin``/``cos`` of states and rational
terms, polynomials over the rationals in ``z = (d, s_a, q_a, ...)`` (``d = x - x_eq``; per angle
``a``, a state whose equilibrium value is exactly 0: ``s_a`` standing for ``sin d_a`` and ``q_a``
for ``1 - cos d_a``) such that, at the point ``z(x) = (d, sin d_a, 1 - cos d_a, ...)`` of EVERY
real state ``x``:

* ``V'(x) = N(z(x)) / Den(z(x))`` with ``Den(z) >= Den(0) > 0`` for every real ``z``;
* every equality ``h(z(x)) = 0`` (the circle ``s_a^2 + q_a^2 - 2 q_a = 0``, i.e.
  ``sin^2 + cos^2 = 1``) and every inequality ``g(z(x)) >= 0`` holds.

So a Putinar identity ``-N - eps |d|^2k = sigma0 + lambda (c - V) + sum sigma_j g_j + sum mu_e h_e``
(sigmas SOS) gives ``-N(z(x)) >= eps |d|^2k > 0`` on ``{V <= c}`` minus ``x_eq``, hence ``V' < 0``
there for the ORIGINAL field. Soundness needs only that the constraints hold at ``z(x)``, never
that they pin ``z`` down (loose constraints cost level, not truth).

**Half-integer powers.** ``b^(k/2)`` of a polynomial ``b`` with ``b >= b(0) = t0^2 > 0`` (``t0``
rational, :func:`positive_everywhere`) becomes ``(t0 + u)^k`` with one variable per base,
``u = sqrt(b) - t0``: ``(t0 + u)^2 = b`` and ``u >= 0`` hold at ``z(x)``, ``u = 0`` at ``x_eq``; a
negative ``k`` leaves the denominator ``(t0 + u)^|k| > 0``.

**One recast.** :func:`polynomial_field` is the recast of the field (``F = Den f``, ``Den > 0``
at ``z(x)``); the exact check (:func:`recast_exact`, the reduction
:class:`Recast`) and the programs that propose a level or a V
(:func:`roa.search._sos.recast_field`) all use it.

**Uncertain parameters** (:class:`roa.proof._reductions.ParameterBox`): a system with a parameter
box gets one more variable per parameter, last in ``z``, its normalised value ``w_j`` in
``[-1, 1]``, and the inequality ``1 - w_j^2 >= 0``; every polynomial above is then one in ``(z, w)`` and the claims
hold at ``(z(x), w(p))`` for every state ``x`` and every parameter ``p`` of the box. ``low`` is
the lowest degree of ``N`` in the state variables (the parameters not counted).

**The inequalities** (orders up to ``taylor``, odd; ``T_m``, ``C_m`` the Taylor polynomials of
``sin`` and ``cos`` of degree ``m``):

* one-sided, for every real ``d``: ``d (T_m(d) - sin d) >= 0`` for ``m = 1, 5, 9, ...`` and
  ``d (sin d - T_m(d)) >= 0`` for ``m = 3, 7, 11, ...``; ``cos d - C_m(d) >= 0`` for
  ``m = 2, 6, 10, ...`` and ``C_m(d) - cos d >= 0`` for ``m = 4, 8, ...``;
* bands: ``|sin d - T_m(d)| <= |d|^(m+2) / (m+2)!`` (odd ``m``) and
  ``|cos d - C_m(d)| <= |d|^(m+2) / (m+2)!`` (even ``m``), squared. With a proved bound
  ``|d_a| <= r`` on ``{V <= level}`` (:func:`angle_bound`) they are used as
  ``(sin d - T_m)^2 <= (r^m / (m+2)!)^2 d^4`` (degree 4 in ``d`` instead of ``2m + 4``), which
  holds wherever ``|d| <= r``, so at ``z(x)`` for every ``x`` of ``{V <= level}``, the only
  points the identity is used at; the check then refuses any level above the one the bound was
  proved for. Without such a bound the global form ``R^2 = d^(2m+4) / (m+2)!^2`` is used.

Proof: for ``t >= 0``, ``cos t <= 1``; integrating from 0 to ``t`` (both sides agree at 0)
gives ``sin t <= t``, again ``1 - cos t <= t^2/2``, i.e. ``cos t >= C_2``, again
``sin t >= T_3``, and so on, the direction alternating: the bounds hold for ``t >= 0``. ``cos``
and ``C_m`` are even (the cos bounds hold for all ``t``); ``sin`` and ``T_m`` are odd, so the sin
bounds multiplied by ``d`` hold for all ``d``. Consecutive orders bracket the function, so it
differs from either by at most their difference ``|d|^(m+2) / (m+2)!``: the bands; and
``|d|^(m+2) <= r^m d^2`` for ``|d| <= r``. (``tests/proof/test_sos_recast.py`` evaluates every
constraint at 50 digits.)

**Scaling.** The polynomials are written in ``y`` with ``d_i = scale_i y_i`` (positive dyadics,
the states' extents on the level set, only to balance the semidefinite program): the identity in
``y`` at ``y = d / scale`` is the identity in ``d``, and ``eps |y|^2k > 0`` for ``d != 0``.

**The denominator.** Each field component is brought to ``p_i / q_i`` (sympy ``together``, exact
rationals) and ``Den`` is their least common multiple; ``Den`` (or ``-Den``, then ``N`` is negated
too) is accepted only if its constant term is > 0 and every other term has all exponents even and
a positive coefficient: each such term is ``>= 0`` for all real ``z``, so ``Den >= Den(0) > 0``
everywhere (a sufficient, exactly checked argument; any other denominator is refused by name).

**Refused, named in the message** (the pipeline then uses the branch and bound): any other
function (``exp``, ``tanh``, ``tan`` whose ``cos`` denominator is not provably positive, ...),
non-integer powers (``sqrt``), ``sin``/``cos`` of anything but a state whose equilibrium value
is exactly 0 (after ``expand_trig``: ``sin(2 x)``, ``sin(x + y)`` are expanded exactly), the
non-smooth ``min``/``max``/``abs``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from roa.proof._reductions import ParameterBox, box_constraints, describe
from roa.proof._sos_check import (
    Mono,
    NotPolynomial,
    QPoly,
    exact_fraction,
    exact_terms,
    lie_derivative,
    named_terms,
    poly_lin,
    poly_mul,
    preconditions,
    qpoly,
    rational,
    scaled,
    state_functions,
    v_center,
)

#: Highest Taylor order of the sin bounds (the cos bounds go one further).
MAX_TAYLOR = 11


@dataclass(frozen=True)
class RecastData:
    """Exact data of a recast: polynomials over the rationals in ``nv`` variables
    ``z = (d_0..d_{n-1}, s_a, q_a, ...)``; ``N`` has the sign of ``V'`` (``V' = N / Den``,
    ``Den > 0``)."""

    n: int
    nv: int
    names: tuple[str, ...]
    center: tuple[Fraction, ...]
    V: QPoly
    N: QPoly
    low: int
    angles: tuple[int, ...]  # the state index of each angle, in the order of its (s, q) pair
    taylor: int
    scale: tuple[Fraction, ...]  # d_i = scale_i y_i: the polynomials are in y (and the aux)
    bounded_level: Fraction | None  # the bands assume |d_a| <= r_a, proved on {V <= this level}
    equalities: tuple[tuple[str, QPoly], ...]
    inequalities: tuple[tuple[str, QPoly], ...]
    denominator: str
    description: str
    Den: QPoly  # V' = N / Den at z(x), Den > 0 there (in y and the aux)
    roots: tuple[tuple[int, Fraction, QPoly], ...]  # (index of u, t0, b in y): u = sqrt(b) - t0
    #: uncertain parameters ``(name, low, high)``, exact: the LAST variables of ``z`` are their
    #: normalised values ``w = (p - mid) / half`` in ``[-1, 1]``
    #: (:class:`roa.proof._reductions.ParameterBox`)
    parameters: tuple[tuple[str, Fraction, Fraction], ...] = ()

    @property
    def nz(self) -> int:
        """Number of state variables of ``z`` (states and auxiliaries, not the parameters)."""
        return self.nv - len(self.parameters)

    def aux(self, a: int) -> tuple[int, int]:
        """Variable indices of ``s`` and ``q`` of the ``a``-th angle."""
        return self.n + 2 * a, self.n + 2 * a + 1

    def point(self, x: Any, p: Any = None) -> list[float]:
        """``z(x)`` in floats (for tests and plots, never for a proof): ``y = d / scale``,
        ``sin``, ``1 - cos`` of each angle, ``sqrt(b) - t0`` of each square root, and the
        normalised parameters ``(p - mid) / half`` (``p``: their values, by name)."""
        import numpy as np

        d = [float(xi) - float(c) for xi, c in zip(x, self.center, strict=True)]
        z = [di / float(r) for di, r in zip(d, self.scale, strict=True)]
        z += [0.0] * (self.nv - self.n)
        for j, (name, lo, hi) in enumerate(self.parameters):
            value = float((lo + hi) / 2) if p is None else float(p[name])
            z[self.nz + j] = (value - float((lo + hi) / 2)) / float((hi - lo) / 2)
        for a, i in enumerate(self.angles):
            si, qi = self.aux(a)
            z[si], z[qi] = float(np.sin(d[i])), float(1 - np.cos(d[i]))
        for ui, t0, b in self.roots:
            z[ui] = float(np.sqrt(evaluate(b, z))) - float(t0)
        return z


def evaluate(p: QPoly, z: Any) -> Any:
    """``p`` at the point ``z`` (floats or mpmath numbers; for tests, never for a proof)."""
    total = 0.0 * z[0]
    for m, c in p.items():
        term = c.numerator / c.denominator if isinstance(c, Fraction) else c
        for zi, e in zip(z, m, strict=True):
            if e:
                term = term * zi**e
        total = total + term
    return total


def angle_constraints(nv: int, i: int, si: int, qi: int, taylor: int, r: Fraction | None = None
                      ) -> tuple[list[tuple[str, QPoly]], list[tuple[str, QPoly]]]:  # fmt: skip
    """The circle (equality) and the Taylor bounds (inequalities) of one angle (module docstring):
    ``d = z_i``, ``s = z_si``, ``q = z_qi``; one-sided sin bounds of odd orders ``1..taylor``,
    cos bounds of even orders ``2..taylor + 1``, bands of orders ``1..taylor + 1`` (with ``r``
    given: valid only where ``|d| <= r``)."""

    def t(**exps: int) -> Mono:
        at = {{"d": i, "s": si, "q": qi}[k]: p for k, p in exps.items()}
        return tuple(at.get(j, 0) for j in range(nv))

    def c(j: int) -> Fraction:  # the Taylor coefficient of d^j of sin (odd j) or cos (even j)
        return Fraction((-1) ** (j // 2), math.factorial(j))

    circle = {t(s=2): Fraction(1), t(q=2): Fraction(1), t(q=1): Fraction(-2)}
    eqs = [(f"s{i}^2 + q{i}^2 - 2 q{i} = 0 (sin^2 + cos^2 = 1)", circle)]
    ineqs: list[tuple[str, QPoly]] = []
    for m in range(1, taylor + 1, 2):  # d (T_m - s) >= 0 for m = 1 mod 4, reversed for 3 mod 4
        sign = 1 if m % 4 == 1 else -1
        g = {t(d=1, s=1): Fraction(-sign), **{t(d=j + 1): sign * c(j) for j in range(1, m + 1, 2)}}
        ineqs.append((f"d{i} ({'T' if sign > 0 else 's'}_{m} - {'s' if sign > 0 else 'T'}) >= 0"
                      f" (sin Taylor bound of order {m})", g))  # fmt: skip
    for m in range(2, taylor + 2, 2):  # cos = 1 - q; cos - C_m >= 0 for m = 2 mod 4, reversed
        sign = 1 if m % 4 == 2 else -1
        # sign (1 - q - C_m), the constant 1 cancels C_m's
        g = {t(q=1): Fraction(-sign), **{t(d=j): -sign * c(j) for j in range(2, m + 1, 2)}}
        ineqs.append((f"cos Taylor bound of order {m} on d{i}", g))
    # (s - T_m)^2 <= R^2 and (q - (1 - C_m))^2 <= R^2, R = |d|^(m+2) / (m+2)!
    for m in range(1, taylor + 2):
        T = {t(s=1) if m % 2 else t(q=1): Fraction(1),  # s - T_m, or q - (1 - C_m)
             **{t(d=j): -c(j) if m % 2 else c(j) for j in range(2 - m % 2, m + 1, 2)}}  # fmt: skip
        band = poly_mul(T, T)
        band = {k: -v for k, v in band.items()}
        if r is None:  # R^2 = d^(2m+4) / (m+2)!^2, every d
            top, coef = 2 * m + 4, Fraction(1, math.factorial(m + 2) ** 2)
        else:  # R^2 <= (r^m / (m+2)!)^2 d^4 where |d| <= r (on the level set)
            top, coef = 4, (r**m / math.factorial(m + 2)) ** 2
        band[t(d=top)] = band.get(t(d=top), Fraction(0)) + coef
        what = "sin" if m % 2 else "cos"
        ineqs.append((f"|{what} d{i} - Taylor_{m}| <= |d{i}|^{m + 2}/{m + 2}! (squared)", band))
    return eqs, ineqs


def positive_everywhere(p: QPoly) -> bool:
    """Sufficient exact check that ``p(z) >= p(0) > 0`` for every real ``z``: a constant > 0 and
    every other term with all exponents even and a positive coefficient."""
    zero = next((m for m in p if sum(m) == 0), None)
    if zero is None or p[zero] <= 0:
        return False
    return all(c > 0 and all(e % 2 == 0 for e in m) for m, c in p.items() if m != zero)


def taylor_order(radius: float) -> int:
    """Heuristic order (odd, at most :data:`MAX_TAYLOR`): the least ``m`` with
    ``radius^(m+2) / (m+2)! <= 1e-3`` (the gap of the sin bounds at the angle's extent). Only the
    level reached depends on it, never soundness."""
    m = 3
    while m < MAX_TAYLOR and radius ** (m + 2) / math.factorial(m + 2) > 1e-3:
        m += 2
    return m


def _pretty(p: QPoly, gens: list[Any]) -> str:
    """``p`` for a message: exact coefficients with small denominators (``1/2``), the others as
    the shortest decimal of their double (``0.1``, not ``3602879701896397/36028797018963968``:
    the polynomial itself stays exact)."""
    import sympy as sp

    return str(sp.Add(*[shown_coefficient(c)
                        * sp.Mul(*[g**e for g, e in zip(gens, m, strict=True)])
                        for m, c in p.items()]))  # fmt: skip


def shown_coefficient(c: Fraction) -> Any:
    """An exact coefficient as shown in messages: itself when its denominator is at most 1000,
    else the sympy Float of the shortest decimal of its double."""
    import sympy as sp

    if c.denominator <= 1000:
        return rational(c)
    return sp.Float(repr(float(c)))


def _square_roots(
    f: list[Any], gens: list[Any]
) -> list[tuple[Any, Fraction, QPoly, dict[Any, Any]]]:
    """The half-integer powers ``b^(k/2)`` of ``f`` that are recast: ``b`` polynomial with
    :func:`positive_everywhere` (so ``b >= b(0) > 0``) and ``b(0) = t0^2`` a rational square.
    Each distinct ``b`` gets ``u = sqrt(b) - t0`` (``u >= 0``, ``(t0 + u)^2 = b``) and
    ``b^(k/2) -> (t0 + u)^k``. Returns ``(u, t0, b, replacements)`` per ``b``; other powers are
    left in place (refused later, by name)."""
    import sympy as sp

    found: dict[Any, tuple[Any, Fraction, QPoly, dict[Any, Any]]] = {}
    pows = {p for fi in f for p in fi.atoms(sp.Pow) if p.exp.is_Rational and p.exp.q == 2}
    for p in sorted(pows, key=sp.default_sort_key):
        base = sp.expand(p.base)
        if base not in found:
            try:
                bp = sp.Poly(base, *gens, domain="QQ")
            except (sp.PolynomialError, sp.polys.polyerrors.CoercionFailed):
                continue
            b = qpoly(bp)
            if not positive_everywhere(b):
                continue
            b0 = b[tuple([0] * len(gens))]
            rn, rd = math.isqrt(b0.numerator), math.isqrt(b0.denominator)
            if rn * rn != b0.numerator or rd * rd != b0.denominator:
                continue
            u = sp.Symbol(f"u{len(found)}", real=True)
            found[base] = (u, Fraction(rn, rd), b, {})
        u, t0, _, rep = found[base]
        rep[p] = (rational(t0) + u) ** int(p.exp.p)
    return list(found.values())


def denominator_sign(L: Any, gens: list[Any], roots: list[int]) -> int | None:
    """+1 or -1 if the polynomial ``L`` has that sign at ``z(x)`` for every state, else None:
    each irreducible factor (sympy ``factor_list`` over the rationals) is
    :func:`positive_everywhere` (or its negative), or ``a u + b`` with ``a b > 0`` and ``u`` a
    square-root variable (``u >= 0`` at ``z(x)``, so the factor has the sign of ``a`` there)."""
    import sympy as sp

    const, factors = sp.factor_list(L.as_expr(), *gens)
    sign = 1 if const > 0 else -1
    for fac, mult in factors:
        q = qpoly(sp.Poly(fac, *gens, domain="QQ"))
        if positive_everywhere(q):
            s = 1
        elif positive_everywhere({m: -c for m, c in q.items()}):
            s = -1
        else:
            zero = tuple([0] * len(gens))
            lin = [m for m in q if m != zero]
            if not (len(q) == 2 and zero in q and len(lin) == 1 and sum(lin[0]) == 1
                    and lin[0].index(1) in roots and q[zero] * q[lin[0]] > 0):  # fmt: skip
                return None
            s = 1 if q[zero] > 0 else -1
        sign *= s**mult
    return sign


def _unsupported(expr: Any, syms: list[Any]) -> str:
    import sympy as sp

    bad = [a for a in expr.atoms(sp.Function) if not isinstance(a, sp.sin | sp.cos)]
    bad += [p for p in expr.atoms(sp.Pow) if not p.exp.is_Integer]
    if not bad:
        bad = [a for a in expr.atoms(sp.sin, sp.cos) if a.args[0] not in syms]
    return ", ".join(sorted({str(b) for b in bad})) or str(expr)


def level_scale(V: Any, level: float) -> tuple[Fraction, ...]:
    """Heuristic extent of each state on ``{V <= level}`` from V's quadratic part
    (``sqrt(level (P^-1)_ii)``), rounded to a power of 2: the variables' scale. Any positive
    scale is sound; it only balances the semidefinite program."""
    import numpy as np

    n = int(V.n)
    P = np.array(_quadratic_part(exact_terms(V), n), dtype=float)
    try:
        ext = np.sqrt(np.maximum(level * np.diag(np.linalg.inv(P)), 1e-12))
    except np.linalg.LinAlgError:
        return tuple([Fraction(1)] * n)
    return tuple(Fraction(2) ** int(np.ceil(np.log2(e))) if np.isfinite(e) else Fraction(1)
                 for e in ext)  # fmt: skip


def _quadratic_part(terms: QPoly, n: int) -> list[list[Fraction]]:
    """The symmetric ``P`` of the quadratic terms of ``terms`` (``d'Pd``)."""
    P = [[Fraction(0)] * n for _ in range(n)]
    for m, v in terms.items():
        if sum(m) == 2:
            i, j = [k for k in range(n) for _ in range(m[k])]
            P[i][j] += v if i == j else v / 2
            P[j][i] += 0 if i == j else v / 2
    return P


def angle_bound(V: Any, level: Any, i: int) -> Fraction | None:
    """A proved ``r`` with ``|d_i| <= r`` on ``{V <= level}``, or None. Quadratic ``V = d'Pd``
    (its exact coefficients, ``P`` positive definite exactly): ``max d_i = sqrt(level
    (P^-1)_ii)`` (Cauchy-Schwarz in the P inner product), ``r`` a dyadic with ``r^2 >=
    level (P^-1)_ii`` checked exactly. Otherwise the global Gram cover
    (:func:`roa.proof._cover.gram_cover`)."""
    import numpy as np

    from roa.proof._cover import gram_cover
    from roa.proof._exact import exact_positive_definite

    n, c = int(V.n), Fraction(level)
    terms = exact_terms(V)
    if all(sum(m) == 2 for m in terms):
        P = _quadratic_part(terms, n)
        if exact_positive_definite(P)[0]:
            import sympy as sp

            need = c * exact_fraction(
                sp.Matrix([[rational(v) for v in row] for row in P]).inv()[i, i]
            )
            r = Fraction(2) ** -20 * (int(np.ceil(np.sqrt(float(need)) * 2**20)) + 1)
            while r * r < need:
                r *= 2
            return r
    cover = gram_cover(V, float(level))
    return None if cover is None else Fraction(float(cover[0][i]))


@dataclass(frozen=True)
class PolynomialField:
    """The field made polynomial (:func:`polynomial_field`): ``F_i = L f_i`` over the rationals
    in ``gens`` (``d``, then per angle ``s``, ``q``, then per square root ``u``, then the box's
    ``w``), with ``L`` (``Lpos``, sign included) ``> 0`` at ``z(x)`` for every state ``x``."""

    n: int
    gens: list[Any]
    nz: int  # states and auxiliaries (the parameters not counted)
    F: list[Any]  # sympy Polys over QQ: L f_i
    Lpos: Any  # sympy Poly over QQ: L > 0 at z(x)
    angles: list[int]
    roots: list[tuple[Any, Fraction, QPoly, dict[Any, Any]]]  # (u, t0, b, replacements)
    parameters: tuple[tuple[str, Fraction, Fraction], ...]
    denominator: str

    def root_constraints(self) -> tuple[list[tuple[str, QPoly]], list[tuple[str, QPoly]]]:
        """``(t0 + u)^2 = b`` and ``u >= 0`` per square root (exact, in ``gens``)."""
        nv = len(self.gens)
        eqs, ineqs = [], []
        for k, (u, t0, b, _) in enumerate(self.roots):
            ui = self.gens.index(u)
            unit = tuple(int(j == ui) for j in range(nv))
            h = poly_lin((Fraction(1), {tuple(2 * e for e in unit): Fraction(1)}),
                         (2 * t0, {unit: Fraction(1)}), (t0 * t0, {tuple([0] * nv): Fraction(1)}),
                         (Fraction(-1), b))  # fmt: skip
            eqs.append((f"(sqrt(b{k}(0)) + {u})^2 = b{k}, b{k} = {_pretty(b, self.gens)}", h))
            ineqs.append((f"{u} >= 0 (b{k} >= b{k}(0))", {unit: Fraction(1)}))
        return eqs, ineqs


def polynomial_field(system: Any, center: tuple[Fraction, ...], *, box: Any = None
                     ) -> PolynomialField:  # fmt: skip
    """The one recast (module docstring) of ``system``'s field around ``center``: sin/cos of
    states, tan, half-integer powers ``b^(k/2)`` (``u = sqrt(b) - t0``), rational terms (times
    their positive denominator), over the parameter box ``box``
    (:class:`roa.proof._reductions.ParameterBox`, its values the last variables). Raises
    :class:`NotPolynomial` naming what cannot be recast."""
    import sympy as sp

    from roa.model._backend import namespace
    from roa.model._sympy_eval import exact_rationals

    if getattr(system, "time_varying", False) or system.equilibrium is None:
        raise NotPolynomial("the SOS check needs an autonomous system with an equilibrium")
    n = len(center)
    xs, d = (list(sp.symbols(f"{v}0:{n}", real=True)) for v in "xd")
    try:
        with sp.evaluate(False):
            f = (system if box is None else box.system).field(0.0, xs, namespace("sympy"))
        shift = {xs[i]: d[i] + rational(c) for i, c in enumerate(center)}
        every = shift if box is None else {**shift, **box.subs}
        early = state_functions(f, every, (sp.sin, sp.cos, sp.tan))
        if early:  # refused before the exact conversion (long on a network's expression)
            raise NotPolynomial(f"cannot recast {named_terms(early)} in the field (sin/cos of "
                                "states and rational terms only)")  # fmt: skip
        f = [exact_rationals(sp.sympify(fi)).xreplace(shift) for fi in f]
        if box is not None:
            f = [fi.xreplace(box.subs) for fi in f]
        f = [sp.expand_trig(fi.replace(sp.tan, lambda a: sp.sin(a) / sp.cos(a))) for fi in f]
    except NotPolynomial:
        raise
    except (TypeError, ValueError, AttributeError, NotImplementedError) as exc:
        raise NotPolynomial(f"the field cannot be written in sympy ({exc})") from None
    if len(f) != n:
        raise NotPolynomial(f"the field has {len(f)} components, V has {n} states")
    other = sorted({str(a) for fi in f for a in fi.atoms(sp.Function, sp.Min, sp.Max)
                    if not isinstance(a, sp.sin | sp.cos)}, key=len)  # fmt: skip
    if other:  # functions of constants (of the state: refused above)
        raise NotPolynomial(f"cannot recast {named_terms(other)} in the field (sin/cos of states "
                            "and rational terms only)")  # fmt: skip
    trig = set().union(*(fi.atoms(sp.sin, sp.cos) for fi in f))
    angles = sorted({d.index(a.args[0]) for a in trig if a.args[0] in d})
    if any(a.args[0] not in d for a in trig):
        raise NotPolynomial("cannot recast " + _unsupported(sum(f), d) + " (sin/cos of a "
                            "state whose equilibrium value is exactly 0 only)")  # fmt: skip
    aux: list[Any] = []
    subs: dict[Any, Any] = {}
    for i in angles:
        s, q = sp.symbols(f"s{i} q{i}", real=True)
        aux += [s, q]
        subs[sp.sin(d[i])] = s
        subs[sp.cos(d[i])] = 1 - q
    f = [fi.xreplace(subs) for fi in f]
    roots = _square_roots(f, d + aux)
    aux += [u for u, _, _, _ in roots]
    gens = d + aux + ([] if box is None else list(box.symbols))
    nv = len(gens)
    nz = nv - (0 if box is None else len(box.symbols))  # states and auxiliaries
    roots = [(u, t0, {m + (0,) * (nv - len(m)): c for m, c in b.items()}, rep)
             for u, t0, b, rep in roots]  # fmt: skip
    f = [sp.together(fi.xreplace({p: r for _, _, _, rep in roots for p, r in rep.items()}))
         for fi in f]  # fmt: skip
    nums, dens = [], []
    for fi in f:
        p, q = sp.fraction(fi)
        try:
            nums.append(sp.Poly(p, *gens, domain="QQ"))
            dens.append(sp.Poly(q, *gens, domain="QQ"))
        except (sp.PolynomialError, sp.polys.polyerrors.CoercionFailed):
            raise NotPolynomial(f"cannot recast {_unsupported(fi, gens)} in the field") from None
    L = functools.reduce(sp.lcm, dens)
    if any(sum(m[:nz]) == 0 for p in nums for m, c in p.terms() if c != 0):
        raise NotPolynomial("f(x_eq) != 0 exactly (for some parameter of the box): V's centre "
                            "is not an equilibrium")  # fmt: skip
    sign = denominator_sign(L, gens, [gens.index(u) for u, _, _, _ in roots])
    if sign is None:
        raise NotPolynomial(f"cannot prove the denominator {L.as_expr()} positive (needs factors "
                            "that are a positive constant plus even terms with positive "
                            "coefficients, or sqrt(b) >= 0)")  # fmt: skip
    F = [sign * nums[i] * sp.div(L, dens[i])[0] for i in range(n)]
    den = "1" if L.is_one else str(L.as_expr())
    params = () if box is None else box.parameters
    return PolynomialField(n, gens, nz, F, sign * L, angles, roots, params, den)


def recast_exact(system: Any, V: Any, taylor: int | None = None,
                 scale: tuple[Fraction, ...] | None = None, level: Any = None, *,
                 box: Any = None) -> RecastData:  # fmt: skip
    """The exact recast of ``V'`` (module docstring) in scaled variables ``y`` (``d_i = scale_i
    y_i``, any positive rationals, default 1: module docstring, **Scaling**); raises :class:`NotPolynomial` naming the term that cannot be recast. ``taylor``: the order of
    the sin bounds (default from the angles' scale, :func:`taylor_order`). ``box``: the
    system's parameter box (:class:`roa.proof._reductions.ParameterBox`; default: the system's
    own, when it declares uncertain parameters)."""
    n, center = v_center(V)
    if box is None and getattr(system, "parameters", None):
        box = ParameterBox().apply(system)
    pf = polynomial_field(system, center, box=box)
    gens, nv, nz, angles = pf.gens, len(pf.gens), pf.nz, pf.angles
    Vq: QPoly = {m + (0,) * (nv - n): c for m, c in exact_terms(V).items()}
    Nq, low = lie_derivative(Vq, pf.F, gens, nz)  # low: the lowest degree in the states
    sc = tuple(Fraction(1) for _ in range(n)) if scale is None else tuple(map(Fraction, scale))
    if len(sc) != n or any(r <= 0 for r in sc):
        raise NotPolynomial(f"scale must be {n} positive rationals")
    found = None if level is None else [angle_bound(V, level, i) for i in angles]
    bounds = None if found is None or None in found else [b for b in found if b is not None]
    radius = max(map(float, bounds)) if bounds else max((float(sc[i]) for i in angles), default=1.0)
    order = taylor_order(radius) if taylor is None else int(taylor)
    if order % 2 == 0 or not 1 <= order <= MAX_TAYLOR:
        raise NotPolynomial(f"taylor must be odd, 1..{MAX_TAYLOR}, got {order}")
    pairs = [angle_constraints(nv, i, n + 2 * a, n + 2 * a + 1, order,
                               None if bounds is None else bounds[a])
             for a, i in enumerate(angles)] + [pf.root_constraints()]  # fmt: skip
    params, pad = pf.parameters, sc + (Fraction(1),) * (nv - n)
    Vq, Nq = scaled(Vq, pad), scaled(Nq, pad)
    eqs = [(w, scaled(h, pad)) for e, _ in pairs for w, h in e]
    ineqs = [(w, scaled(g, pad))
             for w, g in [*(g for _, gs in pairs for g in gs), *box_constraints(nv, params)]]  # fmt: skip
    Lq = scaled(qpoly(pf.Lpos), pad)
    root_data = tuple((gens.index(u), t0, scaled(b, pad)) for u, t0, b, _ in pf.roots)
    den = pf.denominator
    desc = ", ".join([f"sin/cos(d{i}) -> (s{i}, 1 - q{i})" for i in angles]
                     + [f"sqrt({_pretty(b, gens)}) -> {t0} + {u}" for u, t0, b, _ in pf.roots]
                     ) or ("polynomial (no recast)" if params else "")  # fmt: skip
    desc = "; ".join(x for x in (desc, f"V' multiplied by {den} > 0" if den != "1" else "",
                                 f"for every {describe(params)}" if params else "") if x)  # fmt: skip
    return RecastData(n, nv, tuple(str(g) for g in gens), center, Vq, Nq, low, tuple(angles),
                      order, sc, None if bounds is None else Fraction(level), tuple(eqs),
                      tuple(ineqs), den, desc or "polynomial (no recast)", Lq,
                      root_data, params)  # fmt: skip


def recast_preconditions(system: Any, V: Any, level: float, taylor: int | None,
                         scale: Any) -> tuple[RecastData | None, str]:  # fmt: skip
    """The recast data at ``level``, or None and why the check does not apply (the checks of
    :func:`roa.proof._sos_check.preconditions`; a term that cannot be recast is named)."""

    def build(system: Any, V: Any) -> RecastData:
        return recast_exact(system, V, taylor=taylor, scale=scale, level=level)

    return preconditions(system, V, level, build, "no exact recast")


@dataclass(frozen=True)
class Recast:
    """The field made polynomial at a level (:func:`roa.proof._recast.recast_preconditions`:
    the one recast, with the parameter box when the system has one), in the variables ``d =
    diag(scale) y``; ``taylor`` the order of the sin bounds (None: from the level)."""

    taylor: int | None = None
    scale: tuple[Fraction, ...] | None = None

    def accepts(self, system: Any, V: Any) -> bool:
        """Whether the problem needs it: a parameter box, or a field that is not polynomial."""
        from roa.proof._sos_check import exact_data

        if ParameterBox().accepts(system):
            return True
        try:
            exact_data(system, V)
            return False
        except NotPolynomial:
            return True

    def apply(self, system: Any, V: Any, level: float) -> tuple[list[Any], Any]:
        """``([data], data)``: the recast's exact data (:class:`roa.proof._recast.RecastData`);
        raises :class:`NotPolynomial` with why it does not apply (:func:`recast_preconditions`)."""
        scale = level_scale(V, level) if self.scale is None else self.scale
        data, why = recast_preconditions(system, V, level, self.taylor, scale)
        if data is None:
            raise NotPolynomial(why)
        return [data], data

    def invert(self, parts: list[dict[str, Any]], inverse: Any) -> dict[str, Any]:
        cert = {"parts": parts, "taylor": inverse.taylor, "scale": [str(r) for r in inverse.scale]}
        return ParameterBox().invert(cert, inverse.parameters)
