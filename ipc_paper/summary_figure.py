"""Experiment ``summary``: one figure of the whole study, what each estimate guarantees.

For every region estimate (the paper's claims, our sampled levels, the certified sets) and for the
empirical basin: the sector ``|theta(0)|`` it guarantees on the line q = q' = theta' = 0 and its
share of the reference box of physical states, as a dot plot (claimed vs sampled vs certified vs
empirical). Reads the certify, basin_box and basin_theta_thetadot results; makes no claims.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D

from ipc_paper import system as ipc
from ipc_paper.basins import SECTOR, regions
from ipc_paper.estimates import sector_theta
from roa.errors import ResultsError
from roa.io import atomic_write_json
from roa.montecarlo import box_sample
from roa.options import Options
from roa.plotting import (
    KIND_STYLES,
    KIND_WORDS,
    LINE_STYLE,
    region_label,
    save_figure,
)
from roa.studies import MAX_SEED, accepts, check_int

#: Row order of the kinds (top to bottom) and their markers.
KINDS = ("claimed", "sampled", "certified", "refuted", "inconclusive", "empirical")
MARKERS = {"claimed": "o", "sampled": "s", "certified": "D", "refuted": "x", "inconclusive": "x",
           "empirical": "*"}  # fmt: skip
EMPIRICAL_COLOUR = "#238b45"  # the dark end of the time-to-converge colours
SECTOR_AXIS = "sector |theta(0)| guaranteed at q = q' = theta' = 0 [deg]"
SHARE_AXIS = "share of the reference box [%]"


@dataclass(frozen=True, kw_only=True)
class SummaryParams(Options):
    """``[params]`` of :func:`run_summary`: ``samples`` of the reference box (``seed``) to measure
    the share of a region that the basin_box run did not test."""

    samples: int = 20000
    seed: int = 0

    def __post_init__(self) -> None:
        check_int(self, "samples", 1, 10**7)
        check_int(self, "seed", 0, MAX_SEED)


def _colour(kind: str) -> Any:
    return EMPIRICAL_COLOUR if kind == "empirical" else KIND_STYLES[kind]["colours"][0]


def _read(results: Path, name: str) -> dict[str, Any]:
    path = results / name / "summary.json"
    if not path.is_file():
        raise ResultsError(f"{path} missing: run experiments/{name}.toml first")
    return json.loads(path.read_text())


def summary_rows(results: str | Path, *, samples: int, seed: int) -> list[dict[str, Any]]:
    """One row per estimate and one for the empirical basin: ``label``, ``kind``, ``sector_deg``,
    ``box_share`` (0-1, or None) and ``box_share_ci95`` (empirical row)."""
    results = Path(results)
    box = next(b for b in _read(results, "basin_box")["boxes"] if b["box_name"] == "reference")
    tested = {c["region"]: c["points_in_region"] / box["n"] for c in box["containment"]}
    regs, _ = regions(results)
    own = None
    rows = []
    for r in regs:
        share = tested.get(r.name)
        if share is None:  # a region the box run did not test: our own samples of the box
            if own is None:
                smp = box_sample(ipc.closed_loop(), ipc.REFERENCE_BOX, samples, seed=seed)
                own = smp.points(0, smp.n)
            share = float(np.mean(r.contains(own)))
        rows.append({"name": r.name, "label": region_label(r), "kind": r.status,
                     "sector_deg": float(np.degrees(sector_theta(r))), "box_share": share,
                     "box_share_ci95": None})  # fmt: skip
    scan = _read(results, "basin_theta_thetadot").get("sector_scan")
    sector = None
    if scan:
        sector = min(abs(scan["theta_converged_from_deg"]), abs(scan["theta_converged_to_deg"]))
    rows.append({"name": "empirical", "kind": "empirical",
                 "label": f"empirical basin (Monte Carlo, no proof; {box['n']} box samples)",
                 "sector_deg": sector, "box_share": box["fraction_converged"],
                 "box_share_ci95": list(box["fraction_converged_ci95"])})  # fmt: skip
    return sorted(rows, key=lambda w: KINDS.index(w["kind"]) if w["kind"] in KINDS else 99)


def summary_figure(rows: list[dict[str, Any]], *, title: str = "") -> Any:
    """The dot plot of :func:`summary_rows` as a matplotlib Figure (unsaved)."""
    n = len(rows)
    fig, axes = plt.subplots(1, 2, sharey=True, figsize=(11.0, 1.6 + 0.3 * n),
                             layout="constrained", width_ratios=(1.0, 1.0))  # fmt: skip
    y = np.arange(n)[::-1]
    for ax, key, scale, top in (
        (axes[0], "sector_deg", 1.0, 90.0),
        (axes[1], "box_share", 100.0, 100.0),
    ):
        for yi, row in zip(y, rows, strict=True):
            v = row[key]
            if v is None:
                ax.text(1.0, yi, "not measured", va="center", fontsize=8, color="#555555")
                continue
            c = _colour(row["kind"])
            ax.plot([0, v * scale], [yi, yi], color=c, lw=0.8, alpha=0.5)
            filled = row["kind"] in ("certified", "empirical")
            ax.plot(v * scale, yi, MARKERS.get(row["kind"], "o"), color=c, ms=8 if row["kind"] == "empirical" else 6,
                    mfc=c if filled else "white", mew=1.5)  # fmt: skip
            ci = row.get("box_share_ci95") if key == "box_share" else None
            if ci:
                ax.plot([ci[0] * scale, ci[1] * scale], [yi, yi], color=c, lw=2.5)
            shown = v * scale
            if row["kind"] == "certified":  # a certified lower bound is never printed rounded up
                shown = math.floor(shown * 10) / 10
            ax.text(min(v * scale, top) + top * 0.025, yi, f"{shown:.1f}", fontsize=7.5,
                    va="center", color="#333333",
                    bbox={"fc": "white", "ec": "none", "pad": 0.3, "alpha": 0.85})  # fmt: skip
        ax.set_xlim(0, top * 1.1)
        ax.grid(axis="x", alpha=0.3)
        for yi in y:
            ax.axhline(yi, color="#dddddd", lw=0.5, zorder=0)
    axes[0].axvline(np.degrees(SECTOR), **LINE_STYLE)
    axes[0].set_xlabel(SECTOR_AXIS)
    axes[1].set_xlabel(SHARE_AXIS)
    axes[0].set_yticks(y, [r["label"] for r in rows], fontsize=8.5)
    axes[0].set_ylim(-0.7, n - 0.3)
    (lo_q, hi_q), (lo_qd, hi_qd), (lo_t, hi_t), (lo_td, hi_td) = ipc.REFERENCE_BOX
    axes[1].set_title(f"box |q| <= {hi_q:g}, |q'| <= {hi_qd:g}, |theta| <= "
                      f"{np.degrees(hi_t):.0f} deg, |theta'| <= {hi_td:g}", fontsize=9)  # fmt: skip
    axes[0].set_title("the domain allows up to 90 deg", fontsize=9)
    kinds = [k for k in KINDS if any(r["kind"] == k for r in rows)]
    handles = [Line2D([], [], ls="", marker=MARKERS[k], color=_colour(k), ms=7,
                      mfc=_colour(k) if k in ("certified", "empirical") else "white", mew=1.5,
                      label=KIND_WORDS.get(k, "empirical basin (sampled, no proof)"))
               for k in kinds]  # fmt: skip
    handles.append(Line2D([], [], **LINE_STYLE, label="paper's claimed sector 60 deg"))
    fig.legend(handles=handles[:6], loc="outside lower center", ncol=min(len(handles), 6),
               fontsize=8.5, frameon=False)  # fmt: skip
    if title:
        fig.suptitle(title, fontsize=11)
    return fig


@accepts(SummaryParams)
def run_summary(params: dict[str, Any], out: Path, *, quick: bool) -> dict[str, Any]:
    """The summary figure of the study: sector and reference-box share of every estimate."""
    rows = summary_rows(out.parent, samples=int(params["samples"]), seed=int(params["seed"]))
    fig = summary_figure(rows, title="What each region estimate guarantees: the paper's claims, "
                         "our sampled levels, our certified sets and the empirical basin")  # fmt: skip
    save_figure(fig, out / "estimates.png")
    atomic_write_json(out / "estimates.json", {"rows": rows})
    return {"rows": rows, "claims": [], "figures": [f"results/{out.name}/estimates.png"]}
