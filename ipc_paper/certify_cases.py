"""The cases of the certify experiment (ipc_paper/certify_runs.py), one function each.

Each case is a module-level function of plain data (params, matrices, a cached search result or
``None``) returning JSON-ready blocks, so :func:`run_cases` can run independent cases in parallel
worker processes (joblib/loky): a case computes the same numbers in any process and in any order
(:func:`_fresh` resets the process-wide jet mode that a nonsmooth field switches on, which only
changes the boxes' count and speed, never a verdict).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.progress import step


def _box_fraction(form, level: float, box, n: int, seed: int) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    b = np.asarray(box, dtype=float)
    X = b[:, 0] + (b[:, 1] - b[:, 0]) * rng.random((n, b.shape[0]))
    p = float(np.mean(form(X) <= level))
    half = 1.96 * np.sqrt(max(p * (1 - p), 1.0 / n) / n)
    return {
        "fraction": p,
        "ci95": [max(0.0, p - half), min(1.0, p + half)],
        "samples": n,
        "seed": seed,
    }


def _sector_curve(t: np.ndarray) -> np.ndarray:
    """Physical states (q, q', theta, theta') = (0, 0, t, 0): the paper's sector."""
    z = np.zeros_like(t)
    return np.stack([z, z, t, z], axis=-1)


def _ball_surface(u: np.ndarray) -> np.ndarray:
    """Unit-cube samples -> points of the paper's sphere ||T xi||^2 = 4.89 (flat coordinates)."""
    from scipy.special import ndtri

    from ipc_paper.system.lyapunov import PAPER_C_STAR_SQ, T

    g = ndtri(np.clip(u, 1e-12, 1 - 1e-12))  # Gaussian: uniform directions
    g /= np.linalg.norm(g, axis=-1, keepdims=True)
    return np.sqrt(PAPER_C_STAR_SQ) * g @ np.linalg.inv(T).T


def _physical(
    P: np.ndarray, level: float, box, n_box: int, seed: int, coords: str = "flat"
) -> dict[str, Any]:
    """Sector at q = q' = theta' = 0 and reference-box fraction of ``{V(coords(x)) <= level}``.

    ``sector_rad`` / ``sector_deg``: a certified lower bound (interval arithmetic on the exact
    coordinate map, :func:`roa.proof.certified_sector`; degrees rounded down);
    ``sector_float_rad`` / ``sector_float_deg``: the float grid + bisection estimate.
    """
    from ipc_paper.certified import coords_map
    from ipc_paper.system.coordinates import to_flat_components
    from roa.proof import certified_sector, degrees_lower, quadratic_form
    from roa.search import sector

    c2y = coords_map(coords)

    def form(X: np.ndarray) -> np.ndarray:
        Y = c2y(X)
        with np.errstate(invalid="ignore"):
            return np.nan_to_num(np.einsum("ki,ij,kj->k", Y, P, Y), nan=np.inf)

    def coords_xp(x, xp):  # the same maps as coords_map, on components in any namespace
        z1, z2, w1, w2 = to_flat_components(x[0], x[1], x[2], x[3], xp)
        return (z1 if coords == "flat" else x[0], z2, w1, w2)

    def curve_xp(s, xp):  # _sector_curve on components: (0, 0, s, 0)
        return (0.0, 0.0, s, 0.0)

    t_max = np.pi / 2 - 1e-6
    th_float = sector(form, level, _sector_curve, t_max)
    th = certified_sector(quadratic_form(P, coords_xp), level, curve_xp, t_max)
    return {
        "sector_rad": th,
        "sector_deg": degrees_lower(th),
        "sector_method": "interval (certified lower bound)",
        "sector_float_rad": th_float,
        "sector_float_deg": float(np.degrees(th_float)),
        "box": _box_fraction(form, level, box, n_box, seed),
    }


def _level(res: Any) -> float:
    """The level of a level search, or a clear error (the study needs one)."""
    if res.level is None:
        raise RuntimeError(f"level search ended {res.status.value}: {res.message}")
    return float(res.level)


def _certify_pair(system, V, opt: float, params: dict) -> dict[str, Any]:
    """Certify ``below`` x the sampled optimum and refute ``above`` x it (roa.certify)."""
    from roa.certification import certify
    from roa.options import IntervalOptions

    opts = IntervalOptions(max_boxes=int(params["max_boxes"]), sampled_safety=params["below"])
    cert = certify(
        system, V, candidate=opt, interval=opts, check_above=params["above"], validator="interval"
    )
    assert cert.validation is not None and cert.above is not None
    return {
        "sampled_optimum": opt,
        "below": cert.validation.to_json(),
        "above": cert.above.to_json(),
    }


def _slice_coverage(sat: float, P: np.ndarray, level: float, p: dict[str, Any]) -> dict[str, Any]:
    """Monte Carlo map of the saturated physical loop on the slice ``sat_slice`` (q' = theta' = 0)
    and on the line q = q' = theta' = 0: which converged points the set ``{V(xi(x)) <= level}``
    holds (every point inside must converge: a check of the certificate, not a proof)."""
    import roa
    from ipc_paper.certified import coords_map
    from ipc_paper.system import closed_loop
    from roa.integration import CONVERGED
    from roa.montecarlo import grid_slice
    from roa.options import IntegratorOptions, RunOptions
    from roa.status import StopRules

    system = closed_loop(saturation=sat)
    rules = StopRules(t_final=60.0, diverge_bound=1e9)  # as the saturated basin map
    kw: dict[str, Any] = {
        "rules": rules,
        "integrator": IntegratorOptions(),
        "run": RunOptions(progress=False),
    }
    to_flat = coords_map("flat")

    def inside(X: np.ndarray) -> np.ndarray:
        Y = to_flat(X)
        with np.errstate(invalid="ignore"):
            return np.nan_to_num(np.einsum("ki,ij,kj->k", Y, P, Y), nan=np.inf) <= level

    (q_lo, q_hi), (t_lo, t_hi) = p["sat_slice"]
    nq, nt = p["sat_grid"]
    g = grid_slice(system, ["q", "theta"], [(q_lo, q_hi), (t_lo, t_hi)], (nq, nt),
                   fixed={"q_dot": 0.0, "theta_dot": 0.0})  # fmt: skip
    conv = roa.basin(system, g, **kw).code == CONVERGED
    ins = inside(g.points(0, g.n))
    eps = 1e-6  # the line q = q' = theta' = 0: where the empirical basin ends
    line = grid_slice(system, ["theta", "q"], [(-np.pi / 2 + eps, np.pi / 2 - eps), (-1e-12, 1e-12)],
                      (2001, 2))  # fmt: skip
    lconv = (roa.basin(system, line, **kw).code.reshape(line.shape) == CONVERGED).all(axis=0)
    th, zero = line.xs, len(line.xs) // 2
    k = zero
    while k + 1 < len(th) and lconv[k + 1] and lconv[2 * zero - k - 1]:
        k += 1
    return {
        "grid": [nq, nt],
        "ranges": [[q_lo, q_hi], [t_lo, t_hi]],
        "points": int(g.n),
        "converged": int(conv.sum()),
        "in_set": int(ins.sum()),
        "in_set_converged": int((ins & conv).sum()),
        "coverage": float((ins & conv).sum() / max(int(conv.sum()), 1)),
        "line_converged_deg": float(np.degrees(th[k])),
        "settings": f"batch DP5(4), rtol {IntegratorOptions().rtol:g}, t_final 60",
    }


def _fresh(progress: bool) -> None:
    """Every case starts with progress lines on or off."""
    from roa import progress as prog

    prog.enable(progress)


def case_vanderpol(p: dict[str, Any], progress: bool) -> dict[str, Any]:
    """C1: the Van der Pol benchmark (SOS level, sampled optimum, interval pair)."""
    from roa.lyapunov import QuadraticLyapunov
    from roa.search import level_search, sos_level
    from roa.systems.vanderpol import P_BENCHMARK, RHO_BENCHMARK, vanderpol

    _fresh(progress)
    with step("certify: Van der Pol benchmark (SOS, interval)"):
        vdp = vanderpol()
        Vv = QuadraticLyapunov.for_system(vdp, P_BENCHMARK, "benchmark")
        opt_v = _level(level_search(vdp, Vv, shape="level", method="both"))
        return {
            "sos": sos_level(vdp, Vv).to_json(),
            **_certify_pair(vdp, Vv, opt_v, p),
            "published": RHO_BENCHMARK,
        }


def case_paper(p: dict[str, Any], progress: bool) -> dict[str, Any]:
    """C2-C4, C7: the paper's V (SOS programs, interval pair, sector and box share)."""
    from ipc_paper.system import REFERENCE_BOX, transformed
    from ipc_paper.system.lyapunov import paper_lyapunov
    from roa.search import level_search, sos_level

    _fresh(progress)
    aux = p["sos_aux_degree"]
    aux = None if aux is None or int(aux) < 0 else int(aux)
    ipc, Vp = transformed(), paper_lyapunov()
    with step("certify: IPC, the paper's V (SOS programs, interval validation)"):
        opt_p = _level(level_search(ipc, Vp, shape="level", method="both"))
        sos_p = {"enclosure": sos_level(ipc, Vp, recast_mode="enclosure").to_json()}
        if p["sos_exact"]:
            opts = {"time_limit": p["sos_time_limit"]}
            sos_p["exact"] = sos_level(
                ipc, Vp, recast_mode="exact", solver_options=opts, aux_degree=aux
            ).to_json()
            sos_p["exact_no_symmetry"] = sos_level(
                ipc, Vp, recast_mode="exact", solver_options=opts, symmetry=False
            ).to_json()
        ipc_p = {"sos": sos_p, **_certify_pair(ipc, Vp, opt_p, p)}
        ipc_p["physical"] = _physical(
            Vp.P, ipc_p["below"]["level"], REFERENCE_BOX, p["n_box"], p["seed"]
        )
    return ipc_p


def _system(name: str) -> Any:
    from ipc_paper.system import transformed
    from ipc_paper.system.hybrid import hybrid

    return {"flat": transformed, "hybrid": hybrid}[name]()


def case_optimised(
    key: str,
    coords: str,
    objective: str,
    P0: np.ndarray,
    ball: bool,
    search: dict[str, Any],
    cached: dict[str, Any] | None,
    p: dict[str, Any],
    progress: bool,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """C5, C6, C8-C10: a quadratic V searched (or taken from ``cached``) for ``objective`` in
    ``coords``, then certified afresh; ``ball`` measures the paper's sphere instead of the box.
    Returns ``(search result, block)``."""
    from ipc_paper.certified import coords_map
    from ipc_paper.system import REFERENCE_BOX
    from roa.lyapunov import QuadraticLyapunov
    from roa.search import level_search, optimise_quadratic

    _fresh(progress)
    system = _system(coords)
    box = ((0.0, 1.0),) * 4 if ball else REFERENCE_BOX  # ball: fraction of the paper's sphere
    with step(f"certify: {key} (search or cache, then interval validation)"):
        res = cached
        if res is None:
            res = optimise_quadratic(
                system,
                P0,
                _ball_surface if ball else coords_map(coords),
                objective=objective,
                box=box,
                curve=_sector_curve,
                t_max=np.pi / 2 - 1e-3,
                **search,
            ).to_json()
        Vo = QuadraticLyapunov(np.asarray(res["P"]), np.zeros(4), f"optimised ({key})")
        opt_o = _level(level_search(system, Vo, shape="level", method="both"))
        blk = {
            "search": {**res, "cached": cached is not None},
            **_certify_pair(system, Vo, opt_o, p),
        }
        blk["physical"] = _physical(
            Vo.P, blk["below"]["level"], REFERENCE_BOX, p["n_box"], p["seed"], coords
        )
    blk["coords"] = coords
    return res, blk


def saturated_key(p: dict[str, Any], P0: np.ndarray, search: dict[str, Any]) -> dict[str, Any]:
    """The search-cache key of the saturated case."""
    from ipc_paper.system import transformed

    return {"case": "ipc_saturated", "system": transformed(saturation=float(p["sat_limit"])).name,
            "saturation": float(p["sat_limit"]), "objective": "box", "box": _slice_box(p),
            "P0": P0, **search}  # fmt: skip


def _slice_box(p: dict[str, Any]) -> tuple[tuple[float, float], ...]:
    (q_lo, q_hi), (t_lo, t_hi) = p["sat_slice"]
    return ((q_lo, q_hi), (0.0, 0.0), (t_lo, t_hi), (0.0, 0.0))  # (q, theta), q' = theta' = 0


def case_saturated(
    p: dict[str, Any],
    P0: np.ndarray,
    search: dict[str, Any],
    cached: dict[str, Any] | None,
    progress: bool,
) -> tuple[dict[str, Any] | None, dict[str, Any], np.ndarray]:
    """C11, the saturated loop |u| <= sat_limit: a quadratic V in flat coordinates searched for
    the largest share of the saturated map's (q, theta) slice, its level certified (and refuted
    just above) for the saturated field, its sector and its share of the slice's basin.

    The system is :func:`ipc_paper.system.transformed` with ``saturation``: the physical saturated
    loop in the coordinates (2.2), so ``{V <= c}`` in flat coordinates is ``{V(xi(x)) <= c}`` of
    physical states, and ``V' = grad V . f`` is the same number in both. The field carries
    ``xp.clip``: the interval validation encloses it and its generalised derivative
    (:mod:`roa.proof._jet`), so the control may saturate inside the certified set. Returns
    ``(search result to cache or None, block, P of V)``; without ``sat_search`` (quick mode) the seed
    ``P0`` itself is certified.
    """
    from ipc_paper.certified import coords_map
    from ipc_paper.system import REFERENCE_BOX, transformed
    from roa.lyapunov import QuadraticLyapunov
    from roa.search import level_search, optimise_quadratic

    _fresh(progress)
    sat = float(p["sat_limit"])
    system = transformed(saturation=sat)
    with step(f"certify: saturated loop |u| <= {sat:g} (search or cache, interval validation)"):
        if not p["sat_search"]:
            res: dict[str, Any] = {
                "P": np.asarray(P0, dtype=float).tolist(),
                "note": "not searched",
            }
            store = None
        elif cached is not None:
            res, store = cached, None
        else:
            res = optimise_quadratic(system, P0, coords_map("flat"), objective="box",
                                     box=_slice_box(p), curve=_sector_curve,
                                     t_max=np.pi / 2 - 1e-3, **search).to_json()  # fmt: skip
            store = res
        V = QuadraticLyapunov(np.asarray(res["P"]), np.zeros(4), "optimised (ipc_saturated)")
        opt = _level(level_search(system, V, shape="level", method="both"))
        blk = {"saturation": sat, "system": system.name,
               "search": {**res, "cached": cached is not None and bool(p["sat_search"])},
               **_certify_pair(system, V, opt, p)}  # fmt: skip
        blk["physical"] = _physical(
            V.P, blk["below"]["level"], REFERENCE_BOX, p["n_box"], p["seed"], "flat"
        )
    with step("certify: saturated loop, basin of its map's slice (coverage of the certified set)"):
        blk["slice"] = _slice_coverage(sat, V.P, blk["below"]["level"], p)
    blk["coords"] = "flat"
    return store, blk, V.P


def run_cases(tasks: list[tuple[Any, ...]], n_jobs: int) -> list[Any]:
    """``[f(*args) for f, *args in tasks]``, in parallel worker processes when ``n_jobs > 1``
    (results in the order of ``tasks``; put the longest first)."""
    if n_jobs <= 1 or len(tasks) <= 1:
        return [f(*args) for f, *args in tasks]
    import os

    from joblib import Parallel, delayed, parallel_config

    # the workers' BLAS gets this process's default thread count (loky would give each worker
    # cpu_count // n_jobs): results of floating-point solvers (Clarabel's status at the edge of
    # its tolerance) then do not depend on n_jobs
    with parallel_config(backend="loky", inner_max_num_threads=os.cpu_count() or 1):
        par = Parallel(n_jobs=min(n_jobs, len(tasks)))
        return list(par(delayed(f)(*a) for f, *a in tasks))
