"""Experiment runner ``degrees``: polynomial Lyapunov functions of degree 2..8 by SOS V-s iteration
(``roa.certify(..., degree=d)``), each certified by interval validation, against the true region.

* **Van der Pol** (reversed time, mu = 1): the true region of attraction is bounded by the unstable
  limit cycle; its area is computed here (solve_ivp, one period, shoelace). Per degree: certified
  level, certified area / limit-cycle area (grid count), solver and validation seconds.
* **IPC**, flat coordinates (3.8), seeded by the box-optimised quadratic V of the certify
  experiment: certified level, the certified sector at q = q' = theta' = 0 (interval lower bound),
  the share of the reference box, times.

Claims D1 (Van der Pol) and D2 (IPC, the paper's 60 deg) go to the report.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from roa.experiment import accepts
from roa.io import atomic_write_json
from roa.options import Options
from roa.progress import step

E = "results/degrees/summary.json"


@dataclass(frozen=True)
class DegreeParams(Options):
    """``[params]``: degrees per system, V-s rounds, validation budget, box samples.

    ``ipc_degrees = []`` skips the IPC (its SDPs take minutes per round); ``aux_degree`` caps the
    recast variable's degree in the IPC's Gram bases (``< 0``: no cap).
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
    return {"solver_s": round(cert.vs.seconds, 2), "validation_s": round(v, 2),
            "refute_above_s": round(a, 2), "total_s": round(cert.seconds, 2)}  # fmt: skip


def _row(cert: Any) -> dict[str, Any]:
    return {
        "status": cert.status.value,
        "level": cert.level,
        "above": None if cert.above is None else cert.above.status.value,
        "boxes": None if cert.validation is None else cert.validation.boxes,
        "V": cert.V.describe() if cert.V is not None else None,
        "vs": cert.vs.to_dict() if cert.vs is not None else None,
        **(_times(cert) if cert.vs is not None else {}),
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
            cert = roa.certify(vdp, degree=int(d), vs=vs, interval=itv, check_above=1.001)
        row = _row(cert)
        if cert.certified and cert.V is not None and cert.level is not None:
            area = float(np.count_nonzero(cert.V.value(G) <= cert.level)) * cell
            row.update(area=area, area_ratio=area / lc_area)
        rows[str(d)] = row
    return {"limit_cycle_area": lc_area, "limit_cycle": seg[::200].tolist(), "degrees": rows}


def _ipc(p: dict[str, Any], results: Path) -> dict[str, Any]:
    import roa
    from ipc_paper.certified import coords_map
    from ipc_paper.certify_runs import _box_fraction, _sector_curve
    from roa.proof.search import sector
    from roa.proof.sector import certified_sector, degrees_lower
    from roa.systems.ipc import REFERENCE_BOX, transformed
    from roa.systems.ipc.coordinates import to_flat_components

    cert_path = results / "certify" / "certified.json"
    P = np.asarray(json.loads(cert_path.read_text())["optimised_P"], dtype=float)
    ipc = transformed()
    seed = roa.QuadraticLyapunov(P, np.zeros(4), "optimised quadratic V (box fraction)")
    c2y = coords_map("flat")
    rows = {}
    for d in p["ipc_degrees"]:
        aux = None if p["aux_degree"] < 0 else int(p["aux_degree"])
        vs = roa.VsOptions(rounds=p["ipc_rounds"], aux_degree=aux, time_limit=p["time_limit"],
                           max_iters=p["max_iters"])  # fmt: skip
        with step(f"degrees: IPC (flat), degree {d}"):
            cert = roa.certify(ipc, seed, degree=int(d), vs=vs, check_above=1.001,
                               interval=roa.IntervalOptions(max_boxes=p["max_boxes"]))  # fmt: skip
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
                return V.expr(list(to_flat_components(x[0], x[1], x[2], x[3], xp)), xp)

            t_max = np.pi / 2 - 1e-6
            th = certified_sector(form_xp, level, lambda s, xp: (0.0, 0.0, s, 0.0), t_max)
            row.update(
                sector_deg=degrees_lower(th),
                sector_float_deg=float(np.degrees(sector(form, level, _sector_curve, t_max))),
                box=_box_fraction(form, level, REFERENCE_BOX, p["n_box"], p["seed"]),
            )
        rows[str(d)] = row
    return {"seed": seed.name, "seed_P": P.tolist(), "degrees": rows}


@accepts(DegreeParams)
def run(params: dict[str, Any], out: Path, *, quick: bool) -> dict[str, Any]:
    from ipc_paper.degrees_report import claims, figure

    t0 = time.perf_counter()
    ev: dict[str, Any] = {"vanderpol": _vanderpol(params)}
    ev["ipc"] = _ipc(params, out.parent) if params["ipc_degrees"] else {"degrees": {}}
    ev["seconds"] = round(time.perf_counter() - t0, 1)
    atomic_write_json(out / "evidence.json", ev)
    figure(ev, out / "degrees.png")
    return {"claims": claims(ev, quick=quick), "evidence": ev_summary(ev)}


def ev_summary(ev: dict[str, Any]) -> dict[str, Any]:
    """The numbers of the claims, without the polynomials (those are in evidence.json)."""
    keep = ("status", "level", "above", "area_ratio", "sector_deg", "box", "solver_s",
            "validation_s", "total_s")  # fmt: skip
    return {
        sysname: {d: {k: r.get(k) for k in keep if k in r} for d, r in blk["degrees"].items()}
        for sysname, blk in ev.items()
        if isinstance(blk, dict) and "degrees" in blk
    } | {"limit_cycle_area": ev["vanderpol"]["limit_cycle_area"]}
