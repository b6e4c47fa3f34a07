"""The one fixed-level SOS program: any problem's Putinar identity with any sparsity pattern.

**Problem.** The exact data of a level after the reductions (:mod:`roa.proof._reductions`):
:class:`roa.proof._sos_check.ExactData` (a polynomial field) or
:class:`roa.proof._recast.RecastData` (a recast field, a parameter box), read as by
:func:`roa.proof._putinar.check_level`: ``T = -N - eps |d|^(2k)``, factors ``t_0 = 1``,
``t_1 = c - V``, ``t_{2+j} = g_j`` (inequalities) and equalities ``h_e``. :class:`FixedLevel`
builds once (:class:`roa.search._sdp.Program`, the level ``c`` a cvxpy parameter, so that a
bisection re-solves without rebuilding) the program::

    T - sum_{b : k_b >= 1} (m_b' Q_b m_b) t_{k_b} - sum_e mu_e h_e = sum_{b : k_b = 0} m_b' Q_b m_b

with every ``Q_b >= t I`` (or ``Q_b - t I`` scaled diagonally dominant) and the common margin
``t <= 1`` maximised: the margin the exact rounding and projection need. Its float solution is a
:class:`Candidate`; only :func:`roa.proof._putinar.check_level` decides.

**Bases** (:func:`bases`; ``z`` the states, auxiliaries and parameters). ``2k`` is the lowest
state degree of ``N``; ``sigma`` gets the monomials of degree ``k..D``, ``lambda`` those of
degree ``k..L`` (:func:`degrees`: ``2L`` the multiplier's degree, default the least even degree
with ``2L + deg V >= deg N``; ``2D`` the least even degree >= ``deg N`` and ``2L + deg V``). A
degenerate equilibrium (``2k > 2``) forces every term of ``lambda`` below degree ``2k`` to
vanish, so both bases start at ``k`` (the Newton polytope): a basis reaching lower leaves no
strictly feasible point. Per angle of a recast, ``sigma`` also gets ``d^j``, ``d^j s``, ``d^j q``
up to degree ``H`` (``2H`` the highest Taylor bound's degree); an inequality ``g`` of degree
``<= 2D - 2`` gets an SOS multiplier over the degrees ``0..D - deg g / 2``, a higher one a
constant; an equality a free multiplier of degree ``<= 2D - 2`` (a circle's also the angle's
powers ``d^j`` up to ``2H - 2``). With parameters as variables, ``V' = 0`` at ``x_eq`` for every
parameter: blocks keep only monomials of state degree >= 1 (an inequality's and an equality's
multiplier also the constant), else no Gram matrix would be strictly feasible.

**Patterns** (:class:`Pattern`): the blocks ``(factor, basis, cone)`` and the equalities'
multiplier bases. Each is a restriction of the dense program (its blocks form one Gram matrix
with zeros elsewhere): whatever it certifies the dense program could. Every pattern applies to
every problem:

* ``dense`` (:func:`dense`): one block per factor;
* ``sparse`` (:func:`clique_pattern`, correlative sparsity: Waki, Kim, Kojima and Muramatsu
  2006; CS-TSSOS): the **interaction graph** joins two variables of one monomial of ``N`` or
  ``V``, and all the variables of an inequality or an equality; the maximal cliques ``C_j`` of a
  chordal extension (an angle's ``s``, ``q`` contracted with its state, functions of it) get one
  ``sigma`` and one ``lambda`` block each (the dense bases restricted to the clique), each
  inequality one multiplier block per clique holding it, each equality a free multiplier over
  the monomials of the cliques holding it. ``lambda_j V`` has monomials across cliques:
  ``V = sum_G V_G`` over the connected components ``G`` of V's own graph, ``V_G = z_G' P_G z_G``
  (:func:`V_groups`), so ``lambda_j V_G`` is a Gram form over ``{m w : m in lambda_j's basis,
  w in z_G}``, one more ``sigma`` block per clique and group not inside it (any V of any
  degree). Independent blocks of variables inside one problem (a recast of decoupled
  subsystems) are the cliques of a disconnected graph;
* ``sdsos`` (:func:`sdsos`, Ahmadi and Majumdar 2019): the dense blocks, the largest ``sigma``
  blocks scaled diagonally dominant while the interior point's memory estimate exceeds the
  budget (proved by exact dominance); with ``"solver": "scs"`` every block stays PSD and SCS,
  whose memory grows with the program's size only, solves it;
* **sign symmetry**, on every pattern (:func:`sign_symmetries`, :func:`split`): each block split
  by the parity classes of the flips that fix every polynomial of the identity, the equality
  multipliers kept to the invariant monomials (the same optimum).

**Route** (:func:`choose_route`, :func:`route_for`): chosen once per problem; ``auto`` takes the
dense pattern when its ``sigma`` block fits :data:`MAX_SDP_BYTES` (and the interaction graph is
connected), else the clique one when it applies and fits, else the SDSOS one when it fits, else
none (``too_large``).

**Domain containment** (:func:`propose_domain_certificate`): for a polynomial margin ``g``, the
same program with ``T = g - eps``, ``t_1 = c - V``, ``m_1`` of degree ``0..L`` (``2L`` the least
even degree with ``2L + deg V >= deg g``) and ``m_0`` of degree ``0..D`` (``2D`` the least even
degree >= ``deg g`` and ``2L + deg V``); only :func:`roa.proof._domain.check_domain_certificate`
decides.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Any

import numpy as np

from roa.proof._domain import domain_target
from roa.proof._putinar import Certificate, level_identity
from roa.proof._reductions import components, graph
from roa.proof._sos_check import Mono, QPoly, mono_add
from roa.search._sdp import (
    MAX_SDP_BYTES,
    Program,
    choose_solver,
    monomials,
    sdd_bytes,
    sdp_bytes,
    solve,
)

ROUTES = ("auto", "dense", "sparse", "sdsos")

#: Largest block the automatic route makes scaled diagonally dominant: the solve time grows with
#: the number of 2 x 2 cones (one per pair of monomials), so larger blocks are built only when
#: the SDSOS route is requested.
MAX_SDD_BLOCK = 256


@dataclass(frozen=True)
class Candidate:
    """A certificate proposed by a program, in floats (only :mod:`roa.proof._putinar` decides):
    ``certificate`` None when the solver gave no usable point; ``margin`` the least eigenvalue
    ``t`` of the Gram blocks the program maximised; ``sizes`` the program's figures."""

    certificate: Certificate | None
    eps: Fraction
    margin: float | None
    solver_status: str
    seconds: float
    sizes: dict[str, Any] = field(default_factory=dict)

    @property
    def feasible(self) -> bool:
        """A solution with a positive margin (every block positive definite numerically)."""
        return self.certificate is not None and self.margin is not None and self.margin > 0


def default_eps(data: Any, scale: float = 1e-6) -> Fraction:
    """``scale`` x the largest |coefficient| of the lowest-degree part of ``N`` (``V'``, or its
    recast numerator; the degree in the state variables, parameters not counted), a dyadic:
    the one default of every route."""
    nz = data.nv - len(getattr(data, "parameters", ()))
    top = max((abs(float(c)) for m, c in data.N.items() if sum(m[:nz]) == data.low), default=1.0)
    return Fraction(2.0 ** round(np.log2(scale * top)))


def degrees(data: Any, multiplier_degree: int | None = None) -> tuple[int, int, int]:
    """``(k, D, L)``: ``sigma``'s monomials of degree ``k..D``, ``lambda``'s of degree ``k..L``
    (module docstring; ``multiplier_degree`` None: the least even degree balancing ``lambda V``
    against ``N``)."""
    k = data.low // 2
    degV = max(sum(m) for m in data.V)
    degN = max((sum(m) for m in data.N), default=2)
    if multiplier_degree is None:
        multiplier_degree = max(2, degN - degV + (degN - degV) % 2)
    L = max(multiplier_degree // 2, k)
    return max(k, 1), (max(degN, 2 * L + degV) + 1) // 2, L


def _unit(nv: int, i: int, p: int = 1) -> Mono:
    return tuple(p if k == i else 0 for k in range(nv))


@dataclass(frozen=True)
class Bases:
    """The dense bases (module docstring): ``sigma``; per factor ``k >= 1`` (``c - V``, then
    each inequality) its multiplier's; per equality its free multiplier's."""

    sigma: list[Mono]
    factors: list[list[Mono]]
    free: list[list[Mono]]


def bases(data: Any, multiplier_degree: int | None = None) -> Bases:
    """The dense bases of ``data`` (module docstring)."""
    nv = data.nv
    k, D, L = degrees(data, multiplier_degree)
    sigma = monomials(nv, D, k)
    lam = monomials(nv, L, k) if L >= k else []
    top = max((sum(m) for _, g in data.inequalities for m in g), default=2)
    H = max(D, (top + 1) // 2)
    powers: list[list[Mono]] = []
    for a, i in enumerate(getattr(data, "angles", ())):
        sigma += [m for j in range(H + 1) for m in (_unit(nv, i, j), *(mono_add(
            _unit(nv, i, j), _unit(nv, aux)) for aux in data.aux(a))) if D < sum(m) <= H]  # fmt: skip
        powers.append([_unit(nv, i, j) for j in range(2 * D - 1, 2 * H - 1)])
    ineq = []
    for _, g in data.inequalities:
        deg_g = max(sum(m) for m in g)
        ineq.append(monomials(nv, D - (deg_g + 1) // 2, 0) if deg_g <= 2 * D - 2
                    else [tuple([0] * nv)])  # fmt: skip
    free = [monomials(nv, 2 * D - 2, 0) + (powers[e] if e < len(powers) else [])
            for e in range(len(data.equalities))]  # fmt: skip
    boxes = len(getattr(data, "parameters", ()))
    if boxes:  # V' = 0 at x_eq for every parameter: no block may be > 0 there
        nz = nv - boxes

        def moving(basis: list[Mono], keep_one: bool = False) -> list[Mono]:
            return [m for m in basis if sum(m[:nz]) >= 1 or (keep_one and sum(m) == 0)]

        sigma, lam = moving(sigma), moving(lam)
        ineq = [moving(B, keep_one=True) for B in ineq[:-boxes]] + [moving(B) for B in
                                                                    ineq[-boxes:]]  # fmt: skip
        free = [moving(B, keep_one=True) for B in free]
    return Bases(sigma, [lam, *ineq], free)


def support(poly: Any) -> set[int]:
    """The variables of ``poly``'s monomials."""
    return {i for m in poly for i, e in enumerate(m) if e}


def interaction_graph(data: Any) -> Any:
    """The variables' interaction graph (networkx): an edge for two variables of one monomial of
    ``N`` or ``V``, or of one inequality or equality (a multiplier times it mixes all its
    variables)."""
    G = graph(range(data.nv), (data.N, data.V))
    for _, p in (*data.inequalities, *data.equalities):
        G.add_edges_from(itertools.combinations(sorted(support(p)), 2))
    return G


def cliques(data: Any) -> list[tuple[int, ...]]:
    """Maximal cliques of a chordal extension of :func:`interaction_graph` (sorted), an angle's
    ``s`` and ``q`` (functions of its state) taken with its state: the extension is of the
    graph with each angle's three variables contracted to one, and each clique holds them all."""
    import networkx as nx

    owner = {v: i for a, i in enumerate(getattr(data, "angles", ())) for v in data.aux(a)}
    G = nx.Graph()
    G.add_nodes_from(v for v in range(data.nv) if v not in owner)
    G.add_edges_from((owner.get(u, u), owner.get(v, v)) for u, v in interaction_graph(data).edges
                     if owner.get(u, u) != owner.get(v, v))  # fmt: skip
    H, _ = nx.complete_to_chordal_graph(G)
    members = {v: [v, *(u for u, o in owner.items() if o == v)] for v in G}
    return sorted(tuple(sorted(int(u) for v in c for u in members[v]))
                  for c in nx.chordal_graph_cliques(H))  # fmt: skip


def V_groups(data: Any) -> list[tuple[tuple[int, ...], list[Mono]]]:
    """V's variables split into the connected components of its own interaction graph, each with
    the monomials ``z_G`` in its variables of degree ``ceil(low / 2) .. ceil(deg / 2)`` (``low``,
    ``deg``: V's least and largest degrees), over which its part ``V_G`` is a Gram form."""
    low, top = min(sum(m) for m in data.V), max(sum(m) for m in data.V)
    basis = monomials(data.nv, (top + 1) // 2, (low + 1) // 2)
    return [(c, _inside(basis, c)) for c in components(graph(support(data.V), [data.V]))]


def _inside(basis: list[Mono], clique: tuple[int, ...] | set[int]) -> list[Mono]:
    """The monomials of ``basis`` in the variables of ``clique`` only."""
    inside = set(clique)
    return [m for m in basis if all(i in inside for i, e in enumerate(m) if e)]


def sign_symmetries(polys: Iterable[dict[Mono, Any]], nv: int) -> list[Mono]:
    """A basis of the sign symmetries of ``polys`` in ``nv`` variables: the sets ``S`` of variables
    whose joint sign flip fixes every polynomial (0/1 vectors ``s`` with ``s . m`` even for every
    monomial ``m``; a GF(2) vector space, this is the null space of the exponents mod 2; empty
    when none but 0). The group acts on ``m' Q m`` by diagonal +-1 matrices, so averaging any
    certificate over it keeps the identity and positive definiteness and zeroes every entry of
    ``Q`` between monomials of different parities: an invariant certificate's Gram matrix is
    block-diagonal by parity class (Gatermann and Parrilo 2004; TSSOS's sign symmetries)."""
    pivots: dict[int, int] = {}  # pivot column -> reduced row (bit masks, bit i = variable i)
    for p in polys:
        for m in p:
            row = sum(1 << i for i, e in enumerate(m) if e % 2)
            for col, prow in pivots.items():
                if row >> col & 1:
                    row ^= prow
            if row:
                col = (row & -row).bit_length() - 1
                for c in list(pivots):  # keep the rows reduced: clear the new pivot elsewhere
                    if pivots[c] >> col & 1:
                        pivots[c] ^= row
                pivots[col] = row
    out = []
    for free in range(nv):  # one null vector per free column
        if free in pivots:
            continue
        s = [0] * nv
        s[free] = 1
        for col, row in pivots.items():
            if row >> free & 1:
                s[col] = 1
        out.append(tuple(s))
    return out


def split(basis: list[Mono], symmetries: list[Mono]) -> list[list[Mono]]:
    """``basis`` split into its parity classes under ``symmetries`` (in order of first
    appearance; the whole basis when there is no symmetry): the same optimum with smaller
    blocks, for any pattern; the exact check proves whatever blocks it is given."""
    if not symmetries:
        return [basis] if basis else []
    classes: dict[tuple[int, ...], list[Mono]] = {}
    for m in basis:
        key = tuple(sum(a * b for a, b in zip(s, m, strict=True)) % 2 for s in symmetries)
        classes.setdefault(key, []).append(m)
    return list(classes.values())


@dataclass(frozen=True)
class Pattern:
    """The blocks ``(factor, basis, cone)`` of a program and its equalities' multiplier bases
    (module docstring); ``kind`` ``"dense"``, ``"sparse"`` or ``"sdsos"``; ``symmetries`` the
    sign flips its blocks were split by; ``cross`` the number of cross blocks (last among the
    ``sigma`` ones)."""

    kind: str
    blocks: tuple[tuple[int, list[Mono], str], ...]
    free: tuple[list[Mono], ...] = ()
    cliques: tuple[tuple[int, ...], ...] = ()
    symmetries: int = 0
    cross: int = 0

    @property
    def sigma(self) -> list[list[Mono]]:
        return [b for k, b, _ in self.blocks if k == 0]

    @property
    def lam(self) -> list[list[Mono]]:
        return [b for k, b, _ in self.blocks if k == 1]

    @property
    def sdd(self) -> tuple[bool, ...]:
        """Per ``sigma`` block: scaled diagonally dominant."""
        return tuple(c == "sdd" for k, _, c in self.blocks if k == 0)

    @property
    def largest(self) -> int:
        return max(len(b) for _, b, _ in self.blocks)

    @property
    def bytes(self) -> int:
        """Estimated peak memory of the interior-point solve: the blocks' sum."""
        return sum(sdd_bytes(len(b)) if c == "sdd" else sdp_bytes(len(b))
                   for _, b, c in self.blocks)  # fmt: skip

    @property
    def sizes(self) -> dict[str, Any]:
        sigma, lam = [len(b) for b in self.sigma], [len(b) for b in self.lam]
        if self.kind == "sdsos":
            return {"sign_blocks": sigma, "lambda_blocks": lam,
                    "sdd_blocks": [len(b) for b, s in zip(self.sigma, self.sdd, strict=True) if s],
                    "estimated_gib": round(self.bytes / 2**30, 4)}  # fmt: skip
        if self.kind == "sparse":
            return {"cliques": [len(c) for c in self.cliques],
                    "sigma_clique_blocks": sigma[: len(sigma) - self.cross],
                    "sigma_cross_blocks": self.cross, "lambda_blocks": lam}  # fmt: skip
        return {"gram_sizes": sigma + lam}


def _syms(data: Any, symmetry: bool) -> list[Mono]:
    """The sign symmetries of the identity of ``data`` (every polynomial of it; none when
    ``symmetry`` is False)."""
    if not symmetry:
        return []
    target, times = level_identity(data, Fraction(1), Fraction(1))
    return sign_symmetries([target, *times, *(h for _, h in data.equalities)], data.nv)


def _split(kind: str, blocks: list[tuple[int, list[Mono], str]], free: list[list[Mono]],
           syms: list[Mono], **extra: Any) -> Pattern:  # fmt: skip
    """The pattern with every block split by the sign symmetries ``syms`` and the equality
    multipliers kept to the invariant monomials."""
    pieces = [(k, piece, c) for k, b, c in blocks for piece in split(b, syms)]
    even = [[m for m in B if not any(sum(a * b for a, b in zip(s, m, strict=True)) % 2
                                     for s in syms)] for B in free]  # fmt: skip
    return Pattern(kind, tuple(pieces), tuple(even), symmetries=len(syms), **extra)


def dense(data: Any, multiplier_degree: int | None = None, *, symmetry: bool = True) -> Pattern:
    """One block per factor (split by sign symmetry)."""
    B = bases(data, multiplier_degree)
    blocks = [(0, B.sigma, "psd")] + [(k + 1, b, "psd") for k, b in enumerate(B.factors) if b]
    return _split("dense", blocks, B.free, _syms(data, symmetry))


def clique_pattern(data: Any, multiplier_degree: int | None = None, *, symmetry: bool = True
                   ) -> tuple[Pattern | None, str]:  # fmt: skip
    """The clique pattern (module docstring), or None and why it does not apply (one clique
    holding every variable)."""
    cl = cliques(data)
    if max(len(c) for c in cl) >= data.nv:
        return None, "the interaction graph's chordal extension is complete: no sparsity"
    B = bases(data, multiplier_degree)
    sigma = [(0, _inside(B.sigma, c), "psd") for c in cl]
    lam = [_inside(B.factors[0], c) for c in cl]
    groups = V_groups(data)
    cross = [(0, list({mono_add(m, w): None for m in basis for w in z}), "psd")
             for c, basis in zip(cl, lam, strict=True) if basis
             for group, z in groups if not set(group) <= set(c)]  # fmt: skip

    def homes(poly: Any) -> list[tuple[int, ...]]:
        return [c for c in cl if support(poly) <= set(c)]

    ineq = [(j + 2, _inside(b, c), "psd")
            for j, (b, (_, g)) in enumerate(zip(B.factors[1:], data.inequalities, strict=True))
            for c in homes(g)]  # fmt: skip
    free = [list({m: None for c in homes(h) for m in _inside(b, c)})
            for b, (_, h) in zip(B.free, data.equalities, strict=True)]  # fmt: skip
    blocks = [x for x in sigma + cross + [(1, b, "psd") for b in lam] + ineq if x[1]]
    syms = _syms(data, symmetry)
    return _split("sparse", blocks, free, syms, cliques=tuple(cl),
                  cross=sum(len(split(b, syms)) for _, b, _ in cross)), ""  # fmt: skip


def sdsos(data: Any, multiplier_degree: int | None = None,
          solver_options: dict[str, Any] | None = None, *, force: bool = False,
          symmetry: bool = True) -> tuple[Pattern | None, str]:  # fmt: skip
    """The SDSOS pattern (module docstring): the dense pattern's blocks, the largest ``sigma``
    ones scaled diagonally dominant until the estimate fits :data:`MAX_SDP_BYTES` (``force``: at
    least the largest one); with ``"solver": "scs"`` none, the estimate SCS's. None and why when
    it does not fit."""
    d = dense(data, multiplier_degree, symmetry=symmetry)
    sigma = sorted((b for b in d.blocks if b[0] == 0), key=lambda b: -len(b[1]))
    rest = sorted((b for b in d.blocks if b[0] != 0), key=lambda b: (b[0], -len(b[1])))
    gib = 2**30

    def pattern(n_sdd: int) -> Pattern:
        flagged = [(k, b, "sdd" if i < n_sdd else c) for i, (k, b, c) in enumerate(sigma)]
        return Pattern("sdsos", tuple(flagged + rest), d.free, (tuple(range(data.nv)),),
                       d.symmetries)  # fmt: skip

    if str((solver_options or {}).get("solver", "clarabel")).lower() == "scs":
        nnz = sum(len(b) ** 2 * (len(data.V) if k else 1) for k, b, _ in d.blocks)
        rows = len(monomials(data.nv, 2 * degrees(data, multiplier_degree)[1], 0))
        choice = choose_solver([len(b) for _, b, _ in d.blocks], rows, nnz, "scs")
        return (pattern(0), "") if choice.solver is not None else (None, choice.reason)
    p = pattern(0)
    for i in range(len(sigma)):  # the largest first
        if p.bytes <= MAX_SDP_BYTES and not (force and i == 0):
            break
        p = pattern(i + 1)
    if p.bytes > MAX_SDP_BYTES:
        return None, (f"an estimated {p.bytes / gib:.3g} GiB even with the large blocks scaled "
                      f"diagonally dominant (budget {MAX_SDP_BYTES / gib:.3g} GiB)")  # fmt: skip
    if not force and len(sigma[0][1]) > MAX_SDD_BLOCK:
        m = len(sigma[0][1])
        return None, (f"its largest block of {m} monomials would hold {m * (m - 1) // 2} cones, "
                      f"more than the automatic route takes (blocks up to {MAX_SDD_BLOCK} "
                      "monomials); not built: route='sdsos' forces it")  # fmt: skip
    return p, ""


def dense_fits(data: Any, multiplier_degree: int | None = None) -> bool:
    """Whether the dense program of ``data`` is within the memory budget (:data:`MAX_SDP_BYTES`)."""
    return sdp_bytes(len(bases(data, multiplier_degree).sigma)) <= MAX_SDP_BYTES


def choose_route(data: Any, multiplier_degree: int | None = None, route: str = "auto",
                 solver_options: dict[str, Any] | None = None
                 ) -> tuple[str, Pattern | None, str]:  # fmt: skip
    """``("dense" | "sparse" | "sdsos" | "too_large", pattern, why)`` (module docstring); any
    ``route`` but ``"auto"`` forces that pattern (``too_large`` with the reason when it does not
    apply or fit)."""
    import networkx as nx

    if route not in ROUTES:
        raise ValueError(f"route must be one of {ROUTES}, got {route!r}")
    size = len(bases(data, multiplier_degree).sigma)
    fits = dense_fits(data, multiplier_degree)
    joined = route != "auto" or nx.is_connected(interaction_graph(data))
    if route == "dense" or (route == "auto" and fits and joined):
        return "dense", dense(data, multiplier_degree), ""
    too = (f"a dense Gram block of {size} monomials needs an estimated "
           f"{sdp_bytes(size) / 2**30:.3g} GiB (budget {MAX_SDP_BYTES / 2**30:.3g} GiB)")  # fmt: skip
    if route != "auto":
        too = f"the {route} route was requested (the dense Gram block: {size} monomials)"
    elif fits:
        too = "independent blocks of variables (a disconnected interaction graph)"
    p: Pattern | None = None
    if route in ("auto", "sparse"):
        p, why = clique_pattern(data, multiplier_degree)
        if p is not None and p.bytes > MAX_SDP_BYTES:
            why = (f"the sparse program's {len(p.blocks)} blocks need an estimated "
                   f"{p.bytes / 2**30:.3g} GiB")  # fmt: skip
        elif p is not None:
            return "sparse", p, too
        too = f"{too}; {why}"
        if route == "sparse":
            return "too_large", p, too
    s, why = sdsos(data, multiplier_degree, solver_options, force=route == "sdsos")
    if s is None:
        return "too_large", p, f"{too}; SDSOS: {why}"
    return "sdsos", s, too


class FixedLevel:
    """The program of ``data`` with ``pattern`` (module docstring), compiled once with the level
    as a parameter (cvxpy DPP); :meth:`solve` at any level. ``identity``: ``(nv, T, [t_0, t_1,
    ...], [h_e])`` of another identity of this form (``t_1 = -V``: the level is added), in
    place of the level's of ``data`` (a domain containment's)."""

    def __init__(self, data: Any, pattern: Pattern, *, eps: Fraction | None = None,
                 solver_options: dict[str, Any] | None = None,
                 identity: tuple[int, Any, list[Any], list[Any]] | None = None) -> None:  # fmt: skip
        import cvxpy as cp

        t0 = time.perf_counter()
        self.pattern, self.solver_options = pattern, dict(solver_options or {})
        if identity is None:
            self.eps = default_eps(data) if eps is None else Fraction(eps)
            target, times = level_identity(data, Fraction(0), self.eps)  # t_1 = -V; + c below
            identity = (data.nv, target, times, [h for _, h in data.equalities])
        else:
            self.eps = Fraction(eps or 0)
        nv, target, times, equalities = identity
        fl = [{m: float(c) for m, c in p.items()} for p in times]
        zero = tuple([0] * nv)
        prog = Program(nv)
        prog.const({m: -float(c) for m, c in target.items()})
        self.t, self.level = prog.scalar(), cp.Parameter(nonneg=True)
        for k, basis, cone in pattern.blocks:
            prog.gram(basis, fl[k], sign=1.0, margin=self.t, cone=cone,
                      level=self.level if k == 1 else None, level_times={zero: 1.0})  # fmt: skip
        self.mus = [prog.free({m: float(c) for m, c in h.items()}, B)
                    for B, h in zip(pattern.free, equalities, strict=True)]  # fmt: skip
        self.Qs = [Q for _, Q in prog.grams]
        self.cones = tuple(prog.cones) if "sdd" in prog.cones else ()  # as built
        self.problem = prog.problem(self.t, extra=[self.t <= 1])
        self.figures: dict[str, Any] = {
            "rows": len(prog.rows), "gram_sizes": [len(b) for _, b, _ in pattern.blocks],
            "sign_symmetries": pattern.symmetries, "free": sum(len(B) for B in pattern.free),
            "build_seconds": round(time.perf_counter() - t0, 3),
            "estimated_gib": round(pattern.bytes / 2**30, 4)}  # fmt: skip

    def solve(self, level: float) -> Candidate:
        """The program at ``level``: float blocks and the margin ``t`` (None when it failed)."""
        t0 = time.perf_counter()
        self.level.value = float(level)
        res = solve(self.problem, options=self.solver_options)
        p = self.pattern
        ok = (res.usable and any(k == 0 for k, _, _ in p.blocks)
              and all(Q.value is not None for Q in self.Qs))  # fmt: skip
        cert = Certificate(tuple((k, b, np.asarray(Q.value)) for (k, b, _), Q in
                                 zip(p.blocks, self.Qs, strict=True)),
                           tuple((B, np.asarray(mu.value)) for B, mu in
                                 zip(p.free, self.mus, strict=True)), self.cones) if ok else None  # fmt: skip
        t = self.t.value
        sizes = {**self.figures, "solve_seconds": round(time.perf_counter() - t0, 3)}
        return Candidate(cert, self.eps, float(t) if ok and t is not None else None, res.status,
                         time.perf_counter() - t0, sizes)  # fmt: skip


@dataclass
class SosRoute:
    """The program chosen once for exact data (:func:`route_for`): ``kind`` ``"dense"``,
    ``"sparse"``, ``"sdsos"`` or ``"too_large"``, its pattern and why the dense one was not
    taken. :meth:`propose` solves it at a level (compiled once per ``eps``)."""

    data: Any
    kind: str
    plan: Pattern | None
    why: str
    solver_options: dict[str, Any] | None = None
    compiled: dict[Fraction, FixedLevel] = field(default_factory=dict)

    def propose(self, level: float, eps: Fraction | None = None) -> Candidate:
        """A candidate certificate of ``level`` (only :func:`roa.proof._putinar.check_level`
        decides)."""
        eps = default_eps(self.data) if eps is None else Fraction(eps)
        if self.plan is None or self.kind == "too_large":
            return Candidate(None, eps, None, f"too large: {self.why}", 0.0)
        if self.kind == "dense" and self.plan.bytes > MAX_SDP_BYTES:
            return Candidate(None, eps, None, f"too large: a Gram block of {self.plan.largest} "
                             f"monomials needs an estimated {self.plan.bytes / 2**30:.3g} GiB "
                             f"(budget {MAX_SDP_BYTES / 2**30:.3g} GiB); not built", 0.0)  # fmt: skip
        build = 0.0
        if eps not in self.compiled:
            self.compiled[eps] = FixedLevel(self.data, self.plan, eps=eps,
                                            solver_options=self.solver_options)  # fmt: skip
            build = self.compiled[eps].figures["build_seconds"]
        cand = self.compiled[eps].solve(level)
        return replace(cand, seconds=cand.seconds + build)


def route_for(data: Any, multiplier_degree: int | None = None, route: str = "auto",
              solver_options: dict[str, Any] | None = None) -> SosRoute:  # fmt: skip
    """The route of ``data`` (:func:`choose_route`), chosen once. For a V of degree above 2 and
    no ``multiplier_degree`` given, the multiplier gets V's degree when that program fits (the
    least degree balancing ``lambda V`` against ``V'`` leaves ``lambda`` quadratic, too weak for
    a quartic V's sublevel sets: ``tests/proof/test_sos_combinations.py``), else the least."""
    deg_v = max(sum(m) for m in data.V)
    if multiplier_degree is None and deg_v > 2:
        kind, p, why = choose_route(data, deg_v, route, solver_options)
        if kind == "dense" if route == "auto" else kind != "too_large":
            return SosRoute(data, kind, p, why, solver_options)
    kind, p, why = choose_route(data, multiplier_degree, route, solver_options)
    return SosRoute(data, kind, p if kind != "too_large" else None, why, solver_options)


def propose(data: Any, level: float, *, eps: Fraction | None = None, route: str = "dense",
            multiplier_degree: int | None = None,
            solver_options: dict[str, Any] | None = None) -> Candidate:  # fmt: skip
    """A candidate certificate of ``level`` for ``data`` with the pattern of ``route``
    (:func:`route_for`)."""
    return route_for(data, multiplier_degree, route, solver_options).propose(level, eps)


def default_domain_eps(margin: QPoly, n: int) -> Fraction:
    """``1e-6`` x ``g(x_eq)`` (the margin at the equilibrium), as a dyadic."""
    g0 = float(margin.get(tuple([0] * n), Fraction(0)))
    return Fraction(2.0 ** round(np.log2(1e-6 * g0))) if g0 > 0 else Fraction(1, 2**40)


def propose_domain_certificate(
    margin: QPoly, Vq: QPoly, n: int, level: float, *, solver_options: dict[str, Any] | None = None
) -> Candidate:
    """The domain containment program (module docstring) for ``{V <= level}``: ``g - eps -
    lambda (c - V) = m0' Q0 m0``, ``lambda = m1' Q1 m1`` (``eps``: :func:`default_domain_eps`)."""
    t0 = time.perf_counter()
    eps = default_domain_eps(margin, n)
    deg_g, deg_V = max((sum(m) for m in margin), default=0), max(sum(m) for m in Vq)
    L = max(0, (deg_g - deg_V + 1) // 2)
    D = (max(deg_g, 2 * L + deg_V) + 1) // 2
    basis0, basis1 = monomials(n, D, 0), monomials(n, L, 0)
    if sdp_bytes(len(basis0)) > MAX_SDP_BYTES:
        return Candidate(None, eps, None, f"too large: a Gram block of {len(basis0)} monomials; "
                         "not built", time.perf_counter() - t0,
                         {"gram_sizes": [len(basis0), len(basis1)]})  # fmt: skip
    times = [{tuple([0] * n): Fraction(1)}, {m: -c for m, c in Vq.items()}]
    pattern = Pattern("dense", ((0, basis0, "psd"), (1, basis1, "psd")))
    prog = FixedLevel(None, pattern, eps=eps, solver_options=solver_options,
                      identity=(n, domain_target(margin, eps, n), times, []))  # fmt: skip
    return replace(prog.solve(level), seconds=time.perf_counter() - t0)
