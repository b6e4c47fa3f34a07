"""Numerical SOS certificate of a level for dense coupled systems: sign symmetry, then SDSOS.

The program of :mod:`roa.search.sos_certificate` (``-V' - eps|d|^2k - lambda (c - V) = sigma``)
over all monomials of degree ``k..D`` has one Gram block of ``m`` monomials; Clarabel's memory
grows as ``m^4`` (:func:`roa.search.sdp_solver.ipm_bytes`), 16 GiB at ``m = 231``. When the
variables are all coupled (no independent blocks, a complete interaction graph: the chordal
cliques of :mod:`roa.search.sos_sparse` are the whole) two reductions remain, applied in order:

1. **Sign symmetry** (TSSOS, Wang, Magron and Lasserre 2021): the sign flips ``d_i -> -d_i``
   of a subset of variables that leave every monomial of ``V`` and ``V'`` unchanged form a group
   ``G``; averaging any certificate over ``G`` gives one whose Gram blocks only join monomials
   ``a``, ``b`` with ``a + b`` invariant, i.e. ``a = b`` modulo the span (over GF(2)) of the
   supports' exponent parities. The bases split by that class, with the same optimum
   (:func:`sign_classes`). An odd field with ``V`` even splits into odd and even monomials.
2. **Scaled diagonal dominance** (SDSOS, Ahmadi and Majumdar 2019) for the blocks still too large
   for the interior point's memory budget: such a block is ``t I`` plus a sum of 2 x 2 PSD
   blocks, one per pair of its monomials, each a second-order cone; its memory grows as ``m^2``.
   A restriction (inner approximation): whatever it certifies the full program could. The
   exact check of these blocks is scaled diagonal dominance in rationals
   (:mod:`roa.proof.sos_sdd`).

With ``solver="scs"`` in the solver options the blocks stay PSD and the first-order solver SCS
solves them (:mod:`roa.search.sdp_solver`); the exact check decides either way. The program is
compiled once with the level as a parameter (cvxpy DPP), so that a bisection re-solves it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np
import scipy.sparse as sps

from roa.proof.sos_check import ExactData, Mono, norm_power
from roa.search.polysdp import MAX_SDP_BYTES, monomials, sdp_bytes
from roa.search.sdp_solver import split
from roa.search.sos_certificate import default_eps, degrees, gram_columns


def _parity_span(polys: list[dict[Mono, Any]]) -> list[int]:
    """A GF(2) echelon basis (bit masks, distinct leading bits) of the exponent parities."""
    basis: list[int] = []
    for p in polys:
        for m, c in p.items():
            if not c:
                continue
            v = sum(1 << i for i, e in enumerate(m) if e % 2)
            for b in basis:
                v = min(v, v ^ b)
            if v:
                basis.append(v)
                basis.sort(reverse=True)
    return basis


def _reduce(v: int, basis: list[int]) -> int:
    for b in basis:
        v = min(v, v ^ b)
    return v


def sign_classes(data: ExactData, monos: list[Mono]) -> list[list[Mono]]:
    """``monos`` split by sign-symmetry class (module docstring), largest class first."""
    span = _parity_span([data.V, data.Vdot])
    out: dict[int, list[Mono]] = {}
    for m in monos:
        key = _reduce(sum(1 << i for i, e in enumerate(m) if e % 2), span)
        out.setdefault(key, []).append(m)
    return sorted(out.values(), key=len, reverse=True)


def sdd_bytes(m: int) -> int:
    """Estimated memory of an SDD block of ``m`` monomials: three variables and one 3-cone per
    pair, a few dozen doubles of the solver's data each."""
    return 8 * 40 * 3 * (m * (m - 1) // 2 + m)


@dataclass(frozen=True)
class SddPlan:
    """Bases of the program: ``sigma`` blocks with ``sdd[b]`` True when block ``b`` is scaled
    diagonally dominant (else PSD), ``lam`` blocks (PSD); the solver and its estimate."""

    sigma: list[list[Mono]]
    sdd: list[bool]
    lam: list[list[Mono]]
    solver: str
    estimated_bytes: int
    dense: int  # the one dense Gram block's size

    @property
    def sizes(self) -> dict[str, Any]:
        return {"dense_gram": self.dense, "sign_blocks": [len(b) for b in self.sigma],
                "sdd_blocks": [len(b) for b, s in zip(self.sigma, self.sdd, strict=True) if s],
                "lambda_blocks": [len(b) for b in self.lam], "solver": self.solver,
                "estimated_gib": round(self.estimated_bytes / 2**30, 4)}  # fmt: skip


SDD_MODES = ("auto", "largest")


def plan(data: ExactData, multiplier_degree: int | None = None,
         solver_options: dict[str, Any] | None = None, *, budget: int | None = None,
         mode: str = "auto") -> tuple[SddPlan | None, str]:  # fmt: skip
    """The bases (module docstring) and the solver, or None and why: the estimate exceeds
    ``budget`` (default :data:`MAX_SDP_BYTES`) even with every large block scaled diagonally
    dominant (or, with SCS forced, for SCS). ``mode="auto"``: the largest sigma blocks are made SDD until the estimate fits;
    ``"largest"``: the largest one is, whatever the estimate."""
    if mode not in SDD_MODES:
        raise ValueError(f"mode must be one of {SDD_MODES}, got {mode!r}")
    budget = MAX_SDP_BYTES if budget is None else budget
    from roa.search.sdp_solver import scs_bytes

    n = data.n
    k, D, L = degrees(data, multiplier_degree)
    basis0 = monomials(n, D, k)
    basis1 = monomials(n, L, k) if L >= k else []
    sigma = sign_classes(data, basis0)
    lam = sign_classes(data, basis1) if basis1 else []
    solver, _ = split(solver_options)
    rows = len(monomials(n, 2 * D, 0))
    if solver == "scs":
        nnz = sum(len(b) ** 2 for b in sigma) + sum(len(b) ** 2 * len(data.V) for b in lam)
        est = scs_bytes([len(b) for b in sigma + lam], rows, nnz)
        if est > budget:
            return (
                None,
                f"SCS needs an estimated {est / 2**30:.3g} GiB (budget {budget / 2**30:.3g})",
            )
        return SddPlan(sigma, [False] * len(sigma), lam, "scs", est, len(basis0)), ""
    sdd = [False] * len(sigma)
    psd = [len(b) for b in sigma] + [len(b) for b in lam]

    def estimate() -> int:
        return sum(sdp_bytes(m) for m in psd if m) + sum(
            sdd_bytes(len(b)) for b, s in zip(sigma, sdd, strict=True) if s)  # fmt: skip

    for i in range(len(sigma)):  # the largest first
        if mode == "largest" and i == 0:
            sdd[i], psd[i] = True, 0
            continue
        if estimate() <= budget:
            break
        sdd[i], psd[i] = True, 0
    if estimate() > budget or any(sdp_bytes(len(b)) > budget for b in lam):
        return None, (f"an estimated {estimate() / 2**30:.3g} GiB even with the large blocks "
                      f"scaled diagonally dominant (budget {budget / 2**30:.3g} GiB)")  # fmt: skip
    return SddPlan(sigma, sdd, lam, "clarabel", estimate(), len(basis0)), ""


@dataclass(frozen=True)
class SddCandidate:
    """Float blocks of a numerical certificate (None when the solver failed)."""

    plan: SddPlan
    sigma: list[np.ndarray] | None
    lam: list[np.ndarray] | None
    eps: Fraction
    margin: float | None
    solver_status: str
    seconds: float
    figures: dict[str, Any] = field(default_factory=dict)


class SddProgram:
    """The program of a plan, compiled once with the level as a parameter."""

    def __init__(self, data: ExactData, plan: SddPlan, *, eps: Fraction | None = None,
                 solver_options: dict[str, Any] | None = None) -> None:  # fmt: skip
        import cvxpy as cp

        t0 = time.perf_counter()
        n = data.n
        self.plan = plan
        self.eps = default_eps(data) if eps is None else Fraction(eps)
        _, opts = split(solver_options)
        self.solver_options = {"solver": plan.solver, **opts}
        zero = tuple([0] * n)
        target: dict[Mono, float] = {}
        for m, c in data.Vdot.items():
            target[m] = target.get(m, 0.0) - float(c)
        for m, c in norm_power(n, data.low // 2).items():
            target[m] = target.get(m, 0.0) - float(self.eps * c)
        rows: dict[Mono, int] = {m: i for i, m in enumerate(target)}
        minus_V = {m: -float(c) for m, c in data.V.items()}
        cols: list[tuple[list[int], list[int], list[float]]] = []  # (rows, cols, vals) per var
        level_cols: list[tuple[list[int], list[int], list[float]]] = []
        t_rows: list[int] = []
        sizes: list[int] = []
        self.pairs: list[tuple[np.ndarray, np.ndarray] | None] = []
        for basis, is_sdd in zip(plan.sigma, plan.sdd, strict=True):
            if not is_sdd:
                cols.append(gram_columns(rows, basis, {zero: 1.0}))
                level_cols.append(([], [], []))
                sizes.append(len(basis) ** 2)
                self.pairs.append(None)
                continue
            size = len(basis)
            I, J = np.triu_indices(size, 1)
            P = len(I)
            diag = [rows.setdefault(tuple(2 * e for e in b), len(rows)) for b in basis]
            off = [rows.setdefault(tuple(p + q for p, q in zip(basis[i], basis[j], strict=True)),
                                   len(rows)) for i, j in zip(I, J, strict=True)]  # fmt: skip
            # variables [a (P), b (P), c (P)]: Q_ii = t + sum a|b, Q_ij = c (twice in m'Qm)
            r = [diag[i] for i in I] + [diag[j] for j in J] + off
            cols.append((r, list(range(3 * P)), [1.0] * (2 * P) + [2.0] * P))
            level_cols.append(([], [], []))
            sizes.append(3 * P)
            t_rows += diag
            self.pairs.append((I, J))
        for basis in plan.lam:
            cols.append(gram_columns(rows, basis, minus_V))
            level_cols.append(gram_columns(rows, basis, {zero: 1.0}))
            sizes.append(len(basis) ** 2)
        offsets = np.cumsum([0] + sizes)
        nrow, ncol = len(rows), int(offsets[-1])

        def matrix(ps: list[tuple[list, list, list]]) -> Any:
            r = np.concatenate([np.asarray(p[0], dtype=np.int64) for p in ps])
            cc = np.concatenate([np.asarray(p[1], dtype=np.int64) + offsets[i]
                                 for i, p in enumerate(ps)])  # fmt: skip
            v = np.concatenate([np.asarray(p[2], dtype=float) for p in ps])
            return sps.csr_matrix((v, (r, cc)), shape=(nrow, ncol))

        b = np.zeros(nrow)
        for m, value in target.items():
            b[rows[m]] = value
        tcol = np.zeros(nrow)
        np.add.at(tcol, np.asarray(t_rows, dtype=np.int64), 1.0)
        self.t = cp.Variable()
        self.level = cp.Parameter(nonneg=True)
        pieces, cons = [], [self.t <= 1]
        self.vars: list[Any] = []
        for basis, is_sdd, pr in zip(plan.sigma, plan.sdd, self.pairs, strict=True):
            if not is_sdd:
                Q = cp.Variable((len(basis), len(basis)), symmetric=True)
                cons.append(Q - self.t * np.eye(len(basis)) >> 0)
                pieces.append(cp.vec(Q, order="C"))
                self.vars.append(Q)
                continue
            assert pr is not None
            u = cp.Variable(3 * len(pr[0]))
            P = len(pr[0])
            a, bb, cc = u[:P], u[P : 2 * P], u[2 * P :]
            cons.append(cp.SOC(a + bb, cp.vstack([2 * cc, a - bb]), axis=0))
            pieces.append(u)
            self.vars.append(u)
        for basis in plan.lam:
            L = cp.Variable((len(basis), len(basis)), symmetric=True)
            cons.append(L - self.t * np.eye(len(basis)) >> 0)
            pieces.append(cp.vec(L, order="C"))
            self.vars.append(L)
        x = cp.hstack(pieces)
        ident = matrix(cols) @ x + self.level * (matrix(level_cols) @ x) + self.t * tcol
        cons.append(ident == b)
        self.problem = cp.Problem(cp.Maximize(self.t), cons)
        self.rows = nrow
        self.build_seconds = time.perf_counter() - t0

    def solve(self, level: float) -> SddCandidate:
        """The program at ``level``: float blocks (SDD blocks assembled as ``t I`` plus their
        pairs) and the margin ``t``."""
        import cvxpy as cp

        from roa.search.sdp_solver import solve

        t0 = time.perf_counter()
        self.level.value = float(level)
        status = solve(self.problem, self.solver_options)
        ok = status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) and self.t.value is not None and all(
            v.value is not None for v in self.vars)  # fmt: skip
        sigma: list[np.ndarray] | None = None
        lam: list[np.ndarray] | None = None
        t = float(np.asarray(self.t.value)) if ok else None
        if ok:
            assert t is not None
            sigma = []
            for basis, var, pr in zip(self.plan.sigma, self.vars, self.pairs, strict=False):
                if pr is None:
                    sigma.append(np.asarray(var.value))
                    continue
                I, J = pr
                P = len(I)
                u = np.asarray(var.value)
                Q = np.eye(len(basis)) * t
                np.add.at(Q, (I, I), u[:P])
                np.add.at(Q, (J, J), u[P : 2 * P])
                Q[I, J] = u[2 * P :]
                Q[J, I] = u[2 * P :]
                sigma.append(Q)
            lam = [np.asarray(v.value) for v in self.vars[len(self.plan.sigma) :]]
        figures = {"rows": self.rows, "build_seconds": round(self.build_seconds, 3),
                   "solve_seconds": round(time.perf_counter() - t0, 3), **self.plan.sizes}  # fmt: skip
        return SddCandidate(self.plan, sigma, lam, self.eps, t, status,
                            time.perf_counter() - t0, figures)  # fmt: skip


def largest_level(data: ExactData, program: SddProgram, *, rel_tol: float = 1e-3,
                  start: float = 1.0, max_doublings: int = 40,
                  max_solves: int = 20) -> tuple[float | None, int]:  # fmt: skip
    """Largest level with a positive margin (a proposal only): a bracket by doubling (or
    halving) from ``start``, then false position on the margin (Illinois), which is close to
    linear in the level, until the bracket is within ``rel_tol``; ``(level or None, programs
    solved)``, ``inf`` when feasible at ``2^40 start``."""
    count = 0

    def margin(c: float) -> float:
        nonlocal count
        count += 1
        cand = program.solve(c)
        return -1.0 if cand.margin is None else float(cand.margin)

    lo = hi = start
    m_lo = m_hi = margin(start)
    if m_lo > 0:
        for _ in range(max_doublings):
            hi *= 2.0
            m_hi = margin(hi)
            if m_hi <= 0:
                break
            lo, m_lo = hi, m_hi
        else:
            return math.inf, count
    else:
        for _ in range(max_doublings):
            lo /= 2.0
            m_lo = margin(lo)
            if m_lo > 0:
                break
            hi, m_hi = lo, m_lo
        else:
            return None, count
    side = 0
    while hi - lo > rel_tol * lo and count < max_solves:  # invariant: m_lo > 0 >= m_hi
        mid = hi - m_hi * (hi - lo) / (m_hi - m_lo) if m_hi != m_lo else 0.5 * (lo + hi)
        mid = min(max(mid, lo + 0.01 * (hi - lo)), hi - 0.01 * (hi - lo))
        m = margin(mid)
        if m > 0:
            lo, m_lo = mid, m
            if side == 1:
                m_hi /= 2  # Illinois: the stale end's weight halved
            side = 1
        else:
            hi, m_hi = mid, m
            if side == -1:
                m_lo /= 2
            side = -1
    return lo, count
