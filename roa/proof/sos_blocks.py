"""Independent blocks of variables in the exact SOS check (correlative sparsity, decoupled case).

**Claim.** Let the exact data of :mod:`roa.proof.sos_check` split over disjoint sets of variables
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
the chordal cliques of :mod:`roa.search.sos_sparse` (checked by :mod:`roa.proof.sos_sum`), for the
whole or for a block.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from roa.proof.sos_check import ExactData, QPoly

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


def recheck(system: Any, V: Any, level: float, meta: dict[str, Any]) -> Any:
    """Re-check a stored exact SOS certificate without any solver: one certificate
    (:func:`roa.proof.sos_check.recheck_stored`), a sparse one (``sum``: sums of Gram blocks,
    :func:`roa.proof.sos_sum.recheck_sum`), an SDSOS one (``sdd``: scaled diagonally dominant
    blocks, :func:`roa.proof.sos_sdd.recheck_sdd`) or, when it has ``blocks``, one per block.

    A block certificate is ``{"variables": [...], "eps": "p/q", "basis0", "Q0", "basis1", "Q1"}``
    in the block's variables, or ``{"variables", "eps", "sum"}`` for a sparse one
    (:func:`roa.proof.sos_sum.check_sum`). ``certified`` only if the stored blocks partition the
    variables, no monomial of ``V`` or ``V'`` couples two of them (:func:`restrict`), and every block's identity
    and Gram matrices pass :func:`roa.proof.sos_check.check_certificate` exactly. Every
    pattern first passes the preconditions of :mod:`roa.proof.preconditions` (the domain
    containment by the certificate's stored ``domain`` part, checked exactly as stored, or by
    intervals)."""
    from roa.proof.preconditions import Route, check_preconditions
    from roa.status import Verdict

    cert = meta.get("certificate")
    pre = check_preconditions(system, V, level, Route("sos-exact", parameters=True),
                              stored_domain=cert.get("domain") if isinstance(cert, dict) else None,
                              recheck=True)  # fmt: skip
    if pre.refusal is not None:
        return pre.refusal
    v = _recheck(system, V, level, meta)
    if v.status is Verdict.CERTIFIED and pre.notes.get("domain"):
        return replace(v, message=f"{v.message}; domain: {pre.notes['domain']}")
    return v


def _recheck(system: Any, V: Any, level: float, meta: dict[str, Any]) -> Any:
    """:func:`recheck` once the preconditions hold."""
    import time

    from roa.proof.sos_check import (
        check_certificate,
        parse_basis,
        parse_eps,
        parse_matrix,
        preconditions,
        recheck_stored,
        scale_data,
        stored_scale,
    )
    from roa.proof.validation import Validation
    from roa.status import Verdict

    cert = meta.get("certificate")
    if isinstance(cert, dict) and "sum" in cert:  # a sparse certificate (sums of Gram blocks)
        from roa.proof.sos_sum import recheck_sum

        return recheck_sum(system, V, level, meta)
    if isinstance(cert, dict) and "sdd" in cert:  # scaled diagonally dominant blocks (SDSOS)
        from roa.proof.sos_sdd import recheck_sdd

        return recheck_sdd(system, V, level, meta)
    if not (isinstance(cert, dict) and "blocks" in cert):
        return recheck_stored(system, V, level, meta)
    t0 = time.perf_counter()

    def out(status: Verdict, message: str, **extra: Any) -> Validation:
        m = {"method": "sos-exact", "M": np.eye(int(V.n)).tolist(), **extra}
        return Validation(status, float(level), 0, time.perf_counter() - t0, message=message,
                          meta=m)  # fmt: skip

    data, why = preconditions(system, V, level)
    if data is None:
        return out(Verdict.INCONCLUSIVE, why)
    stored = cert["blocks"] if isinstance(cert["blocks"], list) else None
    try:
        scale = stored_scale(cert, data.n)
        if scale is not None:
            data = scale_data(data, scale)
        parts = check_partition([b.get("variables") if isinstance(b, dict) else None
                                 for b in stored or []], data.n)  # fmt: skip
        for block, raw in zip(parts, stored or [], strict=True):
            sub = restrict(data, block)
            if "sum" in raw:  # a sparse certificate of this block (sums of Gram blocks)
                from roa.proof.sos_sum import check_sum, parse

                eps = parse_eps(raw.get("eps"))
                sigma, lam = parse(raw["sum"], len(block))
                rs = check_sum(sub, level, eps, sigma, lam, rounded=True)
                if not rs.ok:
                    return out(Verdict.INCONCLUSIVE, f"stored SOS certificate of block "
                               f"{list(block)} refused: {rs.reason}")  # fmt: skip
                continue
            b0 = parse_basis(raw.get("basis0"), len(block), "basis0")
            b1 = parse_basis(raw.get("basis1") or [], len(block), "basis1")
            Q0 = parse_matrix(raw.get("Q0"), len(b0), "Q0")
            Q1 = parse_matrix(raw.get("Q1") or [], len(b1), "Q1")
            eps = parse_eps(raw.get("eps"))
            res = check_certificate(sub, level, eps, b0, Q0, b1, Q1, rounded=True)
            if not res.ok:
                return out(Verdict.INCONCLUSIVE, f"stored SOS certificate of block "
                           f"{list(block)} refused: {res.reason}")  # fmt: skip
    except (ValueError, TypeError, ZeroDivisionError, AttributeError) as exc:
        return out(Verdict.INCONCLUSIVE, f"malformed SOS certificate: {exc}")
    return out(Verdict.CERTIFIED, f"stored SOS certificates of {len(parts)} independent blocks "
               "re-checked exactly", blocks=[list(b) for b in parts])  # fmt: skip
