"""Experiment runner ``degrees``: polynomial Lyapunov functions of degree 2..8 by SOS V-s iteration
(``roa.certify(..., degree=d)``), each certified by interval validation, against the true region.

* **Van der Pol** (reversed time, mu = 1): the true region of attraction is bounded by the unstable
  limit cycle; its area is computed here (solve_ivp, one period, shoelace). Per degree: certified
  level, certified area / limit-cycle area (grid count), solver and validation seconds.
* **IPC**, flat coordinates (3.8), seeded by the box-optimised quadratic V of the certify
  experiment: certified level, the certified sector at q = q' = theta' = 0 (interval lower bound),
  the share of the reference box, times. Degree 2 by SOS V-s iteration (``ipc_degrees``; degree 4
  SDPs have Gram blocks of 128 monomials), degree 4 by the sampled cutting-plane search
  (``ipc_sampled_degrees``, ``roa.certify`` with :class:`roa.CuttingPlanes`: no SDP over the field,
  the level proved by the same interval validation).
* **IPC, hybrid coordinates** (q, z2, w1, w2) (``hybrid_degrees``): degree 2 the certify
  experiment's box-optimised quadratic V there (C9), degree 4 the sampled search seeded by it;
  the same columns.

Claims D1 (Van der Pol), D2 (IPC, the paper's 60 deg), D3 (IPC, box share) and D4 (the IPC in
hybrid coordinates) go to the report.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from roa.io import atomic_write_json
from roa.options import Options
from roa.progress import step
from roa.studies import accepts

E = "results/degrees/summary.json"


@dataclass(frozen=True)
class DegreeParams(Options):
    """``[params]``: degrees per system, V-s rounds, validation budget, box samples.

    ``ipc_degrees = []`` skips the IPC (its SDPs take minutes per round); ``aux_degree`` caps the
    recast variable's degree in the IPC's Gram bases (``< 0``: no cap). ``ipc_sampled_degrees``:
    the IPC by the sampled cutting-plane search (``roa.certify`` with :class:`roa.CuttingPlanes`,
    ``sampled_*`` its options: decrease margin, outer radius, rounds, the sector held in
    ``{V <= 1}``); the level validated is ``level_safety`` x the optimum (sampled, or V at a
    witness of a refuted validation: ``roa.certify`` with :class:`roa.CuttingPlanes`), the optimum x
    1.001 checked to be refuted. ``hybrid_degrees``: the IPC in hybrid
    coordinates (q, z2, w1, w2): 2 the certify experiment's quadratic V there, higher degrees by
    the sampled search seeded by it (``[]``: not run).
    """

    vdp_degrees: tuple[int, ...] = (2, 4, 6, 8)
    ipc_degrees: tuple[int, ...] = (2, 4)
    rounds: int = 10
    ipc_rounds: int = 2
    aux_degree: int = 2
    max_boxes: int = 6_000_000
    n_box: int = 200_000
    seed: int = 0
    time_limit: float = 1800.0
    max_iters: int = 8000
    ipc_sampled_degrees: tuple[int, ...] = (4,)
    sampled_margin: float = 0.01
    sampled_local_margin: float = 0.01
    sampled_outer: float = 2.5
    sampled_rounds: int = 40
    sampled_hard_deg: float = 60.5
    level_safety: float = 0.999
    hybrid_degrees: tuple[int, ...] = (2, 4)


def limit_cycle(vdp: Any) -> tuple[np.ndarray, float]:
    """One period of the Van der Pol limit cycle (forward time: the reversed field negated) and the
    area it encloses (shoelace)."""
    from scipy.integrate import solve_ivp

    sol = solve_ivp(lambda t, x: -vdp.f(x[None])[0], (0, 60), [2.0, 0.0], rtol=1e-11,
                    atol=1e-12, dense_output=True)  # fmt: skip
    X = sol.sol(np.linspace(40, 60, 200_001)).T
    i = np.where((X[:-1, 1] < 0) & (X[1:, 1] >= 0))[0]
    seg = X[i[0] : i[1] + 1]
    area = 0.5 * abs(seg[:, 0] @ np.roll(seg[:, 1], 1) - seg[:, 1] @ np.roll(seg[:, 0], 1))
    return seg, float(area)


def _times(cert: Any) -> dict[str, float]:
    v = cert.validation.seconds if cert.validation is not None else 0.0
    a = cert.above.seconds if cert.above is not None else 0.0
    # the V search (V-s or cutting planes), else the level search of a given V
    solver = cert.vs.seconds if cert.vs is not None else cert.seconds - v - a
    return {"solver_s": round(solver, 2), "validation_s": round(v, 2),
            "refute_above_s": round(a, 2), "total_s": round(cert.seconds, 2)}  # fmt: skip


def _row(cert: Any) -> dict[str, Any]:
    return {
        "status": cert.status.value,
        "level": cert.level,
        "above": None if cert.above is None else cert.above.status.value,
        "above_level": None if cert.above is None else cert.above.level,
        "candidate": cert.candidate,
        "sampled_optimum": None if cert.search is None else cert.search.level,
        "message": cert.message,
        "boxes": None if cert.validation is None else cert.validation.boxes,
        "V": cert.V.describe() if cert.V is not None else None,
        "vs": cert.vs.to_dict() if cert.vs is not None else None,
        **_times(cert),
    }


def _vanderpol(p: dict[str, Any]) -> dict[str, Any]:
    import roa

    vdp = roa.load_system("vanderpol")
    seg, lc_area = limit_cycle(vdp)
    g = np.linspace(-3.0, 3.0, 1201)
    G = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    cell = (g[1] - g[0]) ** 2
    rows = {}
    for d in p["vdp_degrees"]:
        with step(f"degrees: Van der Pol, degree {d}"):
            vs = roa.VsOptions(shape=np.eye(2), rounds=p["rounds"])
            itv = roa.IntervalOptions(max_boxes=p["max_boxes"])
            cert = roa.certify(
                vdp, degree=int(d), vs=vs, interval=itv, check_above=1.001, validator="interval"
            )
        row = _row(cert)
        if cert.certified and cert.V is not None and cert.level is not None:
            area = float(np.count_nonzero(cert.V.value(G) <= cert.level)) * cell
            row.update(area=area, area_ratio=area / lc_area)
        rows[str(d)] = row
    return {"limit_cycle_area": lc_area, "limit_cycle": seg[::200].tolist(), "degrees": rows}


def _ipc(p: dict[str, Any], results: Path) -> dict[str, Any]:
    import roa
    from ipc_paper.system import transformed

    cert_path = results / "certify" / "certified.json"
    P = np.asarray(json.loads(cert_path.read_text())["optimised_P"], dtype=float)
    ipc = transformed()
    seed = roa.QuadraticLyapunov(P, np.zeros(4), "optimised quadratic V (box fraction)")
    rows = {}
    for d in p["ipc_degrees"]:
        aux = None if p["aux_degree"] < 0 else int(p["aux_degree"])
        vs = roa.VsOptions(rounds=p["ipc_rounds"], aux_degree=aux, time_limit=p["time_limit"],
                           max_iters=p["max_iters"])  # fmt: skip
        with step(f"degrees: IPC (flat), degree {d}"):
            cert = roa.certify(ipc, seed, degree=int(d), vs=vs, check_above=1.001,
                               interval=roa.IntervalOptions(max_boxes=p["max_boxes"]),
                               validator="interval")  # fmt: skip
        rows[str(d)] = _ipc_row(cert, p)
    for d in p.get("ipc_sampled_degrees", ()):
        with step(f"degrees: IPC (flat), degree {d}, sampled search"):
            cert = _ipc_sampled(ipc, seed, int(d), p)
        rows[f"{d} (sampled)"] = _ipc_row(cert, p)
    return {"seed": seed.name, "seed_P": P.tolist(), "degrees": rows}


def _ipc_hybrid(p: dict[str, Any], results: Path) -> dict[str, Any]:
    """The IPC in hybrid coordinates (q, z2, w1, w2): degree 2 is the certify experiment's
    box-optimised quadratic V there (case C9; its level found by sampling, proved by interval
    validation, refuted x1.001), degree 4 the sampled cutting-plane search seeded by it."""
    import roa
    from ipc_paper.system.hybrid import hybrid

    ev = json.loads((results / "certify" / "evidence.json").read_text())
    P = np.asarray(ev["ipc_hybrid_box"]["search"]["P"], dtype=float)
    hyb = hybrid()
    seed = roa.QuadraticLyapunov(P, np.zeros(4), "quadratic V in hybrid coordinates (box fraction)")
    rows = {}
    for d in p["hybrid_degrees"]:
        if int(d) == 2:
            with step("degrees: IPC (hybrid), degree 2 (the quadratic seed)"):
                cert = roa.certify(hyb, seed, method="both", check_above=1.001,
                                   interval=roa.IntervalOptions(max_boxes=p["max_boxes"]),
                                   validator="interval")  # fmt: skip
            rows["2"] = _ipc_row(cert, p, "hybrid")
            continue
        with step(f"degrees: IPC (hybrid), degree {d}, sampled search"):
            cert = _ipc_sampled(hyb, seed, int(d), p, "hybrid")
        rows[f"{d} (sampled)"] = _ipc_row(cert, p, "hybrid")
    return {"seed": seed.name, "seed_P": P.tolist(), "coords": "hybrid", "degrees": rows}


def _ipc_sampled(ipc: Any, seed: Any, d: int, p: dict[str, Any], coords: str = "flat") -> Any:
    """The sampled search with the paper's sector (to ``sampled_hard_deg``) as hard targets and
    uniform samples of the reference box as soft ones; the level: see :class:`DegreeParams`."""
    import roa
    from ipc_paper.certified import coords_map
    from ipc_paper.certify_runs import _sector_curve
    from ipc_paper.system import REFERENCE_BOX
    from roa.options import SampleSearchOptions

    to_y = coords_map(coords)
    rng = np.random.default_rng(p["seed"])
    b = np.asarray(REFERENCE_BOX, dtype=float)
    soft = to_y(b[:, 0] + (b[:, 1] - b[:, 0]) * rng.random((3000, 4)))
    t = np.radians(np.linspace(-p["sampled_hard_deg"], p["sampled_hard_deg"], 41))
    hard = to_y(_sector_curve(t))
    opts = SampleSearchOptions(degree=d, margin=p["sampled_margin"], outer=p["sampled_outer"],
                               local_margin=p["sampled_local_margin"],
                               rounds=p["sampled_rounds"], seed=p["seed"],
                               level_safety=p["level_safety"])  # fmt: skip

    def level(V: Any, opt: float) -> float:  # the largest this V allows (below its optimum)
        return opts.level_safety * opt

    search = roa.CuttingPlanes(opts, hard=hard, soft=soft, level=level, seed=seed)
    return roa.certify(ipc, search, interval=roa.IntervalOptions(max_boxes=p["max_boxes"]),
                       check_above=1.001, validator="interval")  # fmt: skip


def _components(coords: str) -> Any:
    """Physical components -> the named analysis coordinates, for any namespace."""
    from ipc_paper.system.coordinates import to_flat_components

    if coords == "flat":
        return to_flat_components

    def hybrid(q: Any, qd: Any, th: Any, thd: Any, xp: Any) -> tuple:
        return (q, *to_flat_components(q, qd, th, thd, xp)[1:])  # z1 -> q

    return hybrid


def _ipc_row(cert: Any, p: dict[str, Any], coords: str = "flat") -> dict[str, Any]:
    """The row of one IPC certificate: level, times, the certified sector, the box share."""
    from ipc_paper.certified import coords_map
    from ipc_paper.certify_runs import _box_fraction, _sector_curve
    from ipc_paper.system import REFERENCE_BOX
    from roa.proof import certified_sector, degrees_lower
    from roa.search import sector

    c2y, comps = coords_map(coords), _components(coords)
    row = _row(cert)
    if cert.certified and cert.V is not None and cert.level is not None:
        V, level = cert.V, float(cert.level)

        def form(X: np.ndarray, V: Any = V) -> np.ndarray:
            with np.errstate(invalid="ignore"):
                Y = c2y(X)
                ok = np.all(np.isfinite(Y), axis=1)
                out = np.full(len(X), np.inf)
                out[ok] = V.value(Y[ok])
            return out

        def form_xp(x: Any, xp: Any, V: Any = V) -> Any:
            return V.expr(list(comps(x[0], x[1], x[2], x[3], xp)), xp)

        t_max = np.pi / 2 - 1e-6
        th = certified_sector(form_xp, level, lambda s, xp: (0.0, 0.0, s, 0.0), t_max)
        row.update(
            sector_deg=degrees_lower(th),
            sector_float_deg=float(np.degrees(sector(form, level, _sector_curve, t_max))),
            box=_box_fraction(form, level, REFERENCE_BOX, p["n_box"], p["seed"]),
        )
    return row


@accepts(DegreeParams)
def run(params: dict[str, Any], out: Path, *, quick: bool) -> dict[str, Any]:
    from ipc_paper.degrees_report import claims, figure

    t0 = time.perf_counter()
    ev: dict[str, Any] = {"vanderpol": _vanderpol(params)}
    any_ipc = params["ipc_degrees"] or params["ipc_sampled_degrees"]
    ev["ipc"] = _ipc(params, out.parent) if any_ipc else {"degrees": {}}
    hyb = params["hybrid_degrees"]
    ev["ipc_hybrid"] = _ipc_hybrid(params, out.parent) if hyb else {"degrees": {}}
    ev["seconds"] = round(time.perf_counter() - t0, 1)
    atomic_write_json(out / "evidence.json", ev)
    figure(ev, out / "degrees.png")
    return {"claims": claims(ev, quick=quick), "evidence": ev_summary(ev)}


def ev_summary(ev: dict[str, Any]) -> dict[str, Any]:
    """The numbers of the claims, without the polynomials (those are in evidence.json)."""
    keep = ("status", "level", "candidate", "above", "area_ratio", "sector_deg", "box", "solver_s",
            "validation_s", "boxes", "total_s")  # fmt: skip
    return {
        sysname: {d: {k: r.get(k) for k in keep if k in r} for d, r in blk["degrees"].items()}
        for sysname, blk in ev.items()
        if isinstance(blk, dict) and "degrees" in blk
    } | {"limit_cycle_area": ev["vanderpol"]["limit_cycle_area"]}
