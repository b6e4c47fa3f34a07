"""Exact check of an SOS certificate whose large Gram blocks are scaled diagonally dominant (SDSOS).

**Claim.** With the exact data of :mod:`roa.proof.sos_check` (``V``, ``V'`` in ``d = x - x_eq``),
a level ``c > 0`` and ``eps > 0``, the checker proves in exact rational arithmetic the identity
of :mod:`roa.proof.sos_sum`::

    -V'(d) - eps |d|^(2k) - lambda(d) (c - V(d)) = sum_b s_b(d)' S_b s_b(d),
    lambda = sum_j l_j(d)' L_j l_j(d),

where every ``L_j`` and every ``S_b`` without a scaling is positive definite (exact leading
minors, python-flint), and every ``S_b`` with a stored scaling ``w`` (positive rationals) is
*strictly scaled diagonally dominant*: ``w_i S_ii > sum_{j != i} |S_ij| w_j`` for every row
``i``, checked exactly. Then ``D S D`` (``D = diag(w)``) is symmetric, strictly diagonally
dominant with a positive diagonal, hence positive definite (Gershgorin), and so is ``S``. The
argument after that is :mod:`roa.proof.sos_sum`'s: on ``{V <= c}``, ``-V' >= eps |d|^(2k) > 0``
for ``d != 0``. The dominance check costs ``O(m^2)`` rational operations for a block of ``m``
monomials, where an exact LDL' costs ``O(m^3)`` on growing integers.

A scaled diagonally dominant matrix is exactly a sum of 2 x 2 positive semidefinite blocks
placed at rows ``(i, j)`` (Ahmadi and Majumdar 2019): the numerical program
(:mod:`roa.search.sos_sdd`) solves for such a sum with second-order cones, whose memory grows
linearly with the number of pairs, where the interior point's PSD block grows with its square.
The check does not depend on how the blocks or the scaling were found.

**Rounding and projection**: as in :mod:`roa.proof.sos_sum`: the blocks are rounded to dyadic
rationals; the ``L_j`` are kept; the ``S_b`` are projected jointly onto the identity's affine
space; a fresh scaling ``w`` is computed for each SDD block from the projected matrix (the
solution of ``M(S) w = 1`` for its comparison matrix ``M(S)``, rounded to dyadics), then
verified exactly. A stored certificate is taken as it is (nothing projected or recomputed).
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
    parse_rational,
    poly_lin,
    poly_mul,
    project_grams,
    scale_data,
    stored_scale,
)

Matrix = list[list[Fraction]]
#: A sigma block: basis, Gram matrix, and its scaling (None: checked by exact LDL').
SddBlock = tuple[list[Mono], Any, Any]
#: Bound on the number of stored blocks (beyond it a file is refused before any arithmetic).
MAX_BLOCKS = 50_000


def dominance_margin(S: Matrix, w: list[Fraction]) -> Fraction | None:
    """The least ``w_i S_ii - sum_{j != i} |S_ij| w_j`` over the rows (exact), None when ``w``
    does not have one positive entry per row."""
    m = len(S)
    if len(w) != m or any(not v > 0 for v in w):
        return None
    least: Fraction | None = None
    for i in range(m):
        row = S[i]
        slack = w[i] * row[i] - sum((abs(row[j]) * w[j] for j in range(m) if j != i and row[j]),
                                    Fraction(0))  # fmt: skip
        least = slack if least is None or slack < least else least
    return least if least is not None else Fraction(0)


def scaling(S: Matrix, bits: int = 40) -> list[Fraction] | None:
    """A scaling for the dominance check (floats only propose it): ``M(S)^-1 1`` for the
    comparison matrix ``M(S)`` (``|S_ii|`` on the diagonal, ``-|S_ij|`` off it), positive when
    ``S`` is scaled diagonally dominant; rounded to dyadics of ``bits`` bits. None when it is
    not positive."""
    A = np.array([[float(v) for v in row] for row in S])
    M = -np.abs(A)
    np.fill_diagonal(M, np.abs(np.diag(A)))
    try:
        w = np.linalg.solve(M, np.ones(len(A)))
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(w)) or np.any(w <= 0):
        return None
    w = w / np.max(w)
    grid = Fraction(1, 2**bits)
    out = [Fraction(round(Fraction(float(v)) / grid)) * grid for v in w]
    return out if all(v > 0 for v in out) else None


@dataclass(frozen=True)
class SddCheck:
    """Outcome of :func:`check_sdd`: ``ok`` only if every exact check passed; the projected
    ``sigma`` blocks, their scalings (None for LDL' blocks), the rounded ``lam`` blocks."""

    ok: bool
    reason: str
    residual: float | None = None
    min_pivot: float | None = None  # least LDL' pivot or least dominance slack
    sigma: list[Matrix] | None = None
    scalings: list[list[Fraction] | None] | None = None
    lam: list[Matrix] | None = None
    meta: dict[str, Any] = field(default_factory=dict)


def check_sdd(data: ExactData, level: Any, eps: Any, sigma: list[SddBlock],
              lam: list[tuple[list[Mono], Any]], *, rounded: bool = False) -> SddCheck:  # fmt: skip
    """Exact check of the identity of the module docstring. ``sigma``: ``(basis, Gram,
    scaling)`` with ``scaling`` None (LDL'), ``"fresh"`` (computed here after the projection:
    only with ``rounded=False``) or a list of positive rationals (as stored). ``rounded=True``:
    rational matrices taken as they are; the identity must hold exactly as stored."""
    c, e = Fraction(level), Fraction(eps)
    refused = identity_refusal(data, c, e)
    if refused:
        return SddCheck(False, refused)
    if not sigma:
        return SddCheck(False, "no Gram block for sigma")
    n, k = data.n, data.low // 2
    blocks: list[tuple[list[Mono], Matrix]] = []
    for what, parts in (("sigma", [(b, Q) for b, Q, _ in sigma]), ("lambda", lam)):
        for idx, (basis, Q) in enumerate(parts):
            if any(len(m) != n for m in basis) or len(Q) != len(basis):
                return SddCheck(False, f"{what} block {idx}: basis and Gram matrix do not match")
            R = exact_matrix(Q, rounded)
            if not is_symmetric(R):
                return SddCheck(False, f"{what} block {idx} is not symmetric")
            blocks.append((list(basis), R))
    S, L = blocks[: len(sigma)], blocks[len(sigma) :]
    target = poly_lin((Fraction(-1), data.Vdot), (-e, norm_power(n, k)))
    slacks: list[Fraction] = []
    if L:
        lam_poly = poly_lin(*((Fraction(1), gram_poly(b, R)) for b, R in L))
        c_minus_V = poly_lin((Fraction(-1), data.V), (c, {tuple([0] * n): Fraction(1)}))
        target = poly_lin((Fraction(1), target), (Fraction(-1), poly_mul(lam_poly, c_minus_V)))
        for j, (_, R) in enumerate(L):
            ok, piv = exact_positive_definite(R)
            slacks += piv
            if not ok:
                return SddCheck(False, f"the multiplier's Gram block {j} is not positive "
                                "definite (exact)")  # fmt: skip
    P, residual, why = project_grams(S, target, exact=rounded)
    if P is None:
        return SddCheck(False, why, None if residual is None else as_float(residual))
    assert residual is not None
    scalings: list[list[Fraction] | None] = []
    for idx, (Pb, (_, _, w)) in enumerate(zip(P, sigma, strict=True)):
        if w is None:
            ok, piv = exact_positive_definite(Pb)
            slacks += piv
            scalings.append(None)
            if not ok:
                return SddCheck(False, f"the projected Gram block {idx} of sigma is not "
                                "positive definite (exact)", as_float(residual))  # fmt: skip
            continue
        if isinstance(w, str):
            if rounded or w != "fresh":
                return SddCheck(False, f"sigma block {idx}: a stored scaling must be rationals")
            w = scaling(Pb)
            if w is None:
                return SddCheck(False, f"the projected Gram block {idx} of sigma is not "
                                "scaled diagonally dominant (no positive scaling)",
                                as_float(residual))  # fmt: skip
        margin = dominance_margin(Pb, list(w))
        if margin is None or not margin > 0:
            return SddCheck(False, f"the projected Gram block {idx} of sigma is not strictly "
                            "scaled diagonally dominant with its scaling (exact)",
                            as_float(residual))  # fmt: skip
        slacks.append(margin)
        scalings.append(list(w))
    lam_R = [R for _, R in L]
    meta = {"digest": matrix_digest(*P, *lam_R, [list(w) for w in scalings if w is not None]),
            "eps": str(e), "k": k}  # fmt: skip
    dd = sum(w is not None for w in scalings)
    return SddCheck(True, f"identity exact, {len(P) - dd} + {len(L)} Gram blocks positive "
                    f"definite, {dd} strictly scaled diagonally dominant (exact)",
                    as_float(residual), as_float(min(slacks)) if slacks else None, P, scalings,
                    lam_R, meta)  # fmt: skip


def to_json(sigma: list[tuple[list[Mono], Matrix, list[Fraction] | None]],
            lam: list[tuple[list[Mono], Matrix]], **extra: Any) -> dict[str, Any]:  # fmt: skip
    """The stored form: ``{"sigma": [{"basis", "Q", "scaling"?}], "lambda": [{"basis", "Q"}]}``,
    rationals as strings; a block with ``scaling`` is checked by dominance."""

    def one(basis: list[Mono], Q: Matrix) -> dict[str, Any]:
        return {"basis": [list(m) for m in basis], "Q": [[str(v) for v in row] for row in Q]}

    sig = []
    for b, Q, w in sigma:
        item = one(b, Q)
        if w is not None:
            item["scaling"] = [str(v) for v in w]
        sig.append(item)
    return {"sigma": sig, "lambda": [one(b, Q) for b, Q in lam], **extra}


def parse(raw: Any, n: int) -> tuple[list[SddBlock], list[tuple[list[Mono], Matrix]]]:
    """The blocks of a stored SDD certificate (``ValueError`` naming what is malformed)."""
    if not isinstance(raw, dict):
        raise ValueError("the sdd certificate must be an object with 'sigma' and 'lambda'")
    out: dict[str, list[Any]] = {}
    for what in ("sigma", "lambda"):
        items = raw.get(what)
        if not isinstance(items, list) or len(items) > MAX_BLOCKS:
            raise ValueError(f"{what} must be a list of at most {MAX_BLOCKS} blocks")
        parts: list[Any] = []
        for b, item in enumerate(items):
            if not isinstance(item, dict):
                raise ValueError(f"{what} block {b} must be an object with 'basis' and 'Q'")
            basis = parse_basis(item.get("basis"), n, f"{what} block {b} basis")
            Q = parse_matrix(item.get("Q"), len(basis), f"{what} block {b} Q")
            if what == "lambda":
                parts.append((basis, Q))
                continue
            w = item.get("scaling")
            if w is not None:
                if not isinstance(w, list) or len(w) != len(basis):
                    raise ValueError(f"sigma block {b} scaling must be {len(basis)} rationals")
                w = [parse_rational(v, f"sigma block {b} scaling[{i}]") for i, v in enumerate(w)]
            parts.append((basis, Q, w))
        out[what] = parts
    return out["sigma"], out["lambda"]


def recheck_sdd(system: Any, V: Any, level: float, meta: dict[str, Any]) -> Any:
    """Re-check a stored SDD certificate (``meta["certificate"]["sdd"]``, ``meta["eps"]``)
    without any solver: ``certified`` only if :func:`check_sdd` passes on the stored rationals
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
        sigma, lam = parse(meta["certificate"]["sdd"], int(V.n))
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
    res = check_sdd(data, level, eps, sigma, lam, rounded=True)
    if not res.ok:
        return out(Verdict.INCONCLUSIVE, f"stored SOS certificate refused: {res.reason}",
                   residual=res.residual)  # fmt: skip
    return out(Verdict.CERTIFIED, f"stored SDSOS certificate re-checked exactly: {res.reason}",
               residual=res.residual, min_pivot=res.min_pivot, **res.meta)  # fmt: skip
