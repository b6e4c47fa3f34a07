"""CasADi/IPOPT method of Khalil's level-set search (see :mod:`roa.levelset`).

:func:`casadi_level` minimises the shape ``s(x)`` subject to ``V'(x) / s(x) >= 0`` from violating
starting points; the problem set-up and the witness refinement are shared with the sampled method
(:mod:`roa.levelset_core`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.backend import namespace
from roa.levelset_core import LevelSetResult, finish, start, unit
from roa.lyapunov import Lyapunov
from roa.options import CasadiOptions
from roa.system import System


def casadi_level(
    system: System,
    V: Lyapunov,
    S: Any,
    *,
    shape: str = "custom",
    n_starts: int = 16,
    r_start: tuple[float, float] = (0.1, 30.0),
    n_candidates: int = 8000,
    seed: int = 1,
) -> LevelSetResult:
    """Largest shape level with V' < 0 by IPOPT: min s(x) s.t. V'(x)/s(x) >= 0.

    ``S=None`` (a non-quadratic ``V``, shape "level"): the shape is ``V`` itself, i.e.
    min V(x) s.t. V'(x)/V(x) >= 0.

    The infimum of ``s`` over ``{V' >= 0, x != x0}`` is c* (V' < 0 near ``x0``). IPOPT is started
    from violating points (V' > 0), drawn by rejection from random directions at shape radii
    log-uniform in ``r_start``, so that it approaches the boundary from outside and is not pulled to
    the equilibrium. With a domain (``system.margin``), the same is done for ``margin(x) <= 0``.

    Parameters
    ----------
    n_starts : int
        Number of IPOPT starts (>= 1) per problem.
    r_start : (float, float)
        Range of shape radii (sqrt(s)) of the candidate starting points.
    n_candidates : int
        Random points drawn to find violating starting points.
    """
    import casadi as ca

    CasadiOptions(
        n_starts=int(n_starts), r_start=r_start, n_candidates=int(n_candidates), seed=int(seed)
    )  # validates the options; fmt: skip
    prob, early = start(system, V, S, shape, "casadi")
    if early is not None:
        return early
    n = system.n
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
    radii = np.exp(rng.uniform(np.log(r_start[0]), np.log(r_start[1]), int(n_candidates)))
    cand_x = prob.points(U, radii)
    with np.errstate(all="ignore"):
        problems = [("vdot_zero", vd / s, prob.vdot(cand_x) > 0)]
        if system.margin is not None:
            mg = system.margin(comps, namespace("casadi"))
            problems.append(("domain_boundary", -mg, ~system.inside(cand_x)))
    best: LevelSetResult | None = None
    n_ok = n_run = 0
    for _kind, g, violating in problems:
        starts = cand_x[violating][: int(n_starts)]
        if len(starts) == 0:
            continue
        solver = ca.nlpsol("khalil", "ipopt", {"x": x, "f": s, "g": g}, opts)
        for x0 in starts:
            n_run += 1
            sol = solver(x0=x0, lbg=0.0, ubg=np.inf)
            if not solver.stats()["success"]:
                continue
            n_ok += 1
            cand = finish(
                prob,
                np.array(sol["x"]).ravel(),
                "casadi",
                {"n_starts": int(n_starts), "seed": seed},
            )
            if cand.status == "found" and (best is None or cand.value < best.value):
                best = cand
    info = {"n_starts": int(n_starts), "n_run": n_run, "n_converged": n_ok, "seed": seed}
    if n_run == 0:
        return LevelSetResult(
            float(r_start[1] ** 2),
            "unbounded",
            "casadi",
            shape,
            None,
            None,
            details={**info, "note": "no violating point found within r_start"},
        )
    if best is None:
        return LevelSetResult(np.inf, "failed", "casadi", shape, None, None, details=info)
    best.details.update(info)
    return best
