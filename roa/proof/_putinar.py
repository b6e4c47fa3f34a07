"""The one exact check of a Putinar identity (Peyrl-Parrilo rounding, projection, exact LDL').

**Claim.** For exact polynomials over the rationals in ``nv`` variables ``z`` — a left-hand side
``T``, factors ``t_0 = 1, t_1, ..., t_K`` and equalities ``h_e`` — the checker proves, coefficient
by coefficient, the identity::

    T - sum_{b : k_b >= 1} (m_b' Q_b m_b) t_{k_b} - sum_e mu_e h_e = sum_{b : k_b = 0} m_b' Q_b m_b

with every Gram block ``Q_b`` positive definite and the ``mu_e`` polynomials with rational
coefficients. A block is proved positive definite by its exact leading minors (LDL', python-flint),
or, when it is flagged scaled diagonally dominant (an SDSOS block, ``cone`` ``"sdd"``), by exact
strict scaled diagonal dominance with positive rationals ``w``: ``w_i Q_ii > sum_{j != i} |Q_ij|
w_j`` for every row; then ``D Q D`` (``D = diag(w)``) is strictly diagonally dominant with a
positive diagonal, positive definite by Gershgorin, and so is ``Q`` (``O(m^2)`` rational
operations where the LDL' costs ``O(m^3)`` on growing integers). Each block multiplies one factor (``k_b``); a
factor may have several blocks (a sparsity pattern: correlative cliques, or one block per factor
for the dense certificate), and their sum is an SOS multiplier of the factor. So, wherever every
``t_k >= 0`` and every ``h_e = 0``, ``T >= 0``.

The routes read it as follows (:func:`check_level`): ``T = -N - eps |d|^(2k)`` (``N`` with the
sign of ``V'``), ``t_1 = c - V``, ``t_{2+j} = g_j`` (the recast's and the parameter box's
inequalities); at ``z(x)`` with ``V(x) <= c`` this gives ``-N >= eps |d|^(2k) > 0`` for
``d != 0``, i.e. ``V' < 0`` on ``{V <= c}`` minus ``x_eq``. The domain containment reads
``T = margin - eps`` and ``t_1 = c - V`` (:func:`roa.proof._domain.check_domain_certificate`).

**Rounding and projection.** Fresh float blocks are rounded to dyadic rationals; the blocks of
factors ``k >= 1`` and the ``mu_e`` are kept as rounded, except that the constant of a circle's
multiplier is set so that the circle's linear monomial (matched by no block) cancels; the blocks
of factor 0 are then projected jointly (Frobenius norm, exact rationals) onto the affine space of
the identity (:func:`roa.proof._sos_check.project_grams`); an SDD block's scaling is then proposed
from the float comparison matrix (:func:`dd_scaling`, dyadics) and checked exactly. A stored
certificate (``rounded=True``) is checked exactly as stored, scalings included: nothing is moved.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from roa.proof._exact import exact_positive_definite
from roa.proof._sos_check import (
    MAX_BASIS,
    Mono,
    QPoly,
    as_float,
    exact_fraction,
    exact_matrix,
    gram_poly,
    is_symmetric,
    matrix_digest,
    norm_power,
    objects,
    parse_basis,
    parse_matrix,
    parse_rational,
    poly_lin,
    poly_mul,
    project_grams,
    round_matrix,
)

Matrix = list[list[Fraction]]


def dominance_margin(Q: Matrix, w: list[Fraction]) -> Fraction | None:
    """The least ``w_i Q_ii - sum_{j != i} |Q_ij| w_j`` over the rows (exact); None when ``w``
    is not one positive rational per row."""
    m = len(Q)
    if len(w) != m or any(not v > 0 for v in w):
        return None
    slacks = [w[i] * Q[i][i] - sum((abs(Q[i][j]) * w[j] for j in range(m) if j != i and Q[i][j]),
                                   Fraction(0)) for i in range(m)]  # fmt: skip
    return min(slacks, default=Fraction(0))


def dd_scaling(Q: Matrix, bits: int = 40) -> list[Fraction] | None:
    """A scaling to check ``Q`` by dominance (floats only propose it): ``M^-1 1`` for the
    comparison matrix ``M`` (``|Q_ii|`` on the diagonal, ``-|Q_ij|`` off it), positive when ``Q``
    is scaled diagonally dominant; dyadics of ``bits`` bits. None when it is not positive."""
    A = np.array([[float(v) for v in row] for row in Q])
    M = -np.abs(A)
    np.fill_diagonal(M, np.abs(np.diag(A)))
    try:
        w = np.linalg.solve(M, np.ones(len(A)))
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(w)) or np.any(w <= 0):
        return None
    grid = Fraction(1, 2**bits)
    out = [Fraction(round(Fraction(float(v)) / grid)) * grid for v in w / np.max(w)]
    return out if all(v > 0 for v in out) else None


def _definite(R: Matrix, cone: Any) -> tuple[bool, list[Fraction], Any]:
    """``(ok, pivots or the dominance slack, cone as proved)``: exact LDL' for a PSD block,
    exact scaled dominance for an SDD one (``"sdd"``: its scaling proposed here)."""
    if cone is None or cone == "psd":
        ok, piv = exact_positive_definite(R)
        return ok, piv, "psd"
    w = dd_scaling(R) if cone == "sdd" else list(cone)
    margin = None if w is None else dominance_margin(R, w)
    if w is None or margin is None or not margin > 0:
        return False, [] if margin is None else [margin], cone
    return True, [margin], tuple(w)


@dataclass(frozen=True)
class Certificate:
    """A Putinar certificate with its sparsity pattern: ``grams`` ``(factor, basis, Q)`` (factor
    0: the projected SOS part; 1: the level's multiplier ``c - V``; ``2 + j``: inequality ``j``;
    several blocks per factor allowed), ``free``: ``(basis, coefficients)`` per equality, and
    ``cones`` per Gram block (empty: all ``"psd"``): ``"psd"``, ``"sdd"`` (scaled diagonally
    dominant, its scaling to be found) or the scaling itself (a tuple of rationals). Matrices
    are floats (a candidate) or rationals (a checked or stored certificate)."""

    grams: tuple[tuple[int, list[Mono], Any], ...]
    free: tuple[tuple[list[Mono], Any], ...] = ()
    cones: tuple[Any, ...] = ()

    def cone(self, i: int) -> Any:
        """Gram block ``i``'s cone (``"psd"`` unless flagged)."""
        return self.cones[i] if i < len(self.cones) else "psd"

    def blocks(self, factor: int) -> list[tuple[list[Mono], Any]]:
        """The ``(basis, Q)`` blocks of ``factor``, in order."""
        return [(b, Q) for k, b, Q in self.grams if k == factor]

    def to_json(self) -> dict[str, Any]:
        """The stored form: ``{"grams": [{"multiplies", "basis", "Q"[, "cone": "sdd",
        "scaling"]}], "free": [{"basis", "coeffs"}]}`` (rationals as strings)."""
        grams = []
        for i, (k, b, Q) in enumerate(self.grams):
            g: dict[str, Any] = {"multiplies": k, "basis": [list(m) for m in b],
                                 "Q": [[str(v) for v in row] for row in Q]}  # fmt: skip
            if self.cone(i) != "psd":
                g["cone"] = "sdd"
                if self.cone(i) != "sdd":
                    g["scaling"] = [str(v) for v in self.cone(i)]
            grams.append(g)
        return {"grams": grams, "free": [{"basis": [list(m) for m in b],
                                          "coeffs": [str(v) for v in c]} for b, c in self.free]}  # fmt: skip

    @staticmethod
    def parse(raw: Any, nv: int) -> Certificate:
        """A stored certificate (:meth:`to_json`), bounded before any arithmetic; ValueError
        naming what is malformed."""
        if not isinstance(raw, dict):
            raise ValueError("the certificate must be an object with 'grams' and 'free'")
        raw_grams = objects(raw.get("grams", []), "grams")
        raw_free = objects(raw.get("free", []), "free")
        grams, cones = [], []
        for i, g in enumerate(raw_grams):
            k = g.get("multiplies", 0)
            if type(k) is not int or not 0 <= k <= MAX_BASIS:
                raise ValueError(f"grams[{i}].multiplies must be a factor index >= 0")
            basis = parse_basis(g.get("basis"), nv, f"grams[{i}].basis")
            grams.append((k, basis, parse_matrix(g.get("Q"), len(basis), f"grams[{i}].Q")))
            cone, w = g.get("cone", "psd"), g.get("scaling")
            if cone not in ("psd", "sdd") or (cone == "psd") != (w is None):
                raise ValueError(f"grams[{i}]: cone must be 'psd' (no scaling) or 'sdd' with a "
                                 "scaling")  # fmt: skip
            if cone == "sdd" and (not isinstance(w, list) or len(w) != len(basis)):
                raise ValueError(f"grams[{i}].scaling must hold {len(basis)} rationals")
            cones.append("psd" if w is None else tuple(
                parse_rational(v, f"grams[{i}].scaling[{j}]") for j, v in enumerate(w)))  # fmt: skip
        free = []
        for i, f in enumerate(raw_free):
            basis = parse_basis(f.get("basis"), nv, f"free[{i}].basis")
            coeffs = f.get("coeffs")
            if not isinstance(coeffs, list) or len(coeffs) != len(basis):
                raise ValueError(f"free[{i}].coeffs must match its basis")
            free.append((basis, [parse_rational(v, f"free[{i}].coeffs[{j}]")
                                 for j, v in enumerate(coeffs)]))  # fmt: skip
        return Certificate(tuple(grams), tuple(free), tuple(cones))


@dataclass(frozen=True)
class ExactCheck:
    """Outcome of :func:`check_identity`: ``ok`` only if every exact check passed;
    ``certificate`` the rationals proved (factor-0 blocks projected); ``residual`` the largest
    coefficient the projection moved; ``min_pivot`` the least LDL' pivot over all blocks."""

    ok: bool
    reason: str
    residual: float | None = None
    min_pivot: float | None = None
    certificate: Certificate | None = None
    meta: dict[str, Any] = field(default_factory=dict)


def block_name(factor: int, index: int, count: int, names: list[str]) -> str:
    """How a refusal names a block: ``Q0`` / ``Q1`` when its factor has one block, else
    ``sigma block i`` / ``the level multiplier's block i``; an inequality's by its name."""
    if factor == 0:
        return "Q0" if count == 1 else f"sigma block {index}"
    if factor == 1:
        return "the level multiplier's " + ("Q1" if count == 1 else f"block {index}")
    what = names[factor - 2] if factor - 2 < len(names) else f"factor {factor}"
    return f"the multiplier of '{what}'"


def check_identity(target: QPoly, times: list[QPoly], equalities: list[QPoly], cert: Certificate,
                   *, rounded: bool = False, names: list[str] | None = None) -> ExactCheck:  # fmt: skip
    """Exact check of the identity of the module docstring: ``target`` is ``T``, ``times`` the
    factors ``t_0 = 1, t_1, ...``, ``equalities`` the ``h_e``. ``rounded=False``: float blocks,
    rounded here; ``rounded=True``: rationals, checked as they are."""
    names = names or []
    nv = len(next(iter(target))) if target else len(next(iter(times[0])))
    if len(cert.free) != len(equalities):
        return ExactCheck(False, f"the certificate's blocks do not match the problem ({len(times)} "
                          f"factors, {len(equalities)} equalities)")  # fmt: skip
    if not any(k == 0 for k, _, _ in cert.grams):
        return ExactCheck(False, "no Gram block for the SOS part (factor 0)")
    grams: list[tuple[int, list[Mono], Matrix]] = []
    for i, (k, basis, Q) in enumerate(cert.grams):
        if not 0 <= k < len(times):
            return ExactCheck(False, f"the certificate's blocks do not match the problem: Gram "
                              f"block {i} multiplies factor {k} of {len(times)}")  # fmt: skip
        if any(len(m) != nv for m in basis) or len(Q) != len(basis):
            return ExactCheck(False, f"Gram block {i}: basis and matrix do not match")
        R = exact_matrix(Q, rounded)
        if not is_symmetric(R):
            return ExactCheck(False, f"Gram block {i} is not symmetric")
        grams.append((k, list(basis), R))
    free: list[tuple[list[Mono], list[Fraction]]] = []
    for i, (basis, coeffs) in enumerate(cert.free):
        if any(len(m) != nv for m in basis) or len(coeffs) != len(basis):
            return ExactCheck(False, f"equality multiplier {i}: basis and coefficients differ")
        cs = [exact_fraction(v) for v in coeffs] if rounded else [
            round_matrix([[float(v)]])[0][0] for v in coeffs]  # fmt: skip
        free.append((list(basis), cs))
    count = {k: sum(1 for g in grams if g[0] == k) for k, _, _ in grams}
    pivots: list[Fraction] = []
    proved: dict[int, Any] = {}  # block -> its cone as proved (an SDD block: its scaling)

    def refused(i: int, R: Matrix, what: str, residual: Fraction | None = None
                ) -> ExactCheck | None:  # fmt: skip
        """None when block ``i`` (as ``R``) is proved definite, else the refusal."""
        ok, piv, proved[i] = _definite(R, cert.cone(i))
        pivots.extend(piv)
        k = grams[i][0]
        name = block_name(k, sum(1 for g in grams[:i] if g[0] == k), count[k], names)
        cone = ("positive definite" if cert.cone(i) == "psd"
                else "strictly scaled diagonally dominant")  # fmt: skip
        return None if ok else ExactCheck(
            False, f"{what} {name} is not {cone} (exact)",
            None if residual is None else as_float(residual), as_float(min(piv)) if piv else None)  # fmt: skip

    for i, (k, basis, R) in enumerate(grams):  # the multipliers: kept as rounded
        if k == 0:
            continue
        if (no := refused(i, R, "the Gram matrix of")) is not None:
            return no
        target = poly_lin((Fraction(1), target),
                          (Fraction(-1), poly_mul(gram_poly(basis, R), times[k])))  # fmt: skip
    for (basis, cs), h in zip(free, equalities, strict=True):
        mu = poly_lin(*((v, {b: Fraction(1)}) for b, v in zip(basis, cs, strict=True)))
        target = poly_lin((Fraction(1), target), (Fraction(-1), poly_mul(mu, h)))
    zero = tuple([0] * nv)
    for e, (basis, cs) in enumerate(free if not rounded else []):  # fresh: a circle's linear
        h = equalities[e]  # monomial sets its multiplier's constant (nothing else matches it)
        lin = [m for m in h if sum(m) == 1]
        if len(lin) != 1 or zero not in basis:
            continue
        if lin[0] in [m for j, g in enumerate(equalities) if j != e for m in g]:
            continue
        delta = target.get(lin[0], Fraction(0)) / h[lin[0]]
        if delta:
            cs[basis.index(zero)] += delta
            target = poly_lin((Fraction(1), target), (-delta, h))
    sos = [(basis, R) for k, basis, R in grams if k == 0]
    P, residual, why = project_grams(sos, target, exact=rounded)
    if P is None:
        return ExactCheck(False, why, None if residual is None else as_float(residual))
    assert residual is not None
    zeros = [i for i, g in enumerate(grams) if g[0] == 0]
    for i, Pb in zip(zeros, P, strict=True):
        if (no := refused(i, Pb, "the projected Gram matrix", residual)) is not None:
            return no
    it = iter(P)
    cones = tuple(proved[i] for i in range(len(grams)))
    final = Certificate(tuple((k, basis, next(it) if k == 0 else R) for k, basis, R in grams),
                        tuple(free), cones if any(c != "psd" for c in cones) else ())  # fmt: skip
    scalings = [list(c) for c in cones if c != "psd"]
    meta = {"digest": matrix_digest(*[R for _, _, R in final.grams],
                                    *([[[v] for _, cs in free for v in cs]] if free else []),
                                    *([scalings] if scalings else []))}  # fmt: skip
    dd = len(scalings)
    how = (f"{len(grams) - dd} positive definite, {dd} strictly scaled diagonally dominant"
           if dd else "positive definite")  # fmt: skip
    return ExactCheck(True, f"identity exact, {len(grams)} Gram blocks {how} (exact)",
                      as_float(residual), as_float(min(pivots)) if pivots else None, final,
                      meta)  # fmt: skip


def check_level(data: Any, level: Any, eps: Any, cert: Certificate, *, rounded: bool = False
                ) -> ExactCheck:  # fmt: skip
    """Exact check that ``V' < 0`` on ``{V <= level}`` minus ``x_eq`` (module docstring) for the
    exact data of any route: :class:`roa.proof._sos_check.ExactData` (a polynomial field) or
    :class:`roa.proof._recast.RecastData` (a recast field, a parameter box); both give ``nv``,
    ``n``, ``N``, ``V``, ``low``, ``equalities``, ``inequalities`` and ``bounded_level``."""
    c, e = Fraction(level), Fraction(eps)
    if not (c > 0 and e > 0):
        return ExactCheck(False, f"level and eps must be > 0 (got {as_float(c)}, {as_float(e)})")
    k, rem = divmod(data.low, 2)
    if rem or k < 1:
        return ExactCheck(False, f"the lowest degree of V' is {data.low}, not even: V' is not "
                          "negative definite near x_eq")  # fmt: skip
    if data.bounded_level is not None and c > data.bounded_level:
        return ExactCheck(False, f"the recast's angle bounds hold on {{V <= "
                          f"{as_float(data.bounded_level)}}} only, not at level {as_float(c)}")  # fmt: skip
    target, times = level_identity(data, c, e)
    res = check_identity(target, times, [h for _, h in data.equalities], cert, rounded=rounded,
                         names=[w for w, _ in data.inequalities])  # fmt: skip
    extra = {"eps": str(e), "k": k}
    return ExactCheck(res.ok, res.reason, res.residual, res.min_pivot, res.certificate,
                      {**res.meta, **extra} if res.ok else res.meta)  # fmt: skip


def level_identity(data: Any, level: Fraction, eps: Fraction) -> tuple[QPoly, list[QPoly]]:
    """``(T, [t_0, t_1, ...])`` of the level's identity (module docstring) for the data of
    :func:`check_level` (the program that proposes a certificate builds it in floats)."""
    nv, pad = data.nv, data.nv - data.n
    zero = tuple([0] * nv)
    norm = {m + (0,) * pad: v for m, v in norm_power(data.n, data.low // 2).items()}
    target = poly_lin((Fraction(-1), data.N), (-eps, norm))
    times = [{zero: Fraction(1)}, poly_lin((Fraction(-1), data.V), (level, {zero: Fraction(1)})),
             *[g for _, g in data.inequalities]]  # fmt: skip
    return target, times
