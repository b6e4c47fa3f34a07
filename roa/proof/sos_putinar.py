"""Exact check of a constrained SOS certificate of a level (recast fields, Putinar form).

**Claim.** For the recast data of :func:`roa.proof.recast.recast_exact` (``N`` with the sign of
``V'``, equalities ``h_e``, inequalities ``g_j`` that hold at ``z(x)`` for every state ``x``), a
level ``c > 0`` and ``eps > 0``, the checker proves in exact rational arithmetic the polynomial
identity (coefficient by coefficient) in ``z``::

    -N - eps |d|^(2k) - lambda (c - V) - sum_j sigma_j g_j - sum_e mu_e h_e = m0' Q0 m0,

with ``lambda = m1' Q1 m1``, ``sigma_j = mj' Qj mj`` and ``Q0``, ``Q1``, every ``Qj`` positive
definite (exact leading minors, python-flint); ``mu_e`` are free polynomials with rational
coefficients. At ``z(x)`` with ``V(x) <= c``: every ``h_e = 0``, ``g_j >= 0``, so
``-N(z(x)) >= eps |d|^(2k) > 0`` for ``d != 0``, i.e. ``V' < 0`` on ``{V <= c}`` minus ``x_eq``
for the original field (``V' = N / Den``, ``Den > 0``). ``{V <= c}`` is bounded by the Gram cover
of ``V`` as in :mod:`roa.proof.sos_check`; then it lies in the region of attraction (LaSalle).

**Parameter boxes** (:mod:`roa.proof.recast_box`): the uncertain parameters are the last
variables of ``z`` (normalised to ``[-1, 1]``) and their box constraints ``1 - w_j^2 >= 0`` the
last inequalities; the argument above then holds for every parameter of the box. A stored
certificate's box must equal the system's (:func:`recheck_recast`), which alone is used.

**Rounding and projection.** The multipliers' float Gram matrices and coefficients are rounded to
dyadic rationals (never projected; a stored certificate is taken as it is). The linear monomial
``q_a`` of each circle cannot be matched by ``Q0`` (its basis has no constant): the constant
coefficient of ``mu_a`` is set exactly so that the residual there is 0 (``q_a`` is linear in no
other equality). Then ``Q0`` is projected as in :mod:`roa.proof.sos_check`; the identity is
re-evaluated exactly after the projection.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from roa.proof.exact import exact_positive_definite
from roa.proof.recast import RecastData
from roa.proof.recast_box import box_json
from roa.proof.sos_check import (
    Mono,
    QPoly,
    as_float,
    bounded_and_even,
    exact_fraction,
    exact_matrix,
    gram_poly,
    is_symmetric,
    matrix_digest,
    norm_power,
    parse_rational,
    poly_lin,
    poly_mul,
    project_gram,
    round_matrix,
)


@dataclass(frozen=True)
class Blocks:
    """A certificate's bases and matrices: ``grams`` ``[(m0, Q0), (m1, Q1), (m_j, Q_j)...]``
    (one per inequality, in order) and ``free`` ``[(basis, coefficients)]`` (one per equality)."""

    grams: list[tuple[list[Mono], Any]]
    free: list[tuple[list[Mono], Any]]

    def to_json(self) -> dict[str, Any]:
        return {"grams": [{"basis": [list(b) for b in B], "Q": [[str(v) for v in r] for r in Q]}
                          for B, Q in self.grams],
                "free": [{"basis": [list(b) for b in B], "coeffs": [str(v) for v in c]}
                         for B, c in self.free]}  # fmt: skip


@dataclass(frozen=True)
class PutinarCheck:
    """Outcome of :func:`check_putinar`: ``ok`` only if every exact check passed."""

    ok: bool
    reason: str
    residual: float | None = None
    min_pivot: float | None = None
    blocks: Blocks | None = None
    meta: dict[str, Any] = field(default_factory=dict)


def times_polys(data: RecastData, level: Fraction) -> list[QPoly]:
    """What each Gram block multiplies: 1, ``c - V``, then every ``g_j``."""
    zero = tuple([0] * data.nv)
    c_minus_V = poly_lin((Fraction(-1), data.V), (level, {zero: Fraction(1)}))
    return [{zero: Fraction(1)}, c_minus_V, *[g for _, g in data.inequalities]]


def target_poly(data: RecastData, eps: Fraction) -> QPoly:
    """``-N - eps |d|^(2k)`` in the ``nv`` variables."""
    k = data.low // 2
    pad = data.nv - data.n
    norm = {m + (0,) * pad: c for m, c in norm_power(data.n, k).items()}
    return poly_lin((Fraction(-1), data.N), (-eps, norm))


def check_putinar(data: RecastData, level: Any, eps: Any, blocks: Blocks, *, rounded: bool = False
                  ) -> PutinarCheck:  # fmt: skip
    """Exact check of the identity of the module docstring. ``rounded=False``: the float
    matrices and coefficients are rounded first; ``rounded=True``: they are rationals, taken as
    they are, and the identity must hold exactly as stored (nothing is projected or set)."""
    c, e = Fraction(level), Fraction(eps)
    if not (c > 0 and e > 0):
        return PutinarCheck(False, f"level and eps must be > 0 (got {as_float(c)}, {as_float(e)})")
    k, rem = divmod(data.low, 2)
    if rem or k < 1:
        return PutinarCheck(False, f"the lowest degree of V' is {data.low}, not even")
    if data.bounded_level is not None and c > data.bounded_level:
        return PutinarCheck(
            False,
            f"the recast's angle bounds hold on {{V <= "
            f"{as_float(data.bounded_level)}}} only, not at level {as_float(c)}",
        )
    times = times_polys(data, c)
    if len(blocks.grams) != len(times) or len(blocks.free) != len(data.equalities):
        return PutinarCheck(
            False,
            "the certificate's blocks do not match the recast's "
            f"({len(times)} Gram blocks, {len(data.equalities)} equalities)",
        )
    grams: list[tuple[list[Mono], list[list[Fraction]]]] = []
    for idx, (basis, Q) in enumerate(blocks.grams):
        if any(len(b) != data.nv for b in basis) or len(Q) != len(basis):
            return PutinarCheck(False, f"Gram block {idx}: basis and matrix do not match")
        R = exact_matrix(Q, rounded)
        if not is_symmetric(R):
            return PutinarCheck(False, f"Gram block {idx} is not symmetric")
        grams.append((basis, R))
    free: list[tuple[list[Mono], list[Fraction]]] = []
    for idx, (basis, coeffs) in enumerate(blocks.free):
        if any(len(b) != data.nv for b in basis) or len(coeffs) != len(basis):
            return PutinarCheck(False, f"equality multiplier {idx}: basis and coefficients differ")
        cs = [exact_fraction(v) for v in coeffs] if rounded else [
            round_matrix([[float(v)]])[0][0] for v in coeffs]  # fmt: skip
        free.append((list(basis), cs))
    target = target_poly(data, e)
    for (basis, R), t in zip(grams[1:], times[1:], strict=True):
        target = poly_lin((Fraction(1), target), (Fraction(-1), poly_mul(gram_poly(basis, R), t)))
    zero = tuple([0] * data.nv)
    for (basis, cs), (_, h) in zip(free, data.equalities, strict=True):
        mu: QPoly = {}
        for b, v in zip(basis, cs, strict=True):
            mu[b] = mu.get(b, Fraction(0)) + v
        target = poly_lin((Fraction(1), target), (Fraction(-1), poly_mul(mu, h)))
    for idx, (basis, cs) in enumerate(free if not rounded else []):  # fresh: each circle's
        # linear monomial sets mu's constant (a stored certificate is checked as it is)
        h = data.equalities[idx][1]
        lin = [m for m in h if sum(m) == 1]
        if len(lin) != 1 or zero not in basis:
            continue
        others = [m for j, (_, g) in enumerate(data.equalities) if j != idx for m in g]
        if lin[0] in others:
            continue
        delta = target.get(lin[0], Fraction(0)) / h[lin[0]]
        if delta:
            cs[basis.index(zero)] += delta
            target = poly_lin((Fraction(1), target), (-delta, h))
    basis0, R0 = grams[0]
    P, residual, why = project_gram(basis0, R0, target, exact=rounded)
    if P is None:
        return PutinarCheck(False, why, None if residual is None else as_float(residual))
    assert residual is not None
    final = Blocks([(basis0, P), *grams[1:]], free)
    pivots: list[Fraction] = []
    for idx, (_, R) in enumerate(final.grams):
        ok, piv = exact_positive_definite(R)
        pivots += piv
        if not ok:
            what = "Q0 (after projection)" if idx == 0 else (
                "the level multiplier's Q1" if idx == 1 else
                f"the multiplier of '{data.inequalities[idx - 2][0]}'")  # fmt: skip
            return PutinarCheck(False, f"the Gram matrix of {what} is not positive definite "
                                "(exact)", as_float(residual),
                                as_float(min(piv)) if piv else None)  # fmt: skip
    mp = as_float(min(pivots)) if pivots else None
    meta = {"digest": matrix_digest(*[R for _, R in final.grams],
                                    [[v] for _, cs in free for v in cs]),
            "eps": str(e), "k": k, "recast": data.description}  # fmt: skip
    return PutinarCheck(
        True,
        "identity exact with the recast's constraints, every Gram matrix positive definite (exact)",
        as_float(residual),
        mp,
        final,
        meta,
    )


def recast_preconditions(system: Any, V: Any, level: float, taylor: int | None,
                         scale: Any) -> tuple[RecastData | None, str]:  # fmt: skip
    """The recast data at ``level``, or None and why the check does not apply: V not centred at
    the equilibrium, a term that cannot be recast (named), ``{V <= level}`` not proved bounded
    (:func:`roa.proof.cover.gram_cover`), V' starting at an odd degree."""
    import numpy as np

    from roa.proof.recast import recast_exact
    from roa.proof.sos_check import NotPolynomial

    if system.equilibrium is None or not np.array_equal(np.asarray(V.center, float), system.x_eq):
        return None, "V must be centred at the system's equilibrium"
    try:
        data = recast_exact(system, V, taylor=taylor, scale=scale, level=level)
    except NotPolynomial as exc:
        return None, f"no exact recast: {exc}"
    why = bounded_and_even(V, level, data.low)
    return (None, why) if why else (data, "")


def parse_blocks(raw: Any, nv: int) -> Blocks:
    """A stored certificate's blocks (``Blocks.to_json``), bounded before any arithmetic."""
    from roa.proof.sos_check import MAX_BASIS, parse_basis, parse_matrix

    if not isinstance(raw, dict):
        raise ValueError("no constrained certificate in the file")
    grams, free = [], []
    for key in ("grams", "free"):
        items = raw.get(key, [])
        if not isinstance(items, list) or len(items) > MAX_BASIS:
            raise ValueError(f"putinar.{key} must be a list of at most {MAX_BASIS} objects")
        if not all(isinstance(item, dict) for item in items):
            raise ValueError(f"putinar.{key}: every entry must be an object")
    for k, g in enumerate(raw.get("grams", [])):
        basis = parse_basis(g.get("basis"), nv, f"grams[{k}].basis")
        grams.append((basis, parse_matrix(g.get("Q"), len(basis), f"grams[{k}].Q")))
    for k, f in enumerate(raw.get("free", [])):
        basis = parse_basis(f.get("basis"), nv, f"free[{k}].basis")
        coeffs = f.get("coeffs")
        if not isinstance(coeffs, list) or len(coeffs) != len(basis):
            raise ValueError(f"free[{k}].coeffs must match its basis")
        free.append((basis, [parse_rational(v, f"free[{k}].coeffs[{i}]")
                             for i, v in enumerate(coeffs)]))  # fmt: skip
    return Blocks(grams, free)


def recheck_recast(system: Any, V: Any, level: float, cert: dict[str, Any], eps: Fraction
                   ) -> tuple[bool, str, PutinarCheck | None]:  # fmt: skip
    """Re-check a stored recast certificate exactly, without a solver. The recast (variables,
    constraints, denominator) is recomputed from the system; only the multipliers, the Taylor
    order and the variables' scale (any positive rationals are sound) come from the file."""
    taylor = cert.get("taylor")
    raw_scale = cert.get("scale")
    if type(taylor) is not int or not isinstance(raw_scale, list):
        raise ValueError("taylor (an odd integer) and scale (rationals) are required")
    if len(raw_scale) != V.n:
        raise ValueError(f"scale must hold {V.n} rationals")
    if any(len(str(r)) > 100 for r in raw_scale):
        raise ValueError("scale: at most 100 characters each")
    scale = tuple(parse_rational(r, f"scale[{i}]") for i, r in enumerate(raw_scale))
    if not all(s > 0 for s in scale):
        raise ValueError("scale must be positive rationals like '1/4'")
    data, why = recast_preconditions(system, V, level, taylor, scale)
    if data is None:
        return False, why, None
    stored_box = cert.get("parameters")
    if (stored_box or None) != (box_json(data.parameters) or None):  # the system's box decides
        return False, (f"the certificate was made for the parameter box {stored_box}, the system's "
                       f"is {box_json(data.parameters) or 'none'}"), None  # fmt: skip
    blocks = parse_blocks(cert.get("putinar"), data.nv)
    res = check_putinar(data, level, eps, blocks, rounded=True)
    return res.ok, res.reason, res
