"""Sparse numerical SOS certificate of a fixed level (correlative sparsity; proposes only).

The program of :mod:`roa.search.sos_certificate` (``-V' - eps|d|^2k - lambda (c - V) = sigma``,
``lambda``, ``sigma`` SOS) with one Gram matrix over all monomials of degree ``k..D`` in ``n``
variables needs ``O(n^2D)`` entries: at 20-30 states and degree 4, far more solver memory than
the budget :data:`roa.search.polysdp.MAX_SDP_BYTES`. Correlative sparsity (Waki, Kim, Kojima and Muramatsu 2006; CS-TSSOS,
Wang, Magron, Lasserre and Mai 2022) uses the structure of the polynomials instead:

* the **interaction graph** joins two variables when they occur in one monomial of ``V'`` or
  ``V``; a **chordal extension** (:func:`networkx.complete_to_chordal_graph`) and its maximal
  cliques ``C_1 .. C_K`` (:func:`networkx.chordal_graph_cliques`) give the blocks;
* ``sigma`` gets one Gram block per clique over the monomials of degree ``k..D`` in its variables,
  and ``lambda = sum_j lambda_j`` one block per clique over the monomials of degree ``1..L``;
* ``lambda_j V`` has monomials across cliques: for ``V = sum_q p_q d_q^2`` (diagonal, the only V
  this route takes) they are ``m m' d_q^2`` with ``m, m'`` in ``lambda_j``'s basis, and ``sigma``
  gets one more block per clique ``j`` and variable ``q`` outside it over ``{m d_q}`` (``p_q``
  times ``lambda_j``'s Gram matrix is a feasible value: ``lambda_j p_q d_q^2`` is exactly such a
  Gram form).

Every block is an ordinary Gram form, so :func:`roa.proof.sos_sum.check_sum` proves the result
exactly whatever the structure. The program is a restriction of the dense one (a sum of these
blocks is one Gram matrix with zeros elsewhere): whatever it certifies the dense program could,
not conversely; it loses most where ``V' >= 0`` is first reached with many variables at once,
since each clique's blocks see only the part of ``V`` they hold. Each block is kept ``>= t I`` with the common margin ``t``
maximised (``t <= 1``), as in the dense program.

:func:`choose_route` picks the program automatically: the dense one when its Gram block fits the
memory budget :data:`roa.search.polysdp.MAX_SDP_BYTES`, else this one when it applies (diagonal
quadratic V, a clique smaller than ``n``) and fits, else none (``too_large``).
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np
import scipy.sparse as sps

from roa.proof.sos_check import ExactData, Mono, norm_power
from roa.search.polysdp import MAX_SDP_BYTES, monomials, sdp_bytes
from roa.search.sos_certificate import default_eps, degrees, gram_columns


def interaction_graph(data: ExactData) -> Any:
    """The variables' interaction graph (networkx): an edge for two variables of one monomial of
    ``V'`` or ``V``."""
    import networkx as nx

    G = nx.Graph()
    G.add_nodes_from(range(data.n))
    for poly in (data.Vdot, data.V):
        for m, c in poly.items():
            if c:
                G.add_edges_from(itertools.combinations([i for i, e in enumerate(m) if e], 2))
    return G


def cliques(data: ExactData) -> list[tuple[int, ...]]:
    """Maximal cliques of a chordal extension of :func:`interaction_graph` (sorted)."""
    import networkx as nx

    H, _ = nx.complete_to_chordal_graph(interaction_graph(data))
    return sorted(tuple(sorted(int(i) for i in c)) for c in nx.chordal_graph_cliques(H))


def diagonal_V(data: ExactData) -> bool:
    """``V = sum_q p_q d_q^2`` with every ``p_q > 0`` (the cross blocks' form)."""
    n = data.n
    squares = {tuple(2 * (j == q) for j in range(n)) for q in range(n)}
    return set(data.V) == squares and all(c > 0 for c in data.V.values())


def _embed(local: list[Mono], clique: tuple[int, ...], n: int) -> list[Mono]:
    out = []
    for m in local:
        e = [0] * n
        for i, k in zip(clique, m, strict=True):
            e[i] = k
        out.append(tuple(e))
    return out


@dataclass(frozen=True)
class SparsePlan:
    """The bases of the sparse program: ``sigma`` blocks (one per clique, then the cross blocks)
    and ``lambda`` blocks (one per clique)."""

    cliques: list[tuple[int, ...]]
    sigma: list[list[Mono]]
    lam: list[list[Mono]]

    @property
    def sizes(self) -> dict[str, Any]:
        K = len(self.cliques)
        return {"cliques": [len(c) for c in self.cliques],
                "sigma_clique_blocks": [len(b) for b in self.sigma[:K]],
                "sigma_cross_blocks": len(self.sigma) - K,
                "lambda_blocks": [len(b) for b in self.lam]}  # fmt: skip

    @property
    def largest(self) -> int:
        return max(len(b) for b in self.sigma + self.lam)

    @property
    def bytes(self) -> int:
        """Estimated peak memory of the interior-point solve: the blocks' sum."""
        return sum(sdp_bytes(len(b)) for b in self.sigma + self.lam)


def plan(data: ExactData, multiplier_degree: int | None = None) -> tuple[SparsePlan | None, str]:
    """The sparse bases, or None and why the route does not apply (V not diagonal quadratic,
    one clique holding every variable)."""
    if not diagonal_V(data):
        return None, "the sparse route needs V = sum p_q d_q^2 (diagonal quadratic, p_q > 0)"
    n = data.n
    cl = cliques(data)
    if max(len(c) for c in cl) >= n:
        return None, "the interaction graph's chordal extension is complete: no sparsity"
    k, D, L = degrees(data, multiplier_degree)
    sigma = [_embed(monomials(len(c), D, k), c, n) for c in cl]
    lam = [_embed(monomials(len(c), L, 1), c, n) for c in cl] if L >= 1 else []
    for c, basis in zip(cl, lam, strict=False):
        for q in range(n):
            if q not in c:
                sigma.append([tuple(e + (i == q) for i, e in enumerate(m)) for m in basis])
    return SparsePlan(cl, sigma, lam), ""


ROUTES = ("auto", "dense", "sparse")


def choose_route(data: ExactData, multiplier_degree: int | None = None, route: str = "auto"
                 ) -> tuple[str, SparsePlan | None, str]:  # fmt: skip
    """``("dense" | "sparse" | "too_large", plan, why)``: with ``route="auto"`` the dense
    program if its Gram block fits :data:`MAX_SDP_BYTES`, else the sparse one if it applies and
    fits, else neither; ``route="dense"`` or ``"sparse"`` forces one (``too_large`` with the
    reason when it does not apply or fit)."""
    if route not in ROUTES:
        raise ValueError(f"route must be one of {ROUTES}, got {route!r}")
    k, D, _ = degrees(data, multiplier_degree)
    dense = len(monomials(data.n, D, k))
    if route == "dense" or (route == "auto" and sdp_bytes(dense) <= MAX_SDP_BYTES):
        return "dense", None, ""
    too = (f"a dense Gram block of {dense} monomials needs an estimated "
           f"{sdp_bytes(dense) / 2**30:.3g} GiB (budget {MAX_SDP_BYTES / 2**30:.3g} GiB)")  # fmt: skip
    if route == "sparse":
        too = f"the sparse route was requested (the dense Gram block: {dense} monomials)"
    p, why = plan(data, multiplier_degree)
    if p is None:
        return "too_large", None, f"{too}; {why}"
    if p.bytes > MAX_SDP_BYTES:
        return "too_large", p, (f"{too}; the sparse program's {len(p.sigma) + len(p.lam)} blocks "
                                f"need an estimated {p.bytes / 2**30:.3g} GiB")  # fmt: skip
    return "sparse", p, too


@dataclass(frozen=True)
class SparseCandidate:
    """Bases and float Gram blocks of a numerical sparse certificate (``sigma``, ``lam`` None when
    the solver failed)."""

    plan: SparsePlan
    sigma: list[np.ndarray] | None
    lam: list[np.ndarray] | None
    eps: Fraction
    margin: float | None
    solver_status: str
    seconds: float
    figures: dict[str, Any] = field(default_factory=dict)


class SparseProgram:
    """The sparse program of a plan, compiled once with the level as a parameter (cvxpy DPP), so
    that a bisection on the level re-solves it without building it again."""

    def __init__(self, data: ExactData, plan: SparsePlan, *, eps: Fraction | None = None,
                 solver_options: dict[str, Any] | None = None) -> None:  # fmt: skip
        import cvxpy as cp

        t0 = time.perf_counter()
        n = data.n
        self.plan = plan
        self.eps = default_eps(data) if eps is None else Fraction(eps)
        self.solver_options = dict(solver_options or {})
        k = data.low // 2
        zero = tuple([0] * n)
        target: dict[Mono, float] = {}
        for m, c in data.Vdot.items():
            target[m] = target.get(m, 0.0) - float(c)
        for m, c in norm_power(n, k).items():
            target[m] = target.get(m, 0.0) - float(self.eps * c)
        rows: dict[Mono, int] = {m: i for i, m in enumerate(target)}
        minus_V: dict[Mono, float] = {m: -float(c) for m, c in data.V.items()}
        bases = plan.sigma + plan.lam
        # lambda_j (c - V) = c lambda_j - lambda_j V: the level multiplies the first part only
        parts = [gram_columns(rows, b, {zero: 1.0}) for b in plan.sigma]
        parts += [gram_columns(rows, b, minus_V) for b in plan.lam]
        level_parts: list[tuple[list, list, list]] = [([], [], []) for _ in plan.sigma]
        level_parts += [gram_columns(rows, b, {zero: 1.0}) for b in plan.lam]
        offsets = np.cumsum([0] + [len(b) ** 2 for b in bases])
        nrow, ncol = len(rows), int(offsets[-1])

        def matrix(ps: list[tuple[list, list, list]]) -> Any:
            r = np.concatenate([np.asarray(p[0], dtype=np.int64) for p in ps])
            c = np.concatenate([np.asarray(p[1], dtype=np.int64) + offsets[i]
                                for i, p in enumerate(ps)])  # fmt: skip
            v = np.concatenate([np.asarray(p[2], dtype=float) for p in ps])
            return sps.csr_matrix((v, (r, c)), shape=(nrow, ncol))

        b = np.zeros(nrow)
        for m, value in target.items():
            b[rows[m]] = value
        self.Qs = [cp.Variable((len(bb), len(bb)), symmetric=True) for bb in bases]
        self.t = cp.Variable()
        self.level = cp.Parameter(nonneg=True)
        x = cp.hstack([cp.vec(Q, order="C") for Q in self.Qs])
        cons = [Q - self.t * np.eye(Q.shape[0]) >> 0 for Q in self.Qs]
        cons += [self.t <= 1, matrix(parts) @ x + self.level * (matrix(level_parts) @ x) == b]
        self.problem = cp.Problem(cp.Maximize(self.t), cons)
        self.rows = nrow
        self.build_seconds = time.perf_counter() - t0

    def solve(self, level: float) -> SparseCandidate:
        """The program at ``level``: float blocks and the margin ``t`` (None when it failed)."""
        import cvxpy as cp

        t0 = time.perf_counter()
        self.level.value = float(level)
        from roa.search.sdp_solver import solve

        status = solve(self.problem, self.solver_options)
        Qs = self.Qs
        ok = status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) and all(Q.value is not None for Q in Qs)
        K = len(self.plan.sigma)
        vals = [np.asarray(Q.value) for Q in Qs] if ok else None
        t = self.t.value
        figures = {"rows": self.rows, "build_seconds": round(self.build_seconds, 3),
                   "solve_seconds": round(time.perf_counter() - t0, 3),
                   "estimated_gib": round(self.plan.bytes / 2**30, 4)}  # fmt: skip
        return SparseCandidate(self.plan, None if vals is None else vals[:K],
                               None if vals is None else vals[K:], self.eps,
                               float(t) if ok and t is not None else None, status,
                               time.perf_counter() - t0, figures)  # fmt: skip


def propose_sparse(data: ExactData, level: float, plan: SparsePlan, *, eps: Fraction | None = None,
                   solver_options: dict[str, Any] | None = None) -> SparseCandidate:  # fmt: skip
    """Solve the sparse program of ``plan`` at ``level`` once (module docstring)."""
    prog = SparseProgram(data, plan, eps=eps, solver_options=solver_options)
    cand = prog.solve(level)
    return dataclasses.replace(cand, seconds=cand.seconds + prog.build_seconds)
