"""The one SOS level search: the largest level with a numerical SOS certificate.

:func:`level_search` is the entry of every route: for a polynomial field whose V and V' split over
independent blocks of variables, or whose one block's program is patterned (cliques, SDSOS:
:func:`roa.search._sos_program.route_for`, chosen once per block), bisection on the level (below);
otherwise the max-level program of :func:`roa.search._sos.sos_level` (quadratic V, the one recast).
It proposes only: the pipeline validates ``(1 - 1e-4)`` x the level with the exact check and,
when that check fails, backs off on the exact route (:mod:`roa.certification._backoff`, each try
reported) before any branch and bound.

**Bisection, block by block.** For exact data that split over independent blocks of variables
(:mod:`roa.proof._reductions`), the largest level of the whole is the least of the blocks' largest
levels (each block's ``V_j' < 0`` on ``{V_j <= c}`` for every block gives the whole; a block's
witness with the other blocks at 0 is a witness of the whole). Each block's level is found by
bisection on ``c`` with :class:`roa.search._sos_program.FixedLevel`: ``c`` counts as feasible
when the solver gives a solution with a positive margin ``t`` (every Gram block ``>= t I``).

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

from roa.errors import RoaInputError
from roa.proof._reductions import Block, IndependentBlocks
from roa.proof._sos_check import ExactData
from roa.search._sos_program import SosRoute, route_for

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


#: Relative tolerance of the bisection with the sparse program (each step a re-solve).
SPARSE_REL_TOL = 1e-5


def bisect_level(data: ExactData, *, rel_tol: float = 1e-7,
                 solver_options: dict[str, Any] | None = None,
                 route: SosRoute | None = None) -> tuple[float | None, int]:  # fmt: skip
    """Largest numerically feasible level of one block (``inf``: unlimited; None: not even at
    ``2^-MAX_DOUBLINGS``), and the number of programs solved, with the program of ``route``
    (default: :func:`roa.search._sos_program.route_for`). A patterned program (cliques, SDSOS) is
    compiled once, ``rel_tol`` at least :data:`SPARSE_REL_TOL`, and each step at the zero of the
    margins' secant when both ends' margins are known, a halving after two moves of one end."""
    count = 0
    route = route_for(data, solver_options=solver_options) if route is None else route
    patterned = route.kind != "dense"
    if patterned:
        rel_tol = max(rel_tol, SPARSE_REL_TOL)
    margins: dict[float, float] = {}

    def ok(c: float) -> bool:
        nonlocal count
        count += 1
        cand = route.propose(c)
        if patterned and cand.margin is not None:
            margins[c] = cand.margin
        return cand.feasible

    lo = hi = 1.0
    up = ok(1.0)  # double until infeasible, else halve until feasible
    for _ in range(MAX_DOUBLINGS):
        c = 2.0 * hi if up else 0.5 * lo
        lo, hi = (lo, c) if up else (c, hi)
        if ok(c) != up:
            break
        lo = hi = c
    else:
        return (math.inf if up else None), count
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
        lo, hi = (mid, hi) if good else (lo, mid)
    return lo, count


def block_levels(data: ExactData, *, rel_tol: float = 1e-7,
                 solver_options: dict[str, Any] | None = None,
                 routes: list[SosRoute] | None = None,
                 split: tuple[list[Any], list[Any]] | None = None) -> BlockLevels:  # fmt: skip
    """The least of the blocks' largest numerically feasible levels (module docstring); each
    distinct block's route chosen once (``routes``: already chosen, one per block; ``split``:
    the data's independent blocks when already computed)."""
    t0 = time.perf_counter()
    subs, parts = split or IndependentBlocks().apply(data)
    seen: dict[tuple, float | None] = {}
    per: list[tuple[Block, float | None]] = []
    programs = 0
    kinds: list[str] = []
    for j, (block, sub) in enumerate(zip(parts, subs, strict=True)):
        key = (sub.n, tuple(sorted(sub.V.items())), tuple(sorted(sub.Vdot.items())))
        if key not in seen:
            route = routes[j] if routes else route_for(sub, solver_options=solver_options)
            kinds.append(route.kind)
            seen[key], k = bisect_level(sub, rel_tol=rel_tol, route=route)
            programs += k
        per.append((block, seen[key]))
    sizes = {"blocks": [len(b) for b in parts], "distinct_blocks": len(seen), "routes": kinds}
    bad = [list(b) for b, lv in per if lv is None]
    least = math.inf if bad else min(lv for _, lv in per if lv is not None)
    why = (f"no feasible level for block(s) {bad}" if bad else
           "no block limits the level (feasible up to 2^40 in each)" if math.isinf(least) else "")  # fmt: skip
    return BlockLevels(None if why else float(least), per, programs, time.perf_counter() - t0,
                       why, sizes)  # fmt: skip


def level_search(system: Any, V: Any, *, recast_mode: str = "exact",
                 multiplier_degree: int | None = None,
                 solver_options: dict[str, Any] | None = None, symmetry: str | bool = "auto",
                 aux_degree: int | None = None) -> Any:  # fmt: skip
    """The largest SOS level of ``V`` (module docstring) as a :class:`roa.search._sos.SOSResult`."""
    from roa.progress import step
    from roa.proof._sos_check import NotPolynomial, exact_data
    from roa.search._sos import SOSResult, sos_level
    from roa.status import SosStatus

    data = None
    if not getattr(system, "parameters", None):  # exact_data refuses the rest
        try:
            data = exact_data(system, V)
        except NotPolynomial:
            pass
    if data is not None:
        subs, parts = IndependentBlocks().apply(data)
        routes = [route_for(subs[0], solver_options=solver_options)] if len(parts) == 1 else None
        if routes is None or routes[0].kind in ("sparse", "sdsos"):
            what = (f"{len(parts)} independent blocks of variables" if routes is None
                    else "the sparse (chordal clique) program" if routes[0].kind == "sparse"
                    else "the SDSOS program (sign blocks, scaled diagonally dominant)")  # fmt: skip
            with step(f"SOS level by bisection with {what}"):
                bl = block_levels(data, solver_options=solver_options, routes=routes,
                                  split=(subs, parts))  # fmt: skip
            sizes: dict[str, Any] = {**bl.sizes, "programs": bl.programs}
            if routes is not None and routes[0].plan is not None and routes[0].kind != "dense":
                sizes["sparse"] = routes[0].plan.sizes
            if bl.level is None:
                return SOSResult(SosStatus.FAILED, None, "bisection", bl.seconds,
                                 "none (polynomial)", sizes,
                                 f"SOS bisection with {what}: {bl.message}")  # fmt: skip
            how = (f"least of {len(parts)} block levels (bisection)" if routes is None
                   else f"largest level of {what} (bisection)")  # fmt: skip
            return SOSResult(SosStatus.SOLVED, bl.level, "bisection", bl.seconds,
                             "none (polynomial)", sizes, how)  # fmt: skip
    quad = V.quadratic_view()
    if quad is None:
        raise RoaInputError("the max-level SOS program takes a quadratic V")
    with step("SOS program (cvxpy + Clarabel)"):
        return sos_level(system, quad, recast_mode=recast_mode,
                         multiplier_degree=multiplier_degree, solver_options=solver_options,
                         symmetry=symmetry, aux_degree=aux_degree)  # fmt: skip
