"""Exact data of the SOS check of a polynomial field, and the exact arithmetic it is written in.

:func:`exact_data` expands, for a polynomial field ``f`` and a polynomial ``V`` (:meth:`~roa.lyapunov.Lyapunov.polynomial_view` in
``d = x - x_eq``, ``x_eq = V.center``), ``V`` and ``V' = grad V . f`` exactly over the rationals
(every float taken as the exact rational of its double; ``f(x_eq) = 0`` checked exactly), and
:func:`preconditions` adds what every level needs: V centred at the equilibrium, ``{V <= c}``
bounded (``V >= mu |d|^2`` from V's Gram matrix, :func:`roa.proof._cover.gram_cover`) and ``V'``
starting at an even degree ``2k``. The identity itself is checked by
:func:`roa.proof._putinar.check_level` (the one exact check: rounding, the projection of
:func:`project_grams`, exact LDL'); then on ``{V <= c}``, ``V' < 0`` minus ``x_eq``, the set is
compact and positively invariant, and every trajectory from it converges to ``x_eq`` (LaSalle).

The polynomials are ``{exponent tuple: Fraction}``; stored rationals follow one grammar
(:func:`parse_rational`), bounded before any arithmetic.
"""

from __future__ import annotations

import hashlib
import itertools
import math
import re
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from roa.errors import RoaInputError

Mono = tuple[int, ...]
QPoly = dict[Mono, Fraction]


class NotPolynomial(RoaInputError):
    """The field or V is not polynomial: the SOS check does not apply."""


@dataclass(frozen=True)
class ExactData:
    """Exact rational data of the check: ``V`` and ``V'`` as polynomials in ``d = x - x_eq``."""

    n: int
    center: tuple[Fraction, ...]
    V: QPoly
    Vdot: QPoly
    low: int  # lowest total degree of V' (2k)

    # the view of :func:`roa.proof._putinar.check_level`: no auxiliary variable, no constraint
    @property
    def nv(self) -> int:
        return self.n

    @property
    def N(self) -> QPoly:
        return self.Vdot

    equalities: tuple[tuple[str, QPoly], ...] = ()
    inequalities: tuple[tuple[str, QPoly], ...] = ()
    bounded_level: Fraction | None = None


def exact_fraction(x: Any) -> Fraction:
    if isinstance(x, Fraction):
        return x
    import sympy as sp

    if isinstance(x, sp.Rational):
        return Fraction(int(x.p), int(x.q))
    return Fraction(float(x))


def exact_terms(V: Any) -> QPoly:
    """V's terms as exact rationals (the floats taken as the rationals of the doubles)."""
    terms = V.polynomial_view() or {}
    return {tuple(int(k) for k in a): exact_fraction(c) for a, c in terms.items() if c != 0}


def state_functions(f: Any, subs: dict[Any, Any], allowed: tuple[type, ...] = ()) -> list[Any]:
    """The functions of the state in the sympy expressions ``f`` (Function, Min, Max atoms with a
    free symbol) other than ``allowed``, shortest first, once ``subs`` (every free symbol: the
    states by their offsets, ``{x_i: d_i + c_i}``, and a box's parameters) is applied with
    evaluation: what neither the exact check nor a recast can take (``0.0 tanh(x)``,
    ``|x|^2`` and ``exp(0.0 x)`` evaluate away and are not counted). The coefficients stay floats
    (the exact conversion takes long on a network's expression), so a function can cancel in
    rationals and not in floats: such a field is refused here, the conservative way."""
    import sympy as sp

    def functions(g: list[Any]) -> set[Any]:
        return {a for gi in g for a in gi.atoms(sp.Function, sp.Min, sp.Max)
                if a.free_symbols and not isinstance(a, allowed)}  # fmt: skip

    g = [sp.sympify(fi) for fi in f]
    if not functions(g):  # none as written: the exact conversion and its checks decide
        return []
    return sorted(functions([gi.xreplace(subs) for gi in g]), key=lambda a: len(str(a)))


def named_terms(terms: list[Any]) -> str:
    """The first three of ``terms`` (each cut at 60 characters) and how many more."""
    shown = [t if len(t) <= 60 else t[:57] + "..." for t in map(str, terms[:3])]
    return ", ".join(shown) + (f" and {len(terms) - 3} more" if len(terms) > 3 else "")


def rational(c: Fraction) -> Any:
    """``c`` as a sympy Rational."""
    import sympy as sp

    return sp.Rational(c.numerator, c.denominator)


def qpoly(P: Any) -> QPoly:
    """The nonzero terms of a sympy Poly as exact rationals."""
    return {tuple(m): exact_fraction(c) for m, c in P.terms() if c != 0}


def sym_poly(q: QPoly, gens: list[Any]) -> Any:
    """``q`` as a sympy Poly over QQ in ``gens``."""
    import sympy as sp

    return sp.Poly.from_dict({m: rational(c) for m, c in q.items()}, *gens, domain="QQ")


def v_center(V: Any) -> tuple[int, tuple[Fraction, ...]]:
    """``(n, centre)`` of a polynomial V (the centre exact); NotPolynomial without ``terms``."""
    if V.polynomial_view() is None:
        raise NotPolynomial(f"V {getattr(V, 'name', V)!r} is not polynomial (no terms)")
    return int(V.n), tuple(Fraction(float(c)) for c in V.center)


def lie_derivative(Vq: QPoly, F: list[Any], gens: list[Any], nz: int, discrete: bool = False
                   ) -> tuple[QPoly, int]:  # fmt: skip
    """``V' = grad V . F`` (``discrete``: ``V(F) - V``, ``F`` the image's offset from the fixed
    point) exactly over QQ in ``gens`` (``F`` sympy Polys), and its lowest degree in the first
    ``nz`` variables; NotPolynomial for a constant term (cannot happen when ``F(0) = 0``)."""
    import sympy as sp

    Vp = sym_poly(Vq, gens)
    poly = -Vp if discrete else sp.Poly(0, *gens, domain="QQ")
    for a, c in Vq.items() if discrete else ():  # V's terms composed with F - x_eq, exactly
        poly += math.prod((F[i] ** k for i, k in enumerate(a) if k),
                          start=sp.Poly(rational(c), *gens, domain="QQ"))  # fmt: skip
    for i in range(0 if discrete else len(F)):
        poly += Vp.diff(gens[i]) * F[i]
    N = qpoly(poly)
    if any(sum(m[:nz]) == 0 for m in N):
        raise NotPolynomial("f(x_eq) != 0: V' has a constant term")
    return N, min((sum(m[:nz]) for m in N), default=2)


def exact_data(system: Any, V: Any) -> ExactData:
    """``V`` and ``V'`` expanded exactly (sympy over the rationals); raises :class:`NotPolynomial`
    for a field that is not polynomial or a V without ``terms``. For a discrete-time system
    ``Vdot`` is ``V(F(x)) - V(x)`` (a polynomial map ``F`` with ``F(x_eq) = x_eq`` exactly): the
    certificate's claim is the same with that decrease."""
    import sympy as sp

    from roa.model._backend import namespace
    from roa.model._sympy_eval import exact_rationals
    from roa.proof._fast_poly import field_polys

    n, center = v_center(V)
    if getattr(system, "time_varying", False) or system.equilibrium is None:
        raise NotPolynomial("the SOS check needs an autonomous system with an equilibrium")
    xs, d = (list(sp.symbols(f"{v}0:{n}", real=True)) for v in "xd")
    discrete = getattr(system, "time", "continuous") == "discrete"
    try:  # unevaluated, so that no float is rounded against a rational before it is made exact
        with sp.evaluate(False):
            f = system.dynamics(0.0, xs, namespace("sympy"))
        fast = field_polys(list(f), xs, center, d) if len(f) == n else None  # exact ring route
        if fast is None:
            shift = {xs[i]: d[i] + rational(c) for i, c in enumerate(center)}
            other = state_functions(f, shift)
            if other:
                raise NotPolynomial(f"the field is not polynomial in the state (no recasting in "
                                    f"the SOS check): {named_terms(other)}")  # fmt: skip
            f = [exact_rationals(sp.sympify(fi)).xreplace(shift) for fi in f]
    except NotPolynomial:
        raise
    except (TypeError, ValueError, AttributeError, NotImplementedError) as exc:
        raise NotPolynomial(f"the field cannot be written in sympy ({exc})") from None
    if len(f) != n:
        raise NotPolynomial(f"the field has {len(f)} components, V has {n} states")
    try:  # polynomial arithmetic over QQ (exact, and much faster than expanding expressions)
        fp = fast if fast is not None else [sp.Poly(fi, *d, domain="QQ") for fi in f]
    except (sp.PolynomialError, sp.polys.polyerrors.CoercionFailed, sp.GeneratorsNeeded) as exc:
        raise NotPolynomial(f"the field is not polynomial in the state (no recasting in the SOS "
                            f"check): {exc}") from None  # fmt: skip
    if discrete:  # the image's offset from the fixed point: F(x) - x_eq, in d
        fp = [fi - rational(ci) for fi, ci in zip(fp, center, strict=True)]
    if any(p.coeff_monomial(1) != 0 for p in fp):
        raise NotPolynomial("F(x_eq) != x_eq exactly: V's centre is not a fixed point" if discrete
                            else "f(x_eq) != 0 exactly: V's centre is not an equilibrium")  # fmt: skip
    Vq = exact_terms(V)
    Vd, low = lie_derivative(Vq, fp, d, n, discrete)
    return ExactData(n, center, Vq, Vd, low)


# -- exact polynomial arithmetic ---------------------------------------------------------------------
def mono_add(a: Mono, b: Mono) -> Mono:
    return tuple(x + y for x, y in zip(a, b, strict=True))


def gram_poly(basis: list[Mono], Q: Any) -> QPoly:
    """``m' Q m`` for a rational (or float, taken exactly) symmetric ``Q``."""
    out: QPoly = {}
    for (i, bi), (j, bj) in itertools.product(enumerate(basis), enumerate(basis)):
        q = Q[i][j]
        if q:
            key = mono_add(bi, bj)
            out[key] = out.get(key, Fraction(0)) + exact_fraction(q)
    return {m: c for m, c in out.items() if c}


def poly_mul(a: QPoly, b: QPoly) -> QPoly:
    out: QPoly = {}
    for (ma, ca), (mb, cb) in itertools.product(a.items(), b.items()):
        key = mono_add(ma, mb)
        out[key] = out.get(key, Fraction(0)) + ca * cb
    return {m: c for m, c in out.items() if c}


def poly_lin(*pairs: tuple[Fraction, QPoly]) -> QPoly:
    """``sum_k w_k p_k``."""
    out: QPoly = {}
    for w, p in pairs:
        for m, c in p.items():
            out[m] = out.get(m, Fraction(0)) + w * c
    return {m: c for m, c in out.items() if c}


def norm_power(n: int, k: int) -> QPoly:
    """``|d|^(2k) = (d_1^2 + ... + d_n^2)^k``."""
    sq: QPoly = {tuple(2 * (j == i) for j in range(n)): Fraction(1) for i in range(n)}
    out: QPoly = {tuple([0] * n): Fraction(1)}
    for _ in range(k):
        out = poly_mul(out, sq)
    return out


def round_matrix(Q: Any, bits: int = 30) -> list[list[Fraction]]:
    """Symmetric dyadic rounding of a float matrix: entries on the grid ``2^(e - bits)`` with
    ``2^e >= max |Q_ij|`` (upper triangle, mirrored)."""
    A = np.asarray(Q, dtype=float)
    top = float(np.max(np.abs(A))) if A.size else 0.0
    e = int(np.ceil(np.log2(top))) if top > 0 else 0
    grid = Fraction(2) ** (e - bits)
    S = 0.5 * (A + A.T)  # symmetric exactly (float addition commutes)
    return [[Fraction(round(Fraction(float(v)) / grid)) * grid for v in row] for row in S]


def exact_matrix(Q: Any, rounded: bool) -> list[list[Fraction]]:
    """A Gram matrix in exact arithmetic: a stored (already rounded) one read entry by entry,
    else a float matrix by :func:`round_matrix`."""
    return [[exact_fraction(v) for v in row] for row in Q] if rounded else round_matrix(Q)


def is_symmetric(R: list[list[Fraction]]) -> bool:
    """Whether the exact square matrix ``R`` is symmetric."""
    return all(R[i][j] == R[j][i] for i in range(len(R)) for j in range(i))


def matrix_digest(*mats: list[list[Fraction]]) -> str:
    return hashlib.sha256(b"".join(repr([[str(v) for v in row] for row in M]).encode() + b";"
                                   for M in mats)).hexdigest()  # fmt: skip


def project_grams(
    blocks: list[tuple[list[Mono], list[list[Fraction]]]], target: QPoly, *, exact: bool = False
) -> tuple[list[list[list[Fraction]]] | None, Fraction | None, str]:
    """``(P, residual, why)``: the rounded Gram blocks projected jointly (Frobenius norm over all
    blocks, exact rationals) onto the affine space where ``sum_b m_b' P_b m_b = target``: every
    entry ``(b, i, j)`` yields one monomial ``m_bi m_bj``, so the constraints of distinct
    monomials touch disjoint entries and each monomial's ``N_a`` entries, over all blocks, move
    by ``(r_a - s_a) / N_a`` (``r_a`` the target's coefficient, ``s_a`` the blocks'); the largest
    coefficient moved, and ``P`` None with the reason when the identity cannot hold. ``exact=True``
    (stored certificates): no entry moves; the identity must hold exactly as given, else the
    first monomial whose coefficients differ is named."""
    pairs: dict[Mono, list[tuple[int, int, int]]] = {}
    for b, (basis, _) in enumerate(blocks):
        for (i, bi), (j, bj) in itertools.product(enumerate(basis), enumerate(basis)):
            pairs.setdefault(mono_add(bi, bj), []).append((b, i, j))
    outside = [m for m in target if m not in pairs]
    if outside:
        return None, None, (f"the identity cannot hold: monomial {outside[0]} of the residual "
                            "is outside the Gram basis")  # fmt: skip
    Ps = [[row[:] for row in R] for _, R in blocks]
    residual = Fraction(0)
    for m, idx in pairs.items():
        diff = target.get(m, Fraction(0)) - sum((blocks[b][1][i][j] for b, i, j in idx),
                                                Fraction(0))  # fmt: skip
        residual = max(residual, abs(diff))
        if diff and exact:
            return None, residual, (f"the identity does not hold exactly as stored: the "
                                    f"coefficient of monomial {m} differs by {as_float(diff):.3g}")  # fmt: skip
        if diff:
            share = diff / len(idx)
            for b, i, j in idx:
                Ps[b][i][j] += share
    total = poly_lin(*((Fraction(1), gram_poly(basis, P))
                       for (basis, _), P in zip(blocks, Ps, strict=True)))  # fmt: skip
    if total != target:  # the identity must now hold exactly
        return None, residual, "the projection did not reproduce the identity exactly"
    return Ps, residual, ""


def preconditions(system: Any, V: Any, level: float, build: Any = None,
                  what: str = "not polynomial") -> tuple[Any, str]:  # fmt: skip
    """The exact data of the check (``build(system, V)``, default :func:`exact_data`; raising
    :class:`NotPolynomial`, reported after ``what``), or None and why the check does not apply:
    uncertain parameters (the default build proves one field), V's centre not an exact
    equilibrium, ``{V <= level}`` not proved bounded (``V >= mu |d|^2`` from V's Gram matrix,
    :func:`roa.proof._cover.gram_cover`), or V' starting at an odd degree."""
    from roa.proof._cover import gram_cover

    if build is None and getattr(system, "parameters", None):
        return None, "the system has uncertain parameters: the SOS check proves one field"
    if system.equilibrium is None or not np.array_equal(np.asarray(V.center, float), system.x_eq):
        return None, "V must be centred at the system's equilibrium"
    try:
        data = (build or exact_data)(system, V)  # refuses f(x_eq) != 0 (exact constant terms)
    except NotPolynomial as exc:
        return None, f"{what}: {exc}"
    if gram_cover(V, level) is None:
        return None, ("V >= mu |d|^2 not proved (no positive definite Gram matrix over the linear "
                      "monomials): {V <= level} may be unbounded")  # fmt: skip
    return (None, "the lowest degree of V' is odd") if data.low % 2 else (data, "")


#: Bounds on a stored certificate (beyond them it is refused before any arithmetic).
MAX_BASIS = 5000
MAX_DIGITS = 2000


#: The one grammar of a stored rational: ASCII digits, an optional leading minus sign and an
#: optional ``/`` and denominator (no spaces, underscores, exponents, decimals or other digits).
RATIONAL = re.compile(r"-?[0-9]+(/[0-9]+)?", re.ASCII)


def parse_rational(raw: Any, what: str) -> Fraction:
    """A rational of a stored certificate: a string (or a JSON integer) in the grammar of
    :data:`RATIONAL`, at most :data:`MAX_DIGITS` characters, with a nonzero denominator; its
    size is bounded before any arithmetic. ValueError naming ``what`` otherwise."""
    if isinstance(raw, bool) or not isinstance(raw, str | int):
        raise ValueError(f"{what} must be a rational written as a string like '-3/4', got "
                         f"{type(raw).__name__}")  # fmt: skip
    if isinstance(raw, int) and abs(raw).bit_length() > 3.33 * MAX_DIGITS:
        raise ValueError(f"{what}: at most {MAX_DIGITS} digits")
    text = str(raw)
    if len(text) > MAX_DIGITS:
        raise ValueError(f"{what}: at most {MAX_DIGITS} characters")
    if not RATIONAL.fullmatch(text):
        raise ValueError(f"{what} must be a rational like '-3/4' (ASCII digits, optional '-' and "
                         f"'/'), got {text[:40]!r}")  # fmt: skip
    num, _, den = text.partition("/")
    if den and int(den) == 0:
        raise ValueError(f"{what}: zero denominator")
    return Fraction(int(num), int(den) if den else 1)


def as_float(x: Fraction) -> float:
    """``x`` as a float for reports (+-inf beyond the float range)."""
    try:
        return float(x)
    except OverflowError:
        return float("inf") if x > 0 else float("-inf")


def objects(raw: Any, what: str, limit: int = MAX_BASIS, *, empty: bool = True) -> list[Any]:
    """``raw`` as a stored list of at most ``limit`` objects (non-empty unless ``empty``);
    ValueError naming ``what`` otherwise."""
    if not isinstance(raw, list) or len(raw) > limit or not (raw or empty):
        raise ValueError(f"{what} must be a {'' if empty else 'non-empty '}list of at most {limit} "
                         "objects")  # fmt: skip
    if not all(isinstance(item, dict) for item in raw):
        raise ValueError(f"{what}: every entry must be an object")
    return raw


def parse_basis(raw: Any, n: int, what: str) -> list[Mono]:
    if not isinstance(raw, list) or len(raw) > MAX_BASIS:
        raise ValueError(f"{what} must be a list of at most {MAX_BASIS} exponent lists")
    out = []
    for b in raw:
        if not (isinstance(b, list) and len(b) == n and all(
            type(k) is int and 0 <= k <= 64 for k in b)):  # fmt: skip
            raise ValueError(f"{what}: every monomial must be {n} non-negative integers")
        out.append(tuple(b))
    return out


def parse_matrix(raw: Any, m: int, what: str) -> list[list[Fraction]]:
    if not (isinstance(raw, list) and len(raw) == m and all(isinstance(r, list) and len(r) == m
                                                            for r in raw)):  # fmt: skip
        raise ValueError(f"{what} must be a {m}x{m} matrix of rationals")
    return [[parse_rational(v, f"{what}[{i}][{j}]") for j, v in enumerate(row)]
            for i, row in enumerate(raw)]  # fmt: skip


def scaled(p: QPoly, scale: tuple[Fraction, ...]) -> QPoly:
    """``p`` with ``d_i = scale_i y_i`` substituted (variables past ``len(scale)`` unchanged)."""
    out: QPoly = {}
    for m, c in p.items():
        for i, r in enumerate(scale):
            c *= r ** m[i]
        out[m] = c
    return out


def scale_data(data: ExactData, scale: tuple[Fraction, ...]) -> ExactData:
    """The data in variables ``y`` with ``d = diag(scale) y`` (:class:`roa.proof._reductions.Rescale`)."""
    return ExactData(data.n, data.center, scaled(data.V, scale), scaled(data.Vdot, scale), data.low)


def stored_scale(cert: Any, n: int, *, chars: int = MAX_DIGITS) -> tuple[Fraction, ...] | None:
    """The ``scale`` of a stored certificate (``n`` positive rationals of at most ``chars``
    characters), None when absent; ValueError when malformed."""
    raw = cert.get("scale") if isinstance(cert, dict) else None
    if raw is None:
        return None
    if not isinstance(raw, list) or len(raw) != n or any(len(str(r)) > chars for r in raw):
        raise ValueError(f"scale must be a list of {n} positive rationals (at most {chars} "
                         "characters each)")  # fmt: skip
    scale = tuple(parse_rational(r, f"scale[{i}]") for i, r in enumerate(raw))
    if not all(r > 0 for r in scale):
        raise ValueError("scale must be positive rationals")
    return scale
