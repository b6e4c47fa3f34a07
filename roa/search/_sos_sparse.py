"""Patterned numerical SOS certificates of a fixed level (cliques, sign classes, SDSOS; proposes only).

The program of :mod:`roa.search._sos_certificate` (``-V' - eps|d|^2k - lambda (c - V) = sigma``,
``lambda``, ``sigma`` SOS) with one Gram matrix over all monomials of degree ``k..D`` in ``n``
variables needs ``O(n^2D)`` entries: at 20-30 states and degree 4, far more solver memory than
the budget :data:`roa.search.MAX_SDP_BYTES`. Correlative sparsity (Waki, Kim, Kojima and Muramatsu 2006; CS-TSSOS,
Wang, Magron, Lasserre and Mai 2022) uses the structure of the polynomials instead:

* the **interaction graph** joins two variables when they occur in one monomial of ``V'`` or
  ``V``; a **chordal extension** (:func:`networkx.complete_to_chordal_graph`) and its maximal
  cliques ``C_1 .. C_K`` (:func:`networkx.chordal_graph_cliques`) give the blocks;
* ``sigma`` gets one Gram block per clique over the monomials of degree ``k..D`` in its variables,
  and ``lambda = sum_j lambda_j`` one block per clique over the monomials of degree ``1..L``;
* ``lambda_j V`` has monomials across cliques: ``V`` splits over the connected components ``G``
  of its own interaction graph, ``V = sum_G V_G`` with ``V_G = z_G' P_G z_G`` a Gram form over
  the monomials ``z_G`` of ``G``'s variables (:func:`V_groups`), so ``lambda_j V_G = (m
  (x) z_G)' (Q_j (x) P_G) (m (x) z_G)`` for ``lambda_j = m' Q_j m``: ``sigma`` gets one more block
  per clique ``j`` and group ``G`` not inside it, over the products ``{m w : m in lambda_j's
  basis, w in z_G}`` (a diagonal quadratic V: one block per clique and variable outside it, over
  ``{m d_q}``; a coupled V: larger blocks, any V of any degree).

Every block is an ordinary Gram form, so :func:`roa.proof._putinar.check_level` proves the result
exactly whatever the structure. The program is a restriction of the dense one (a sum of these
blocks is one Gram matrix with zeros elsewhere): whatever it certifies the dense program could,
not conversely; it loses most where ``V' >= 0`` is first reached with many variables at once,
since each clique's blocks see only the part of ``V`` they hold. Each block is kept ``>= t I`` with the common margin ``t``
maximised (``t <= 1``), as in the dense program.

A dense coupled system (a complete interaction graph: no cliques) gets the **SDSOS pattern**
(:func:`sdsos_plan`) instead: the dense program's bases split by sign symmetry
(:mod:`roa.search._sos_symmetry`), and the largest ``sigma`` blocks, while the interior point's
memory estimate exceeds the budget, made scaled diagonally dominant (``cone="sdd"`` of
:meth:`roa.search._sdp.Program.gram`; Ahmadi and Majumdar 2019): a restriction, whatever it
certifies the dense program could, with memory linear in the block's pairs. The exact check proves
those blocks by scaled diagonal dominance (:func:`roa.proof._putinar.check_identity`). With
``"solver": "scs"`` in the solver options every block stays PSD and SCS, whose memory grows with
the program's size only, solves it.

:func:`choose_route` picks the program automatically: the dense one when its Gram block fits the
memory budget :data:`roa.search.MAX_SDP_BYTES`, else the clique one when it applies (a clique
smaller than ``n``) and fits, else the SDSOS one when it fits, else none
(``too_large``). :func:`route_for` is that choice made once for exact data, as an object that
proposes a certificate at any level (:class:`SosRoute`): the exact validator and the level search
both use it.
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from roa.proof._putinar import Certificate
from roa.proof._sos_check import ExactData, Mono, mono_add
from roa.search._sdp import (
    MAX_SDP_BYTES,
    Program,
    choose_solver,
    monomials,
    sdd_bytes,
    sdp_bytes,
    solve,
)
from roa.search._sos_certificate import (
    Candidate,
    default_eps,
    degrees,
    level_target,
    propose_certificate,
)
from roa.search._sos_symmetry import sign_symmetries, split


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


def V_groups(data: ExactData) -> list[tuple[tuple[int, ...], list[Mono]]]:
    """V's variables split into the connected components of its own interaction graph (an
    edge for two variables of one monomial of ``V``), each with the monomials ``z_G`` in its
    variables of degree ``ceil(low / 2) .. ceil(deg / 2)`` (``low``, ``deg``: V's least and
    largest degrees), over which its part ``V_G`` is a Gram form."""
    import networkx as nx

    n = data.n
    G = nx.Graph()
    G.add_nodes_from(range(n))
    for m in data.V:
        G.add_edges_from(itertools.combinations([i for i, e in enumerate(m) if e], 2))
    low = min(sum(m) for m in data.V)
    top = max(sum(m) for m in data.V)
    out = []
    for comp in sorted(tuple(sorted(int(i) for i in c)) for c in nx.connected_components(G)):
        local = monomials(len(comp), (top + 1) // 2, (low + 1) // 2)
        out.append((comp, _embed(local, comp, n)))
    return out


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
    """The sparse bases, or None and why the route does not apply (one clique holding every
    variable)."""
    n = data.n
    cl = cliques(data)
    if max(len(c) for c in cl) >= n:
        return None, "the interaction graph's chordal extension is complete: no sparsity"
    k, D, L = degrees(data, multiplier_degree)
    sigma = [_embed(monomials(len(c), D, k), c, n) for c in cl]
    lam = [_embed(monomials(len(c), L, 1), c, n) for c in cl] if L >= 1 else []
    groups = V_groups(data)
    for c, basis in zip(cl, lam, strict=False):
        for group, z in groups:
            if set(group) <= set(c):
                continue
            block = {mono_add(m, w): None for m in basis for w in z}  # lambda_c V_G's Gram basis
            sigma.append(list(block))
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


@dataclass
class SosRoute:
    """The program chosen once for exact data (:func:`route_for`): ``kind`` ``"dense"``,
    ``"sparse"``, ``"sdsos"`` or ``"too_large"``, its plan (None: dense) and why the dense one
    was not taken. :meth:`propose` solves it at a level (a patterned program compiled once per
    ``eps``, the level a parameter)."""

    data: ExactData
    kind: str
    plan: SparsePlan | None
    why: str
    multiplier_degree: int | None = None
    solver_options: dict[str, Any] | None = None
    compiled: dict[Fraction, SparseProgram] = field(default_factory=dict)

    def propose(self, level: float, eps: Fraction | None = None) -> Candidate:
        """A candidate certificate of ``level`` (only :func:`roa.proof._putinar.check_level`
        decides)."""
        eps = default_eps(self.data) if eps is None else Fraction(eps)
        if self.kind == "too_large":
            return Candidate(None, eps, None, f"too large: {self.why}", 0.0)
        if self.plan is None:
            return propose_certificate(self.data, level, eps=eps,
                                       multiplier_degree=self.multiplier_degree,
                                       solver_options=self.solver_options)  # fmt: skip
        prog = self.compiled.get(eps)
        build = 0.0
        if prog is None:
            prog = self.compiled[eps] = SparseProgram(self.data, self.plan, eps=eps,
                                                      solver_options=self.solver_options)  # fmt: skip
            build = prog.build_seconds
        cand = prog.solve(level)
        return dataclasses.replace(cand, seconds=cand.seconds + build)


def route_for(data: ExactData, multiplier_degree: int | None = None, route: str = "auto",
              solver_options: dict[str, Any] | None = None) -> SosRoute:  # fmt: skip
    """The route of ``data`` (:func:`choose_route`), chosen once. For a V of degree above 2 and
    no ``multiplier_degree`` given, the multiplier gets V's degree when that program fits (the
    least degree balancing ``lambda V`` against ``V'`` leaves ``lambda`` quadratic, too weak for
    a quartic V's sublevel sets: ``tests/proof/test_sos_combinations.py``), else the least."""
    deg_v = max(sum(m) for m in data.V)
    if multiplier_degree is None and deg_v > 2:
        kind, p, why = choose_route(data, deg_v, route, solver_options)
        if kind == "dense" if route == "auto" else kind != "too_large":
            return SosRoute(data, kind, p if kind in ("sparse", "sdsos") else None, why, deg_v,
                            solver_options)  # fmt: skip
    kind, p, why = choose_route(data, multiplier_degree, route, solver_options)
    return SosRoute(data, kind, p if kind in ("sparse", "sdsos") else None, why,
                    multiplier_degree, solver_options)  # fmt: skip
