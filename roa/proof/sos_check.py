"""Exact check of an SOS certificate of a level (Peyrl-Parrilo rounding and projection).

**Claim.** For a polynomial field ``f``, a polynomial ``V`` (``V.terms`` in ``d = x - x_eq``,
``x_eq = V.center``) and a level ``c > 0``, the checker proves, in exact rational arithmetic, the
polynomial identity (coefficient by coefficient)::

    -V'(d) - eps |d|^(2k) - lambda(d) (c - V(d)) = sigma0(d),
    sigma0 = m0(d)' Q0 m0(d),   lambda = m1(d)' Q1 m1(d)   (or lambda = 0),

with ``Q0`` and ``Q1`` positive definite (exact leading minors, python-flint) and ``eps > 0``.
Then on ``{V <= c}``: ``-V' >= eps |d|^(2k) + lambda (c - V) >= eps |d|^(2k) > 0`` for ``d != 0``,
i.e. ``V' < 0`` on ``{V <= c}`` minus ``x_eq``.

**Assumptions, each checked exactly** (else the verdict is inconclusive with the reason):

* the field, evaluated in sympy at ``x_eq + d`` with every float taken as the exact rational of
  the double, is polynomial in ``d`` (no recasting here); ``f(x_eq) = 0`` exactly;
* ``V``'s coefficients and centre are the exact rationals of its doubles (the same V the interval
  validation reads), and ``V`` has a Gram matrix ``V.gram`` over a basis holding the linear
  monomials that is positive definite after the exact reproduction of the coefficients
  (:func:`roa.proof.cover.gram_cover`): ``V >= mu |d|^2`` globally, so ``{V <= c}`` is compact.
  With ``V' < 0`` on it (minus ``x_eq``) it is positively invariant and every trajectory from it
  converges to ``x_eq`` (LaSalle): ``{V <= c}`` lies in the region of attraction.

**Rounding and projection.** The float Gram matrices of the numerical solver
(:mod:`roa.search.sos_certificate`) are rounded to dyadic rationals; ``lambda`` is fixed at its
rounded Gram ``Q1``, and ``Q0`` is projected orthogonally (Frobenius norm, exact rationals) onto the
affine space where ``m0' Q0 m0`` equals the exact residual ``-V' - eps|d|^2k - lambda (c - V)``:
the constraints of distinct monomials touch disjoint entries, so the projection adds
``(r_a - s_a) / N_a`` to each of the ``N_a`` entries ``(i, j)`` with ``m0_i m0_j = d^a``.
"""

from __future__ import annotations

import hashlib
import itertools
import re
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.proof.exact import exact_positive_definite

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


def exact_fraction(x: Any) -> Fraction:
    if isinstance(x, Fraction):
        return x
    import sympy as sp

    if isinstance(x, sp.Rational):
        return Fraction(int(x.p), int(x.q))
    return Fraction(float(x))


def exact_terms(V: Any) -> QPoly:
    """V's terms as exact rationals (the floats taken as the rationals of the doubles)."""
    terms = getattr(V, "terms", None) or {}
    return {tuple(int(k) for k in a): exact_fraction(c) for a, c in terms.items() if c != 0}


def exact_data(system: Any, V: Any) -> ExactData:
    """``V`` and ``V'`` expanded exactly (sympy over the rationals); raises :class:`NotPolynomial`
    for a field that is not polynomial or a V without ``terms``."""
    import sympy as sp

    from roa.backend import namespace
    from roa.lyapunov.symbolic import exact_rationals
    from roa.proof.fast_poly import field_polys

    terms = getattr(V, "terms", None)
    if terms is None:
        raise NotPolynomial(f"V {getattr(V, 'name', V)!r} is not polynomial (no terms)")
    if getattr(system, "time_varying", False) or system.equilibrium is None:
        raise NotPolynomial("the SOS check needs an autonomous system with an equilibrium")
    n = int(V.n)
    center = tuple(Fraction(float(c)) for c in V.center)
    xs = list(sp.symbols(f"x0:{n}", real=True))
    d = list(sp.symbols(f"d0:{n}", real=True))
    try:  # unevaluated, so that no float is rounded against a rational before it is made exact
        with sp.evaluate(False):
            f = system.field(0.0, xs, namespace("sympy"))
        fast = field_polys(list(f), xs, center, d) if len(f) == n else None  # exact ring route
        shift = {
            xs[i]: d[i] + sp.Rational(c.numerator, c.denominator) for i, c in enumerate(center)
        }
        if fast is None:
            f = [exact_rationals(sp.sympify(fi)).xreplace(shift) for fi in f]
    except (TypeError, ValueError, AttributeError, NotImplementedError) as exc:
        raise NotPolynomial(f"the field cannot be written in sympy ({exc})") from None
    if len(f) != n:
        raise NotPolynomial(f"the field has {len(f)} components, V has {n} states")
    try:  # polynomial arithmetic over QQ (exact, and much faster than expanding expressions)
        fp = fast if fast is not None else [sp.Poly(fi, *d, domain="QQ") for fi in f]
    except (sp.PolynomialError, sp.polys.polyerrors.CoercionFailed, sp.GeneratorsNeeded) as exc:
        raise NotPolynomial(
            f"the field is not polynomial in the state (no recasting in the SOS check): {exc}"
        ) from None
    if any(p.coeff_monomial(1) != 0 for p in fp):
        raise NotPolynomial("f(x_eq) != 0 exactly: V's centre is not an equilibrium")
    Vq = exact_terms(V)
    Vp = sp.Poly.from_dict(
        {a: sp.Rational(c.numerator, c.denominator) for a, c in Vq.items()}, *d, domain="QQ"
    )
    poly = sp.Poly(0, *d, domain="QQ")
    for i in range(n):
        poly = poly + Vp.diff(d[i]) * fp[i]
    Vd: QPoly = {tuple(m): exact_fraction(c) for m, c in poly.terms() if c != 0}
    if any(sum(m) == 0 for m in Vd):
        raise NotPolynomial("f(x_eq) != 0: V' has a constant term")  # cannot happen, grad V(0)=0
    low = min((sum(m) for m in Vd), default=2)
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
    m = A.shape[0]
    out = [[Fraction(0)] * m for _ in range(m)]
    for i in range(m):
        for j in range(i, m):
            v = Fraction(round(Fraction(float(0.5 * (A[i, j] + A[j, i]))) / grid)) * grid
            out[i][j] = out[j][i] = v
    return out


def exact_matrix(Q: Any, rounded: bool) -> list[list[Fraction]]:
    """A Gram matrix in exact arithmetic: a stored (already rounded) one read entry by entry,
    else a float matrix by :func:`round_matrix`."""
    return [[exact_fraction(v) for v in row] for row in Q] if rounded else round_matrix(Q)


def is_symmetric(R: list[list[Fraction]]) -> bool:
    """Whether the exact square matrix ``R`` is symmetric."""
    return all(R[i][j] == R[j][i] for i in range(len(R)) for j in range(i))


def matrix_digest(*mats: list[list[Fraction]]) -> str:
    h = hashlib.sha256()
    for M in mats:
        h.update(repr([[str(v) for v in row] for row in M]).encode())
        h.update(b";")
    return h.hexdigest()


@dataclass(frozen=True)
class SosCheck:
    """Outcome of :func:`check_certificate`: ``ok`` only if every exact check passed."""

    ok: bool
    reason: str
    residual: float | None = None  # max |coefficient| of the identity before projection
    min_pivot: float | None = None  # least LDL' pivot of the projected Q0 (and of Q1)
    Q0: list[list[Fraction]] | None = None
    Q1: list[list[Fraction]] | None = None
    meta: dict[str, Any] = field(default_factory=dict)


def project_gram(
    basis0: list[Mono], R0: list[list[Fraction]], target: QPoly, *, exact: bool = False
) -> tuple[list[list[Fraction]] | None, Fraction | None, str]:
    """``(P, residual, why)``: the rounded Gram matrix ``R0`` projected orthogonally (Frobenius,
    exact rationals) onto the affine space where ``m0' P m0 = target`` (module doc: each
    monomial's ``N_a`` entries move by ``(r_a - s_a) / N_a``), the largest coefficient moved,
    and ``P`` None with the reason when the identity cannot hold. ``exact=True`` (a stored
    certificate): nothing is moved; ``P`` is ``R0`` when the identity holds exactly as given."""
    Ps, residual, why = project_grams([(basis0, R0)], target, exact=exact)
    return (None if Ps is None else Ps[0]), residual, why


def project_grams(
    blocks: list[tuple[list[Mono], list[list[Fraction]]]], target: QPoly, *, exact: bool = False
) -> tuple[list[list[list[Fraction]]] | None, Fraction | None, str]:
    """:func:`project_gram` for a sum of Gram forms ``sum_b m_b' P_b m_b = target``, projected
    jointly (Frobenius norm over all blocks): every entry ``(b, i, j)`` yields one monomial
    ``m_bi m_bj``, so the constraints of distinct monomials still touch disjoint entries and each
    monomial's ``N_a`` entries, over all blocks, move by ``(r_a - s_a) / N_a``. ``exact=True``
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


def identity_refusal(data: ExactData, level: Fraction, eps: Fraction) -> str | None:
    """Why the identity ``-V' - eps|d|^2k - lambda (c - V) = sigma`` cannot prove the level
    (``level`` or ``eps`` not positive, or ``V'`` not starting at an even degree >= 2), else
    None."""
    if not (level > 0 and eps > 0):
        return f"level and eps must be > 0 (got {as_float(level)}, {as_float(eps)})"
    k, rem = divmod(data.low, 2)
    if rem or k < 1:
        return (f"the lowest degree of V' is {data.low}, not even: V' is not negative definite "
                "near x_eq")  # fmt: skip
    return None


def check_certificate(
    data: ExactData,
    level: Any,
    eps: Any,
    basis0: list[Mono],
    Q0: Any,
    basis1: list[Mono] | None,
    Q1: Any,
    *,
    rounded: bool = False,
) -> SosCheck:
    """Exact Peyrl-Parrilo check of ``-V' - eps|d|^2k - lambda (c - V) = m0' Q0 m0``.

    ``Q0``, ``Q1``: float Gram matrices (rounded here) or, with ``rounded=True``, rational ones
    taken as they are (``Q0`` is projected in both cases; ``Q1`` is never changed). ``basis1`` None
    or empty: ``lambda = 0``. Returns ``ok`` True only if the projected ``Q0`` and ``Q1`` are
    positive definite exactly and ``eps``, ``level`` > 0.
    """
    c, e = Fraction(level), Fraction(eps)
    refused = identity_refusal(data, c, e)
    if refused:
        return SosCheck(False, refused)
    n, k = data.n, data.low // 2
    if any(len(b) != n for b in basis0) or len(Q0) != len(basis0):
        return SosCheck(False, "basis0 and Q0 do not match")
    R0 = [[exact_fraction(v) for v in row] for row in Q0] if rounded else round_matrix(Q0)
    if any(R0[i][j] != R0[j][i] for i in range(len(R0)) for j in range(i)):
        return SosCheck(False, "Q0 is not symmetric")
    target = poly_lin((Fraction(-1), data.Vdot), (-e, norm_power(n, k)))
    R1: list[list[Fraction]] = []
    if basis1:
        if len(Q1) != len(basis1) or any(len(b) != n for b in basis1):
            return SosCheck(False, "basis1 and Q1 do not match")
        R1 = [[exact_fraction(v) for v in row] for row in Q1] if rounded else round_matrix(Q1)
        if any(R1[i][j] != R1[j][i] for i in range(len(R1)) for j in range(i)):
            return SosCheck(False, "Q1 is not symmetric")
        lam = gram_poly(basis1, R1)
        c_minus_V = poly_lin((Fraction(-1), data.V), (c, {tuple([0] * n): Fraction(1)}))
        target = poly_lin((Fraction(1), target), (Fraction(-1), poly_mul(lam, c_minus_V)))
    ok1, piv1 = exact_positive_definite(R1)
    if not ok1:
        return SosCheck(False, "the multiplier's Gram matrix Q1 is not positive definite (exact)",
                        min_pivot=as_float(min(piv1)) if piv1 else None, Q1=R1)  # fmt: skip
    P, residual, why = project_gram(basis0, R0, target, exact=rounded)
    if P is None:
        return SosCheck(False, why, None if residual is None else as_float(residual))
    assert residual is not None
    ok0, piv0 = exact_positive_definite(P)
    pivots = piv0 + piv1
    mp = as_float(min(pivots)) if pivots else None
    meta = {"digest": matrix_digest(P, R1), "eps": str(e), "k": k}
    if not ok0:
        return SosCheck(False, "the projected Gram matrix Q0 is not positive definite (exact)",
                        as_float(residual), mp, P, R1, meta)  # fmt: skip
    return SosCheck(True, "identity exact, Q0 and Q1 positive definite (exact)",
                    as_float(residual), mp, P, R1, meta)  # fmt: skip


def preconditions(system: Any, V: Any, level: float) -> tuple[ExactData | None, str]:
    """The exact data of the check, or None and why the check does not apply: the field or V
    not polynomial, V's centre not an exact equilibrium, ``{V <= level}`` not proved bounded
    (V >= mu |d|^2 from its Gram matrix, :func:`roa.proof.cover.gram_cover`), or V' starting
    at an odd degree."""
    if getattr(system, "parameters", None):
        return None, "the system has uncertain parameters: the SOS check proves one field"
    if system.equilibrium is None or not np.array_equal(np.asarray(V.center, float), system.x_eq):
        return None, "V must be centred at the system's equilibrium"
    try:
        data = exact_data(system, V)  # refuses f(x_eq) != 0 (exact constant terms)
    except NotPolynomial as exc:
        return None, f"not polynomial: {exc}"
    why = bounded_and_even(V, level, data.low)
    return (None, why) if why else (data, "")


def bounded_and_even(V: Any, level: float, low: int) -> str:
    """Why the check does not apply to V at ``level`` whatever the field (``{V <= level}`` not
    proved bounded by V's Gram matrix, :func:`roa.proof.cover.gram_cover`; V' starting at an
    odd degree ``low``), or "" when it does."""
    from roa.proof.cover import gram_cover

    if gram_cover(V, level) is None:
        return ("V >= mu |d|^2 not proved (no positive definite Gram matrix over the linear "
                "monomials): {V <= level} may be unbounded")  # fmt: skip
    return "the lowest degree of V' is odd" if low % 2 else ""


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


def parse_eps(raw: Any) -> Fraction:
    """The ``eps`` of a stored certificate (:func:`parse_rational`); ValueError otherwise."""
    return parse_rational(raw, "eps")


def as_float(x: Fraction) -> float:
    """``x`` as a float for reports (+-inf beyond the float range)."""
    try:
        return float(x)
    except OverflowError:
        return float("inf") if x > 0 else float("-inf")


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
    """The data in variables ``y`` with ``d = diag(scale) y``: any positive scale is sound, as
    the map is a bijection and ``|y|^(2k) > 0`` for ``y != 0``; it only balances the program's
    coefficients."""
    return ExactData(data.n, data.center, scaled(data.V, scale), scaled(data.Vdot, scale),
                     data.low)  # fmt: skip


def stored_scale(cert: Any, n: int) -> tuple[Fraction, ...] | None:
    """The ``scale`` of a stored certificate (``n`` positive rationals), None when absent;
    ValueError when malformed."""
    raw = cert.get("scale") if isinstance(cert, dict) else None
    if raw is None:
        return None
    if not isinstance(raw, list) or len(raw) != n:
        raise ValueError(f"scale must be a list of {n} positive rationals")
    scale = tuple(parse_rational(r, f"scale[{i}]") for i, r in enumerate(raw))
    if not all(r > 0 for r in scale):
        raise ValueError("scale must be positive rationals")
    return scale


def recheck_stored(system: Any, V: Any, level: float, meta: dict[str, Any]) -> Any:
    """Re-check a stored exact SOS certificate (``meta``: ``certificate`` with ``basis0``,
    ``basis1``, ``Q0``, ``Q1`` as rationals, and ``eps``) for ``system`` and ``V`` at ``level``,
    in exact arithmetic and without any solver: ``certified`` only if every check of
    :func:`check_certificate` passes on the stored matrices (plus the exact equilibrium and the
    bounded sublevel set that :class:`roa.certification.SosValidator` requires)."""
    import time

    from roa.proof.validation import Validation
    from roa.status import Verdict

    t0 = time.perf_counter()

    def out(status: Verdict, message: str, **extra: Any) -> Validation:
        m = {"method": "sos-exact", "M": np.eye(int(V.n)).tolist(), **extra}
        return Validation(status, float(level), 0, time.perf_counter() - t0, message=message,
                          meta=m)  # fmt: skip

    cert = meta.get("certificate")
    try:
        if not isinstance(cert, dict):
            raise ValueError("no certificate (bases and Gram matrices) in the file")
        n = int(V.n)
        eps = parse_eps(meta.get("eps"))
        if "putinar" in cert:  # a recast (non-polynomial) field's constrained certificate
            from roa.proof.sos_putinar import recheck_recast

            ok, reason, rres = recheck_recast(system, V, level, cert, eps)
            fig = {} if rres is None else {"residual": rres.residual, "min_pivot": rres.min_pivot}
            if not ok:
                return out(Verdict.INCONCLUSIVE, f"stored SOS certificate refused: {reason}",
                           **fig)  # fmt: skip
            assert rres is not None
            return out(Verdict.CERTIFIED, "stored SOS certificate (recast field) re-checked "
                       f"exactly: {reason}", **fig, **rres.meta)  # fmt: skip
        basis0 = parse_basis(cert.get("basis0"), n, "basis0")
        basis1 = parse_basis(cert.get("basis1") or [], n, "basis1")
        Q0 = parse_matrix(cert.get("Q0"), len(basis0), "Q0")
        Q1 = parse_matrix(cert.get("Q1") or [], len(basis1), "Q1")
    except (ValueError, TypeError, ZeroDivisionError) as exc:
        return out(Verdict.INCONCLUSIVE, f"malformed SOS certificate: {exc}")
    data, why = preconditions(system, V, level)
    if data is None:
        return out(Verdict.INCONCLUSIVE, why)
    try:
        scale = stored_scale(cert, n)
    except ValueError as exc:
        return out(Verdict.INCONCLUSIVE, f"malformed SOS certificate: {exc}")
    if scale is not None:
        data = scale_data(data, scale)
    res = check_certificate(data, level, eps, basis0, Q0, basis1, Q1, rounded=True)
    if not res.ok:
        return out(Verdict.INCONCLUSIVE, f"stored SOS certificate refused: {res.reason}",
                   residual=res.residual, min_pivot=res.min_pivot)  # fmt: skip
    return out(Verdict.CERTIFIED, f"stored SOS certificate re-checked exactly: {res.reason}",
               residual=res.residual, min_pivot=res.min_pivot, **res.meta)  # fmt: skip
