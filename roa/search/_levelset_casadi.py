"""CasADi/IPOPT method of Khalil's level-set search (see :mod:`roa.search._levelset`).

:func:`casadi_level` minimises the shape ``s(x)`` subject to ``V'(x) / s(x)^(p/2) >= 0`` from the
first violations along random rays; the problem set-up and the witness refinement are shared with the sampled method
(:mod:`roa.search._levelset_core`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.lyapunov import Lyapunov
from roa.model._backend import namespace
from roa.model._system import System
from roa.options import CasadiOptions
from roa.search._levelset_core import LevelSetResult, crossings, finish, start, unit, vdot_order


def casadi_level(
    system: System,
    V: Lyapunov,
    S: Any,
    *,
    shape: str = "custom",
    n_starts: int = 16,
    r_start: tuple[float, float] = (0.1, 100.0),
    n_candidates: int = 8000,
    seed: int = 1,
) -> LevelSetResult:
    """Largest shape level with V' < 0 by IPOPT: min s(x) s.t. V'(x) / s(x)^(p/2) >= 0.

    ``S=None`` (a non-quadratic ``V``, shape "level"): the shape is ``V`` itself.

    The infimum of ``s`` over ``{V' >= 0, x != x0}`` is c* (V' < 0 near ``x0``). ``p`` is the
    degree at which V' starts at ``x0`` (:func:`roa.search._levelset_core.vdot_order`: 2 for a definite
    linearisation, 4 when it is degenerate), so that the constraint stays negative, away from 0,
    next to ``x0`` and IPOPT cannot satisfy it there to its tolerance.

    Starts: ``n_candidates`` random directions are scanned as rays on a geometric grid of shape
    radii over ``r_start`` (:func:`roa.search._levelset_core.crossings`); IPOPT starts at the first
    violation of the ``n_starts`` rays that violate earliest (well separated directions), i.e.
    next to the boundary, from outside. With a domain (``system.margin``), the first exit from it
    is a violation too. ``details`` reports the rays, how many violate, the shape value searched up
    to, and the runs (``n_run``, ``n_converged``). When no ray violates, IPOPT is not run and the
    status is ``unbounded`` with ``value`` the shape value searched up to: a sampled estimate (the
    rays may miss a thin violating set), never a bound.

    Parameters
    ----------
    n_starts : int
        Number of IPOPT starts (>= 1).
    r_start : (float, float)
        Range of shape radii (sqrt(s)) scanned along the rays.
    n_candidates : int
        Random directions scanned for starting points.
    """
    import casadi as ca

    CasadiOptions(
        n_starts=int(n_starts), r_start=r_start, n_candidates=int(n_candidates), seed=int(seed)
    )  # validates the options; fmt: skip
    prob, early = start(system, V, S, shape, "casadi")
    if early is not None:
        return early
    n = system.n
    order = vdot_order(prob)
    x = ca.SX.sym("x", n)
    comps = [x[i] for i in range(n)]
    _, vd = V.symbolic(system, comps, namespace("casadi"))
    if prob.by_value:
        s = prob.shape_expr(comps, namespace("casadi"))
    else:
        d = x - ca.DM(V.center)
        s = ca.mtimes([d.T, ca.DM(prob.S), d])
    opts: dict[str, Any] = {
        "ipopt.print_level": 0,
        "print_time": 0,
        "ipopt.sb": "yes",
        "ipopt.tol": 1e-10,
        "ipopt.max_iter": 200,
        "error_on_fail": False,
    }
    rng = np.random.default_rng(seed)
    U = unit(rng.standard_normal((int(n_candidates), n)))
    r_grid = np.geomspace(r_start[0], r_start[1], 128)
    r = crossings(prob, U, r_grid)
    hits = np.flatnonzero(np.isfinite(r))
    chosen: list[int] = []
    for i in hits[np.argsort(r[hits])]:
        if all(abs(U[i] @ U[j]) < 0.95 for j in chosen):
            chosen.append(int(i))
        if len(chosen) >= int(n_starts):
            break
    starts = prob.points(U[chosen], r[chosen]) if chosen else np.empty((0, n))
    g = vd / s ** (order // 2)
    if system.margin is not None:  # the first violation of a ray may be the domain's boundary
        g = ca.fmax(g, -system.margin(comps, namespace("casadi")))
    info: dict[str, Any] = {
        "n_starts": int(n_starts),
        "n_rays": int(n_candidates),
        "n_rays_violating": int(len(hits)),
        "searched_up_to": float(r_start[1] ** 2),
        "vdot_order": order,
        "seed": seed,
    }
    best: LevelSetResult | None = None
    n_ok = 0
    if len(starts):
        solver = ca.nlpsol("khalil", "ipopt", {"x": x, "f": s, "g": g}, opts)
        for x0 in starts:
            sol = solver(x0=x0, lbg=0.0, ubg=np.inf)
            if not solver.stats()["success"]:
                continue
            n_ok += 1
            cand = finish(prob, np.array(sol["x"]).ravel(), "casadi", {})
            if cand.status == "found" and (best is None or cand.value < best.value):
                best = cand
    info.update(n_run=len(starts), n_converged=n_ok)
    if 0 < len(starts) < int(n_starts):  # n_run beside n_starts: say why fewer ran
        info["starts_note"] = (
            f"{len(starts)} of the {int(n_starts)} starts ran: "
            + (f"only {len(hits)} of the {int(n_candidates)} rays violate"
               if len(hits) < int(n_starts) else
               f"{len(starts)} of the {len(hits)} violating rays point in well separated "
               "directions (|cos| < 0.95 between two starts)")
        )  # fmt: skip
    if len(starts) == 0:
        info["note"] = (
            f"IPOPT not run: none of {int(n_candidates)} rays violates up to "
            f"s = {r_start[1] ** 2:.4g}"
        )
        return LevelSetResult(
            float(r_start[1] ** 2), "unbounded", "casadi", shape, None, None, details=info
        )
    if best is None:
        return LevelSetResult(np.inf, "failed", "casadi", shape, None, None, details=info)
    best.details.update(info)
    return best
