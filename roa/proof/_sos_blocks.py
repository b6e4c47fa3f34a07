"""Independent blocks of variables in the exact SOS check (correlative sparsity, decoupled case).

**Claim.** Let the exact data of :mod:`roa.proof._sos_check` split over disjoint sets of variables
``I_1, ..., I_m`` (in ``d = x - x_eq``): every monomial of ``V`` and of ``V'`` has its variables in
one ``I_j``, and neither has a constant term. Then ``V = sum_j V_j(d_j)`` and
``V' = sum_j W_j(d_j)``. If ``V >= mu |d|^2`` (the caller's Gram cover), each ``V_j >= mu |d_j|^2``
(the other blocks set to 0). If, for every ``j``, ``W_j < 0`` on ``{V_j <= c}`` minus ``d_j = 0``
(the block's own SOS certificate, checked exactly), then ``V' < 0`` on ``{V <= c}`` minus
``d = 0``: on ``{V <= c}`` each ``V_j(d_j) <= V(d) <= c`` since the others are ``>= 0``, each
``W_j(d_j) < 0`` where ``d_j != 0`` and ``W_j(0) = 0``, and ``d != 0`` has a block with
``d_j != 0``. ``W_j`` need not be ``V_j``'s own derivative: the argument uses only the split.

The blocks are the connected components of the graph on the variables that joins two variables
when they occur in one monomial of ``V`` or ``V'`` (:func:`scipy.sparse.csgraph.connected_components`).
Coupled systems have one block, and nothing changes; decoupled copies of a system have one per copy,
so their Gram matrices are as small as one copy's. A connected but sparse graph is handled by
the chordal cliques of :func:`roa.search._sos_program.clique_pattern` (checked by :mod:`roa.proof._putinar`), for the
whole or for a block.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from roa.proof._sos_check import ExactData, QPoly

Block = tuple[int, ...]


def blocks(data: ExactData) -> list[Block]:
    """The variable blocks of ``data`` (sorted, covering ``range(n)``); one block when coupled or
    when ``V`` or ``V'`` has a constant term."""
    n = data.n
    zero = tuple([0] * n)
    if data.V.get(zero, 0) or data.Vdot.get(zero, 0):
        return [tuple(range(n))]
    rows: list[int] = []
    cols: list[int] = []
    for poly in (data.V, data.Vdot):
        for m, c in poly.items():
            if not c:
                continue
            support = [i for i, k in enumerate(m) if k]
            rows += support[:-1]
            cols += support[1:]  # a path through the monomial's variables joins them all
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    count, label = connected_components(graph, directed=False)
    return [tuple(int(i) for i in np.flatnonzero(label == b)) for b in range(count)]


def restrict(data: ExactData, block: Block) -> ExactData:
    """The data of one block: ``V_j`` and ``W_j`` in the block's variables (in its order).

    Raises ``ValueError`` if a monomial of ``V`` or ``V'`` touches the block and another variable
    (``block`` is then not a union of blocks)."""
    inside = set(block)

    def part(poly: QPoly) -> QPoly:
        out: QPoly = {}
        for m, c in poly.items():
            support = {i for i, k in enumerate(m) if k}
            if not c or not support & inside:
                continue
            if not support <= inside:
                raise ValueError(f"monomial {m} couples block {list(block)} to other variables")
            out[tuple(m[i] for i in block)] = c
        return out

    V, W = part(data.V), part(data.Vdot)
    low = min((sum(m) for m in W), default=0)
    center = tuple(data.center[i] for i in block)
    return replace(data, n=len(block), center=center, V=V, Vdot=W, low=low)


def check_partition(parts: Any, n: int) -> list[Block]:
    """Stored blocks as a partition of ``range(n)`` (``ValueError`` unless disjoint and covering)."""
    if not isinstance(parts, list) or not parts:
        raise ValueError("blocks must be a non-empty list of variable lists")
    out: list[Block] = []
    for p in parts:
        if not (isinstance(p, list) and p and all(type(i) is int and 0 <= i < n for i in p)):
            raise ValueError(f"every block must be a non-empty list of variable indices < {n}")
        out.append(tuple(p))
    flat = sorted(i for p in out for i in p)
    if flat != list(range(n)):
        raise ValueError("blocks must cover every variable exactly once")
    return out
