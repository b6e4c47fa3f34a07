"""Experiment runner ``robust``: the IPC's certified region when the plant's mass ratio is uncertain.

The controller is designed with the nominal mass ratio ``delta = M / m = 1``; the real plant's
ratio ``delta_plant`` lies in ``[delta_low, delta_high]`` (default ``[0.5, 2]``). The closed loop in
flat coordinates is :func:`ipc_paper.system.transformed_uncertain`; every certificate here holds
for *every* ``delta_plant`` of the box (:func:`roa.certify` on a system with uncertain parameters:
one interval branch and bound over states and the parameter, :mod:`roa.proof._robust`).

Cases (each a :func:`roa.certify` call; refutations name the ``delta_plant`` of their witness):

* ``paper``: the paper's V (3.11) over the box;
* ``box_optimised``: the certify experiment's box-optimised quadratic V (claim C5) over the box;
* ``robust_quadratic``: a quadratic V designed for the box here: the linearisation is affine in
  ``1 / delta_plant`` (``A = A0 + A1 / delta_plant``, checked at the midpoint), so ``P`` with
  ``A_i' P + P A_i <= -2 alpha P`` at the two ends (an LMI, cvxpy + Clarabel) makes it a quadratic
  Lyapunov function of the linearisation for every ``delta_plant`` of the box; of those, the ``P``
  nearest (Frobenius) to the box-optimised one. Its robust level is proposed at the worst sample
  point (``safety`` x it) and proved for the box; ``1.001`` x the proposal is refuted. The sector at
  ``q = q' = theta' = 0`` (certified lower bound) and the share of the reference box are measured
  as in the certify experiment.
* the paper's 60 deg sector for every ``delta_plant`` of ``[1 / k, k]``: no quadratic V certifies
  60 deg even at the nominal value (claims C5, C6), so the question goes to a V that does
  there: the degree-4 V of the degrees experiment (D2). For each ``k`` of ``sector_k``, the level
  whose sublevel set holds the 60 deg sector is checked for the box ``[1 / k, k]``
  (certified / refuted with a witness / inconclusive within ``max_boxes``).

Claims R1-R4 go to the report.
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

E = "results/robust/summary.json"


@dataclass(frozen=True)
class RobustParams(Options):
    """``[params]``: the box of the plant's mass ratio, the design and validation settings.

    ``alpha``: decay rate of the robust quadratic design; ``safety``: the level validated is
    ``safety`` x the worst sampled optimum over the box; ``max_boxes``: budget of each interval
    validation; ``sector_k``: the boxes ``[1 / k, k]`` of the 60 deg question (``[]``: not run);
    ``n_box``, ``seed``: samples of the reference box; ``n_curve``: values of delta_plant of the
    figure's curves; ``cases``: which of ``paper``, ``box_optimised``, ``robust_quadratic`` run
    (the others are reported "not run").
    """

    delta_low: float = 0.5
    delta_high: float = 2.0
    alpha: float = 0.2
    safety: float = 0.99
    max_boxes: int = 6_000_000
    sector_k: tuple[float, ...] = (1.05, 1.1, 1.25)
    n_box: int = 200_000
    n_curve: int = 13
    seed: int = 0
    cases: tuple[str, ...] = ("paper", "box_optimised", "robust_quadratic")

    def __post_init__(self) -> None:
        from roa.errors import RoaInputError

        if not 0 < self.delta_low < 1 < self.delta_high:
            raise RoaInputError(
                f"robust: need 0 < delta_low < 1 < delta_high, got [{self.delta_low}, "
                f"{self.delta_high}]"
            )
        if not 0 < self.safety < 1:
            raise RoaInputError(f"robust: safety must be in (0, 1), got {self.safety}")
        if not 0 <= self.alpha <= 1:
            raise RoaInputError(f"robust: alpha must be in [0, 1], got {self.alpha}")
        unknown = set(self.cases) - {"paper", "box_optimised", "robust_quadratic"}
        if unknown:
            raise RoaInputError(f"robust: unknown cases {sorted(unknown)}")
        if any(not 1 < k <= 4 for k in self.sector_k):
            raise RoaInputError(f"robust: each sector_k must be in (1, 4], got {self.sector_k}")


def robust_quadratic(system: Any, P_near: np.ndarray, alpha: float) -> tuple[np.ndarray, dict]:
    """``P`` of the module doc and the design's figures (decay checked at the two ends)."""
    import cvxpy as cp

    from roa.errors import RoaInputError
    from roa.model import linearise

    box = system.parameters["delta_plant"]
    ends = [linearise(system.at(delta_plant=d)).A for d in (box.low, box.high)]
    mid = 2.0 / (1.0 / box.low + 1.0 / box.high)  # the midpoint of 1 / delta_plant
    A_mid = linearise(system.at(delta_plant=mid)).A
    affine_gap = float(np.abs(A_mid - 0.5 * (ends[0] + ends[1])).max())
    if affine_gap > 1e-9:
        raise RoaInputError(f"the linearisation is not affine in 1/delta_plant ({affine_gap:.3g})")
    P = cp.Variable((4, 4), symmetric=True)
    cons = [P >> 1e-3 * np.eye(4)] + [A.T @ P + P @ A << -2 * alpha * P for A in ends]
    prob = cp.Problem(cp.Minimize(cp.norm(P - P_near, "fro")), cons)
    prob.solve(solver="CLARABEL")
    if P.value is None:
        raise RoaInputError(f"no quadratic V with decay rate {alpha} for the box: {prob.status}")
    Pr = 0.5 * (P.value + P.value.T)
    Linv = np.linalg.inv(np.linalg.cholesky(Pr))  # decay: eigenvalues of L^-1 (A'P + PA) L^-T
    decay = [float(np.linalg.eigvalsh(Linv @ (A.T @ Pr + Pr @ A) @ Linv.T).max()) for A in ends]
    return Pr, {"alpha": alpha, "solver_status": prob.status, "distance": float(prob.value),
                "max_eig_scaled_ends": decay, "affine_gap": affine_gap}  # fmt: skip


def _row(cert: Any) -> dict[str, Any]:
    v = cert.validation
    out = {
        "status": cert.status.value,
        "level": cert.level,
        "candidate": cert.candidate,
        "message": cert.message,
        "boxes": None if v is None else v.boxes,
        "seconds": round(cert.seconds, 1),
        "witness": None if v is None else v.witness,
        "witness_parameters": None if v is None else v.witness_parameters,
        "above": None if cert.above is None else cert.above.status.value,
        "above_level": None if cert.above is None else cert.above.level,
        "above_parameters": None if cert.above is None else cert.above.witness_parameters,
    }
    if cert.search is not None:
        out["worst_sample"] = cert.search.details.get("parameters")
    return out


def _sector_box(V: Any, level: float, p: dict[str, Any]) -> dict[str, Any]:
    """Certified sector at q = q' = theta' = 0 (degrees, lower bound) and reference-box share of
    ``{V(flat(x)) <= level}``."""
    from ipc_paper.certified import coords_map
    from ipc_paper.certify_cases import _box_fraction
    from ipc_paper.system import REFERENCE_BOX
    from ipc_paper.system.coordinates import to_flat_components
    from roa.proof import certified_sector, degrees_lower

    c2y = coords_map("flat")

    def form(X: np.ndarray) -> np.ndarray:
        with np.errstate(invalid="ignore"):
            Y = c2y(X)
            ok = np.all(np.isfinite(Y), axis=1)
            out = np.full(len(X), np.inf)
            out[ok] = V.value(Y[ok])
        return out

    def form_xp(x: Any, xp: Any) -> Any:
        return V.expr(list(to_flat_components(x[0], x[1], x[2], x[3], xp)), xp)

    th = certified_sector(form_xp, level, lambda s, xp: (0.0, 0.0, s, 0.0), np.pi / 2 - 1e-6)
    return {"sector_deg": degrees_lower(th),
            "box": _box_fraction(form, level, REFERENCE_BOX, p["n_box"], p["seed"])}  # fmt: skip


def sector_level(V: Any, degrees: float = 60.0) -> float:
    """The largest ``V`` on the sector ``|theta| <= degrees`` at ``q = q' = theta' = 0`` (a dense
    grid, x (1 + 1e-6)): ``{V <= it}`` holds the sector (checked after certification by
    :func:`roa.proof.certified_sector`)."""
    from ipc_paper.system.coordinates import to_flat_components
    from roa.model import NP

    th = np.radians(np.linspace(-degrees, degrees, 40001))
    z = np.zeros_like(th)
    Y = np.stack([np.broadcast_to(np.asarray(c, dtype=float), th.shape)
                  for c in to_flat_components(z, z, th, z, NP)], axis=1)  # fmt: skip
    return float(V.value(Y).max()) * (1 + 1e-6)


def _cases(p: dict[str, Any], results: Path) -> dict[str, Any]:
    import roa
    from ipc_paper.system import transformed_uncertain
    from roa.search import as_lyapunov

    system = transformed_uncertain(delta_low=p["delta_low"], delta_high=p["delta_high"])
    itv = roa.IntervalOptions(max_boxes=p["max_boxes"], sampled_safety=p["safety"])
    ev: dict[str, Any] = {"box": [p["delta_low"], p["delta_high"]]}
    skipped = {"status": "not run", "message": "not run (cases)"}
    ev["paper"] = ev["box_optimised"] = ev["robust_quadratic"] = skipped
    if "paper" in p["cases"]:
        with step("robust: the paper's V over the box"):
            ev["paper"] = _row(
                roa.certify(system, None, method="interval", interval=itv, validator="interval")
            )
    P_box = np.asarray(json.loads((results / "certify" / "V_optimised_box.json").read_text())["P"])
    if "box_optimised" in p["cases"]:
        with step("robust: the box-optimised V (C5) over the box"):
            ev["box_optimised"] = _row(roa.certify(system, P_box, method="interval",
                                                   interval=itv, validator="interval"))  # fmt: skip
    P, design = robust_quadratic(system, P_box, p["alpha"])
    if "robust_quadratic" in p["cases"]:
        with step("robust: the quadratic V designed for the box"):
            cert = roa.certify(
                system, P, method="interval", interval=itv, check_above=1.001, validator="interval"
            )
        row = {**_row(cert), "P": P.tolist(), "design": design}
        if cert.certified and cert.level is not None:
            row.update(_sector_box(as_lyapunov(system, P), float(cert.level), p))
        nominal = roa.level_search(system.nominal(), P, method="sampled")
        row["nominal_sampled_optimum"] = nominal.level
        ev["robust_quadratic"] = row
    Vs = {"paper": None, "box_optimised": P_box, "robust_quadratic": P}
    ev["curves"] = _curves(system, Vs, p["n_curve"])
    ev["sector60"] = _sector60(p, results)
    return ev


def _curves(system: Any, Vs: dict[str, Any], n: int = 13) -> dict[str, Any]:
    """The sampled optimum of each V at ``n`` values of delta_plant (geometric grid over the box):
    what a nominal-only analysis would miss (a search per value: no proof)."""
    import roa

    box = system.parameters["delta_plant"]
    deltas = np.geomspace(box.low, box.high, n)
    out: dict[str, Any] = {"delta_plant": deltas.tolist()}
    opts = roa.SampledOptions(n_directions=4000)
    for name, P in Vs.items():
        levels = []
        for d in deltas:
            r = roa.level_search(system.at(delta_plant=float(d)), P, method="sampled",
                                 sampled=opts)  # fmt: skip
            levels.append(r.level)
        out[name] = levels
    return out


def _sector60(p: dict[str, Any], results: Path) -> dict[str, Any]:
    """The 60 deg sector for every delta_plant of [1 / k, k], with the degree-4 V of D2."""
    import roa
    from ipc_paper.system import transformed_uncertain
    from roa.lyapunov import from_json

    out: dict[str, Any] = {"k": {}}
    if not p["sector_k"]:
        return {**out, "why": "not run (sector_k = [])"}
    deg = json.loads((results / "degrees" / "evidence.json").read_text())
    entry = deg.get("ipc", {}).get("degrees", {}).get("4 (sampled)")
    if not entry or entry.get("status") != "certified":
        return {**out, "why": "no certified degree-4 V in the degrees experiment"}
    V = from_json(entry["V"], np.zeros(4))
    level = sector_level(V)
    out.update(level=level, nominal_level=entry["level"], V=entry["V"])
    itv = roa.IntervalOptions(max_boxes=p["max_boxes"])
    for k in sorted(p["sector_k"]):
        system = transformed_uncertain(delta_low=1.0 / k, delta_high=k)
        with step(f"robust: the 60 deg sector for delta_plant in [1/{k:g}, {k:g}]"):
            cert = roa.certify(system, V, level=level, interval=itv, validator="interval")
        out["k"][f"{k:g}"] = _row(cert)
        if cert.status is roa.Verdict.REFUTED:
            break  # a wider box holds this one: refuted too
    return out


@accepts(RobustParams)
def run(params: dict[str, Any], out: Path, *, quick: bool) -> dict[str, Any]:
    from ipc_paper.robust_report import claims, figure

    t0 = time.perf_counter()
    ev = _cases(params, out.parent)
    ev["seconds"] = round(time.perf_counter() - t0, 1)
    atomic_write_json(out / "evidence.json", ev)
    figure(ev, out / "robust.png", quick=quick)
    return {"claims": claims(ev, quick=quick), "evidence": ev,
            "figures": ["results/robust/robust.png"]}  # fmt: skip
