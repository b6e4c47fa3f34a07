"""Patterned numerical SOS certificates of a fixed level (cliques, sign classes, SDSOS; proposes only).

The program of :mod:`roa.search.sos_certificate` (``-V' - eps|d|^2k - lambda (c - V) = sigma``,
``lambda``, ``sigma`` SOS) with one Gram matrix over all monomials of degree ``k..D`` in ``n``
variables needs ``O(n^2D)`` entries: at 20-30 states and degree 4, far more solver memory than
the budget :data:`roa.search.sdp.MAX_SDP_BYTES`. Correlative sparsity (Waki, Kim, Kojima and Muramatsu 2006; CS-TSSOS,
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

Every block is an ordinary Gram form, so :func:`roa.proof.putinar.check_level` proves the result
exactly whatever the structure. The program is a restriction of the dense one (a sum of these
blocks is one Gram matrix with zeros elsewhere): whatever it certifies the dense program could,
not conversely; it loses most where ``V' >= 0`` is first reached with many variables at once,
since each clique's blocks see only the part of ``V`` they hold. Each block is kept ``>= t I`` with the common margin ``t``
maximised (``t <= 1``), as in the dense program.

A dense coupled system (a complete interaction graph: no cliques) gets the **SDSOS pattern**
(:func:`sdsos_plan`) instead: the dense program's bases split by sign symmetry
(:mod:`roa.search.sos_symmetry`), and the largest ``sigma`` blocks, while the interior point's
memory estimate exceeds the budget, made scaled diagonally dominant (``cone="sdd"`` of
:meth:`roa.search.sdp.Program.gram`; Ahmadi and Majumdar 2019): a restriction, whatever it
certifies the dense program could, with memory linear in the block's pairs. The exact check proves
those blocks by scaled diagonal dominance (:func:`roa.proof.putinar.check_identity`). With
``"solver": "scs"`` in the solver options every block stays PSD and SCS, whose memory grows with
the program's size only, solves it.

:func:`choose_route` picks the program automatically: the dense one when its Gram block fits the
memory budget :data:`roa.search.sdp.MAX_SDP_BYTES`, else the clique one when it applies (diagonal
quadratic V, a clique smaller than ``n``) and fits, else the SDSOS one when it fits, else none
(``too_large``).
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from roa.proof.putinar import Certificate
from roa.proof.sos_check import ExactData, Mono
from roa.search.sdp import (
    MAX_SDP_BYTES,
    Program,
    choose_solver,
    monomials,
    sdd_bytes,
    sdp_bytes,
    solve,
)
from roa.search.sos_certificate import Candidate, default_eps, degrees, level_target
from roa.search.sos_symmetry import sign_symmetries, split


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
    """The bases of a patterned program: ``sigma`` blocks (one per clique, then the cross blocks;
    or the sign classes of the SDSOS pattern) and ``lambda`` blocks (one per clique or class);
    ``sdd[b]`` True when ``sigma`` block ``b`` is scaled diagonally dominant (empty: none)."""

    cliques: list[tuple[int, ...]]
    sigma: list[list[Mono]]
    lam: list[list[Mono]]
    sdd: tuple[bool, ...] = ()
    kind: str = "cliques"  # or "sdsos"

    def is_sdd(self, b: int) -> bool:
        return b < len(self.sdd) and self.sdd[b]

    @property
    def sizes(self) -> dict[str, Any]:
        if self.kind == "sdsos":
            return {"sign_blocks": [len(b) for b in self.sigma],
                    "sdd_blocks": [len(b) for i, b in enumerate(self.sigma) if self.is_sdd(i)],
                    "lambda_blocks": [len(b) for b in self.lam],
                    "estimated_gib": round(self.bytes / 2**30, 4)}  # fmt: skip
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
        return sum(sdd_bytes(len(b)) if self.is_sdd(i) else sdp_bytes(len(b))
                   for i, b in enumerate(self.sigma + self.lam))  # fmt: skip


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


#: Largest block the automatic route makes scaled diagonally dominant: the solve time grows with
#: the number of 2 x 2 cones (one per pair of monomials), so larger blocks are built only when
#: the SDSOS route is requested.
MAX_SDD_BLOCK = 256


def sdsos_plan(data: ExactData, multiplier_degree: int | None = None,
               solver_options: dict[str, Any] | None = None, *, force: bool = False
               ) -> tuple[SparsePlan | None, str]:  # fmt: skip
    """The SDSOS pattern (module docstring): the dense bases split by sign symmetry, the largest
    ``sigma`` blocks scaled diagonally dominant until the estimate fits :data:`MAX_SDP_BYTES`
    (``force``: at least the largest one); with ``"solver": "scs"`` none, the estimate SCS's.
    None and why when it does not fit."""
    n = data.n
    k, D, L = degrees(data, multiplier_degree)
    syms = sign_symmetries([data.Vdot, data.V], n)
    sigma = sorted(split(monomials(n, D, k), syms), key=len, reverse=True)
    lam = sorted(split(monomials(n, L, k), syms), key=len, reverse=True) if L >= k else []
    gib = 2**30
    if str((solver_options or {}).get("solver", "clarabel")).lower() == "scs":
        nnz = sum(len(b) ** 2 for b in sigma) + sum(len(b) ** 2 * len(data.V) for b in lam)
        choice = choose_solver([len(b) for b in sigma + lam], len(monomials(n, 2 * D, 0)), nnz,
                               "scs")  # fmt: skip
        if choice.solver is None:
            return None, choice.reason
        return SparsePlan([tuple(range(n))], sigma, lam, kind="sdsos"), ""
    sdd = [False] * len(sigma)
    p = SparsePlan([tuple(range(n))], sigma, lam, tuple(sdd), "sdsos")
    for i in range(len(sigma)):  # the largest first
        if p.bytes <= MAX_SDP_BYTES and not (force and i == 0):
            break
        sdd[i] = True
        p = SparsePlan([tuple(range(n))], sigma, lam, tuple(sdd), "sdsos")
    if p.bytes > MAX_SDP_BYTES:
        return None, (f"an estimated {p.bytes / gib:.3g} GiB even with the large blocks scaled "
                      f"diagonally dominant (budget {MAX_SDP_BYTES / gib:.3g} GiB)")  # fmt: skip
    if not force and len(sigma[0]) > MAX_SDD_BLOCK:
        return None, (f"its largest block of {len(sigma[0])} monomials would hold "
                      f"{len(sigma[0]) * (len(sigma[0]) - 1) // 2} cones, more than the automatic "
                      f"route takes (blocks up to {MAX_SDD_BLOCK} monomials); not built: "
                      "route='sdsos' forces it")  # fmt: skip
    return p, ""


ROUTES = ("auto", "dense", "sparse", "sdsos")


def choose_route(data: ExactData, multiplier_degree: int | None = None, route: str = "auto",
                 solver_options: dict[str, Any] | None = None
                 ) -> tuple[str, SparsePlan | None, str]:  # fmt: skip
    """``("dense" | "sparse" | "sdsos" | "too_large", plan, why)``: with ``route="auto"`` the
    dense program if its Gram block fits :data:`MAX_SDP_BYTES`, else the clique one if it
    applies and fits, else the SDSOS one if it fits, else none; any other ``route`` forces
    that program (``too_large`` with the reason when it does not apply or fit)."""
    if route not in ROUTES:
        raise ValueError(f"route must be one of {ROUTES}, got {route!r}")
    k, D, _ = degrees(data, multiplier_degree)
    dense = len(monomials(data.n, D, k))
    if route == "dense" or (route == "auto" and sdp_bytes(dense) <= MAX_SDP_BYTES):
        return "dense", None, ""
    too = (f"a dense Gram block of {dense} monomials needs an estimated "
           f"{sdp_bytes(dense) / 2**30:.3g} GiB (budget {MAX_SDP_BYTES / 2**30:.3g} GiB)")  # fmt: skip
    if route != "auto":
        too = f"the {route} route was requested (the dense Gram block: {dense} monomials)"
    p: SparsePlan | None = None
    if route in ("auto", "sparse"):
        p, why = plan(data, multiplier_degree)
        if p is not None and p.bytes > MAX_SDP_BYTES:
            why = (f"the sparse program's {len(p.sigma) + len(p.lam)} blocks need an estimated "
                   f"{p.bytes / 2**30:.3g} GiB")  # fmt: skip
        elif p is not None:
            return "sparse", p, too
        too = f"{too}; {why}"
        if route == "sparse":
            return "too_large", p, too
    s, why = sdsos_plan(data, multiplier_degree, solver_options, force=route == "sdsos")
    if s is None:
        return "too_large", p, f"{too}; SDSOS: {why}"
    return "sdsos", s, too


class SparseProgram:
    """The sparse program of a plan, compiled once with the level as a parameter (cvxpy DPP), so
    that a bisection on the level re-solves it without building it again."""

    def __init__(self, data: ExactData, plan: SparsePlan, *, eps: Fraction | None = None,
                 solver_options: dict[str, Any] | None = None) -> None:  # fmt: skip
        import cvxpy as cp

        t0 = time.perf_counter()
        self.plan = plan
        self.eps = default_eps(data) if eps is None else Fraction(eps)
        self.solver_options = dict(solver_options or {})
        zero = tuple([0] * data.n)
        prog = Program(data.n)
        target = level_target(data, self.eps)
        prog.const({m: -v for m, v in target.items()})
        self.t = prog.scalar()
        self.level = cp.Parameter(nonneg=True)
        minus_V: dict[Mono, float] = {m: -float(c) for m, c in data.V.items()}
        syms = sign_symmetries([target, data.V], data.n)  # each block split by parity class
        for i, b in enumerate(plan.sigma):
            for piece in split(b, syms):
                prog.gram(piece, {zero: 1.0}, sign=1.0, margin=self.t,
                          cone="sdd" if plan.is_sdd(i) else "psd")  # fmt: skip
        self.K = len(prog.grams)
        # lambda_j (c - V) = c lambda_j - lambda_j V: the level multiplies the first part only
        for b in plan.lam:
            for piece in split(b, syms):
                prog.gram(piece, minus_V, sign=1.0, margin=self.t, level=self.level,
                          level_times={zero: 1.0})  # fmt: skip
        self.bases = [b for b, _ in prog.grams]
        self.Qs = [Q for _, Q in prog.grams]
        self.cones = tuple(prog.cones) if "sdd" in prog.cones else ()
        self.problem = prog.problem(self.t, extra=[self.t <= 1])
        self.rows = len(prog.rows)
        self.build_seconds = time.perf_counter() - t0

    def solve(self, level: float) -> Candidate:
        """The program at ``level``: float blocks and the margin ``t`` (None when it failed)."""
        t0 = time.perf_counter()
        self.level.value = float(level)
        res = solve(self.problem, options=self.solver_options)
        Qs = self.Qs
        ok = res.usable and all(Q.value is not None for Q in Qs)
        vals = [np.asarray(Q.value) for Q in Qs] if ok else None
        t = self.t.value
        figures = {"rows": self.rows, "build_seconds": round(self.build_seconds, 3),
                   "solve_seconds": round(time.perf_counter() - t0, 3),
                   "estimated_gib": round(self.plan.bytes / 2**30, 4)}  # fmt: skip
        cert = None
        if vals is not None:
            cert = Certificate(tuple((0 if i < self.K else 1, b, Q) for i, (b, Q) in
                                     enumerate(zip(self.bases, vals, strict=True))), (),
                               self.cones)  # fmt: skip
        return Candidate(cert, self.eps, float(t) if ok and t is not None else None, res.status,
                         time.perf_counter() - t0, figures)  # fmt: skip


def propose_sparse(data: ExactData, level: float, plan: SparsePlan, *, eps: Fraction | None = None,
                   solver_options: dict[str, Any] | None = None) -> Candidate:  # fmt: skip
    """Solve the sparse program of ``plan`` at ``level`` once (module docstring)."""
    prog = SparseProgram(data, plan, eps=eps, solver_options=solver_options)
    cand = prog.solve(level)
    return dataclasses.replace(cand, seconds=cand.seconds + prog.build_seconds)
