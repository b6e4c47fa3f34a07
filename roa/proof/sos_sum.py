"""Exact check of an SOS certificate whose SOS parts are sums of Gram blocks (sparse SOS).

**Claim.** With the exact data of :mod:`roa.proof.sos_check` (``V``, ``V'`` in ``d = x - x_eq``),
a level ``c > 0`` and ``eps > 0``, the checker proves in exact rational arithmetic the identity::

    -V'(d) - eps |d|^(2k) - lambda(d) (c - V(d)) = sigma(d),
    sigma = sum_b s_b(d)' S_b s_b(d),   lambda = sum_j l_j(d)' L_j l_j(d),

with every ``S_b`` and ``L_j`` positive definite (exact leading minors, python-flint). ``sigma``
and ``lambda`` are then sums of squares, so on ``{V <= c}``: ``-V' >= eps |d|^(2k) > 0`` for
``d != 0``, exactly as for one Gram matrix (:mod:`roa.proof.sos_check`, whose preconditions are
the same: exact equilibrium, ``{V <= c}`` bounded by V's Gram cover, ``2k`` the even lowest
degree of ``V'``). The argument does not depend on how the bases were chosen: the correlative
sparsity of :mod:`roa.search.sos_sparse` (one block per clique of a chordal extension of the
variables' interaction graph, plus the blocks that ``lambda V`` needs) only makes the program
small. The check is the same for any choice, and a wrong choice only makes it fail.

**Rounding and projection** (Peyrl-Parrilo, for several blocks): the float blocks are rounded to
dyadic rationals; the ``L_j`` are kept as rounded; the ``S_b`` are projected jointly (Frobenius
norm over all blocks) onto the affine space of the identity (:func:`roa.proof.sos_check.project_grams`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from roa.proof.exact import exact_positive_definite
from roa.proof.sos_check import (
    ExactData,
    Mono,
    as_float,
    exact_matrix,
    gram_poly,
    identity_refusal,
    is_symmetric,
    matrix_digest,
    norm_power,
    parse_basis,
    parse_eps,
    parse_matrix,
    poly_lin,
    poly_mul,
    project_grams,
    scale_data,
    stored_scale,
)

Block = tuple[list[Mono], Any]
Matrix = list[list[Fraction]]

#: Bound on the number of stored blocks (beyond it a file is refused before any arithmetic).
MAX_BLOCKS = 50_000


@dataclass(frozen=True)
class SumCheck:
    """Outcome of :func:`check_sum`: ``ok`` only if every exact check passed; ``sigma`` (the
    projected blocks) and ``lam`` (the rounded multiplier blocks) as rationals."""

    ok: bool
    reason: str
    residual: float | None = None  # max |coefficient| of the identity before projection
    min_pivot: float | None = None  # least LDL' pivot over all blocks
    sigma: list[Matrix] | None = None
    lam: list[Matrix] | None = None
    meta: dict[str, Any] = field(default_factory=dict)


def check_sum(data: ExactData, level: Any, eps: Any, sigma: list[Block], lam: list[Block], *,
              rounded: bool = False) -> SumCheck:  # fmt: skip
    """Exact check of ``-V' - eps|d|^2k - (sum_j l_j' L_j l_j)(c - V) = sum_b s_b' S_b s_b``.

    ``sigma``, ``lam``: lists of ``(basis, Gram)``, floats (rounded here) or, with
    ``rounded=True``, rationals taken as they are. ``ok`` True only if the projected ``S_b`` and
    the ``L_j`` are all positive definite exactly and ``eps``, ``level`` > 0."""
    c, e = Fraction(level), Fraction(eps)
    refused = identity_refusal(data, c, e)
    if refused:
        return SumCheck(False, refused)
    k = data.low // 2
    if not sigma:
        return SumCheck(False, "no Gram block for sigma")
    n = data.n
    blocks: list[tuple[list[Mono], Matrix]] = []
    for what, parts in (("sigma", sigma), ("lambda", lam)):
        for b, (basis, Q) in enumerate(parts):
            if any(len(m) != n for m in basis) or len(Q) != len(basis):
                return SumCheck(False, f"{what} block {b}: basis and Gram matrix do not match")
            R = exact_matrix(Q, rounded)
            if not is_symmetric(R):
                return SumCheck(False, f"{what} block {b} is not symmetric")
            blocks.append((list(basis), R))
    S, L = blocks[: len(sigma)], blocks[len(sigma) :]
    target = poly_lin((Fraction(-1), data.Vdot), (-e, norm_power(n, k)))
    pivots: list[Fraction] = []
    if L:
        lam_poly = poly_lin(*((Fraction(1), gram_poly(b, R)) for b, R in L))
        c_minus_V = poly_lin((Fraction(-1), data.V), (c, {tuple([0] * n): Fraction(1)}))
        target = poly_lin((Fraction(1), target), (Fraction(-1), poly_mul(lam_poly, c_minus_V)))
        for j, (_, R) in enumerate(L):
            ok, piv = exact_positive_definite(R)
            pivots += piv
            if not ok:
                return SumCheck(False, f"the multiplier's Gram block {j} is not positive "
                                "definite (exact)", min_pivot=as_float(min(piv)) if piv else None,
                                lam=[R for _, R in L])  # fmt: skip
    P, residual, why = project_grams(S, target, exact=rounded)
    if P is None:
        return SumCheck(False, why, None if residual is None else as_float(residual))
    assert residual is not None
    for b, Pb in enumerate(P):
        ok, piv = exact_positive_definite(Pb)
        pivots += piv
        if not ok:
            return SumCheck(False, f"the projected Gram block {b} of sigma is not positive "
                            "definite (exact)", as_float(residual), as_float(min(piv)) if piv
                            else None, P, [R for _, R in L])  # fmt: skip
    meta = {"digest": matrix_digest(*P, *(R for _, R in L)), "eps": str(e), "k": k}
    return SumCheck(True, f"identity exact, {len(P)} + {len(L)} Gram blocks positive definite "
                    "(exact)", as_float(residual), as_float(min(pivots)), P, [R for _, R in L],
                    meta)  # fmt: skip


def to_json(sigma: list[tuple[list[Mono], Matrix]], lam: list[tuple[list[Mono], Matrix]],
            **extra: Any) -> dict[str, Any]:  # fmt: skip
    """The stored form of a sum certificate: ``{"sigma": [...], "lambda": [...], **extra}``, each
    block ``{"basis": [[exponents]], "Q": [["p/q"]]}``."""

    def one(basis: list[Mono], Q: Matrix) -> dict[str, Any]:
        return {"basis": [list(m) for m in basis], "Q": [[str(v) for v in row] for row in Q]}

    return {"sigma": [one(b, Q) for b, Q in sigma], "lambda": [one(b, Q) for b, Q in lam], **extra}


def parse(raw: Any, n: int) -> tuple[list[Block], list[Block]]:
    """The blocks of a stored sum certificate (``ValueError`` naming what is malformed)."""
    if not isinstance(raw, dict):
        raise ValueError("the sum certificate must be an object with 'sigma' and 'lambda'")
    out: list[list[Block]] = []
    for what in ("sigma", "lambda"):
        items = raw.get(what)
        if not isinstance(items, list) or len(items) > MAX_BLOCKS:
            raise ValueError(f"{what} must be a list of at most {MAX_BLOCKS} blocks")
        parts: list[Block] = []
        for b, item in enumerate(items):
            if not isinstance(item, dict):
                raise ValueError(f"{what} block {b} must be an object with 'basis' and 'Q'")
            basis = parse_basis(item.get("basis"), n, f"{what} block {b} basis")
            parts.append((basis, parse_matrix(item.get("Q"), len(basis), f"{what} block {b} Q")))
        out.append(parts)
    return out[0], out[1]


def recheck_sum(system: Any, V: Any, level: float, meta: dict[str, Any]) -> Any:
    """Re-check a stored sum certificate (``meta["certificate"]["sum"]`` and ``meta["eps"]``)
    without any solver: ``certified`` only if :func:`check_sum` passes on the stored rationals
    (plus :func:`roa.proof.sos_check.preconditions`)."""
    import time

    from roa.proof.sos_check import preconditions
    from roa.proof.validation import Validation
    from roa.status import Verdict

    t0 = time.perf_counter()

    def out(status: Verdict, message: str, **extra: Any) -> Validation:
        m = {"method": "sos-exact", "M": np.eye(int(V.n)).tolist(), **extra}
        return Validation(status, float(level), 0, time.perf_counter() - t0, message=message,
                          meta=m)  # fmt: skip

    try:
        eps = parse_eps(meta.get("eps"))
        sigma, lam = parse(meta["certificate"]["sum"], int(V.n))
    except (ValueError, TypeError, ZeroDivisionError, KeyError) as exc:
        return out(Verdict.INCONCLUSIVE, f"malformed SOS certificate: {exc}")
    data, why = preconditions(system, V, level)
    if data is None:
        return out(Verdict.INCONCLUSIVE, why)
    try:
        scale = stored_scale(meta["certificate"], data.n)
    except ValueError as exc:
        return out(Verdict.INCONCLUSIVE, f"malformed SOS certificate: {exc}")
    if scale is not None:
        data = scale_data(data, scale)
    res = check_sum(data, level, eps, sigma, lam, rounded=True)
    if not res.ok:
        return out(Verdict.INCONCLUSIVE, f"stored SOS certificate refused: {res.reason}",
                   residual=res.residual, min_pivot=res.min_pivot)  # fmt: skip
    return out(Verdict.CERTIFIED, f"stored sparse SOS certificate re-checked exactly: "
               f"{res.reason}", residual=res.residual, min_pivot=res.min_pivot,
               **res.meta)  # fmt: skip
