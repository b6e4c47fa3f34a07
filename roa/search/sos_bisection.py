"""Largest level with a numerical SOS certificate, block by block, by bisection on the level.

For exact data that split over independent blocks of variables (:mod:`roa.proof.sos_blocks`), the
largest level of the whole is the least of the blocks' largest levels (each block's ``V_j' < 0``
on ``{V_j <= c}`` for every block gives the whole; a block's witness with the other blocks at 0
is a witness of the whole). Each block's level is found by bisection on ``c`` with the fixed-level
program of :func:`roa.search.sos_certificate.propose_certificate`: ``c`` counts as feasible when
the solver reports an optimal solution with a positive margin ``t`` (both Gram matrices
``>= t I``). This proposes a level only: the exact check (:class:`roa.SosValidator`) decides it.

The bracket starts at ``c = 1`` and doubles (or halves) until feasibility changes; a block that is
still feasible at ``2^MAX_DOUBLINGS`` imposes no limit (``inf``). A block without a limit may also
turn numerically infeasible at a huge level (the solver's scaling: ~4e9 for ``x' = -x``), which
only gives it a large finite level. Blocks with identical data
(copies of one subsystem) are solved once.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

from roa.proof.reductions import IndependentBlocks
from roa.proof.sos_blocks import Block
from roa.proof.sos_check import ExactData
from roa.search.sos_certificate import default_eps, propose_certificate

#: Doublings (and halvings) of the bracket from c = 1 before a block counts as unlimited.
MAX_DOUBLINGS = 40


@dataclass(frozen=True)
class BlockLevels:
    """The least block level (``level``; None when no block limits it or a program failed) and,
    per block, its variables and level; ``programs``: the SDPs solved."""

    level: float | None
    per_block: list[tuple[Block, float | None]]
    programs: int
    seconds: float
    message: str = ""
    sizes: dict[str, Any] = field(default_factory=dict)


def _feasible(data: ExactData, c: float, solver_options: dict[str, Any] | None) -> bool:
    return propose_certificate(
        data, c, eps=default_eps(data), solver_options=solver_options
    ).feasible


#: Relative tolerance of the bisection with the sparse program (each step a re-solve).
SPARSE_REL_TOL = 1e-5


def bisect_level(data: ExactData, *, rel_tol: float = 1e-7,
                 solver_options: dict[str, Any] | None = None) -> tuple[float | None, int]:  # fmt: skip
    """Largest numerically feasible level of one block (``inf``: unlimited; None: not even at
    ``2^-MAX_DOUBLINGS``), and the number of programs solved. A block whose dense program does
    not fit the memory budget is bisected with the clique or the SDSOS program
    (:func:`roa.search.sos_sparse.choose_route`; compiled once, ``rel_tol`` at least
    :data:`SPARSE_REL_TOL`, and each step at the zero of the margins' secant when both ends'
    margins are known, a halving after two moves of one end)."""
    from roa.search.sos_sparse import SparseProgram, choose_route

    count = 0
    route, plan, _ = choose_route(data, solver_options=solver_options)
    program = None
    if route in ("sparse", "sdsos") and plan is not None:
        program = SparseProgram(data, plan, eps=default_eps(data), solver_options=solver_options)
        rel_tol = max(rel_tol, SPARSE_REL_TOL)
    margins: dict[float, float] = {}

    def ok(c: float) -> bool:
        nonlocal count
        count += 1
        if program is not None:
            cand = program.solve(c)
            if cand.margin is not None:
                margins[c] = cand.margin
            return cand.feasible
        return _feasible(data, c, solver_options)

    lo, hi = 1.0, 1.0
    if ok(1.0):
        for _ in range(MAX_DOUBLINGS):
            hi *= 2.0
            if not ok(hi):
                break
            lo = hi
        else:
            return math.inf, count
    else:
        for _ in range(MAX_DOUBLINGS):
            lo /= 2.0
            if ok(lo):
                break
            hi = lo
        else:
            return None, count
    side = ""
    while hi - lo > rel_tol * lo:  # invariant: lo feasible, hi not
        mid = 0.5 * (lo + hi)
        m_lo, m_hi = margins.get(lo), margins.get(hi)
        if m_lo is not None and m_hi is not None and m_lo > 0 > m_hi and side != "same":
            # the margin is close to linear in the level: its secant's zero, inside the bracket
            mid = min(max(lo - m_lo * (hi - lo) / (m_hi - m_lo), lo + 0.01 * (hi - lo)),
                      hi - 0.01 * (hi - lo))  # fmt: skip
        good = ok(mid)
        moved = "lo" if good else "hi"
        side = "same" if side == moved else moved  # after two moves of one end: a halving
        if good:
            lo = mid
        else:
            hi = mid
    return lo, count


def block_levels(data: ExactData, *, rel_tol: float = 1e-7,
                 solver_options: dict[str, Any] | None = None) -> BlockLevels:  # fmt: skip
    """The least of the blocks' largest numerically feasible levels (module docstring)."""
    t0 = time.perf_counter()
    subs, parts = IndependentBlocks().apply(data)
    seen: dict[tuple, float | None] = {}
    per: list[tuple[Block, float | None]] = []
    programs = 0
    for block, sub in zip(parts, subs, strict=True):
        key = (sub.n, tuple(sorted(sub.V.items())), tuple(sorted(sub.Vdot.items())))
        if key not in seen:
            seen[key], k = bisect_level(sub, rel_tol=rel_tol, solver_options=solver_options)
            programs += k
        per.append((block, seen[key]))
    levels = [lv for _, lv in per]
    sizes = {"blocks": [len(b) for b in parts], "distinct_blocks": len(seen)}
    if any(lv is None for lv in levels):
        bad = [list(b) for b, lv in per if lv is None]
        return BlockLevels(None, per, programs, time.perf_counter() - t0,
                           f"no feasible level for block(s) {bad}", sizes)  # fmt: skip
    least = min(levels)  # type: ignore[type-var]
    if least is None or math.isinf(least):
        return BlockLevels(None, per, programs, time.perf_counter() - t0,
                           "no block limits the level (feasible up to 2^40 in each)", sizes)  # fmt: skip
    return BlockLevels(float(least), per, programs, time.perf_counter() - t0, "", sizes)
