"""Claims R1-R4 and the figure of the ``robust`` experiment (:mod:`ipc_paper.robust`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ipc_paper.degrees_report import box_share

E = "results/robust/summary.json"


def _verdict_text(r: dict[str, Any]) -> str:
    status = r["status"]
    if status == "not run":
        return r["message"]
    if status == "certified":
        return f"certified at V <= {r['level']:.6g} ({r['boxes']} boxes, {r['seconds']} s)"
    if status == "refuted":
        wp = r.get("witness_parameters") or {}
        at = ", ".join(f"{k} = {v:.4g}" for k, v in wp.items())
        return (f"refuted: V' >= 0 inside every level tried, witness at {at} (50 digits); "
                f"last level {r['level']:.4g}")  # fmt: skip
    return f"{status}: {r['message'][:160]}"


def claims(ev: dict[str, Any], *, quick: bool) -> list[dict[str, Any]]:
    lo, hi = ev["box"]
    box = f"delta_plant in [{lo:g}, {hi:g}]"
    paper = "not considered (the controller and its analysis use the nominal delta only)"
    out = []
    for cid, key, what in (("R1", "paper", "the paper's V (3.11)"),
                           ("R2", "box_optimised", "the box-optimised quadratic V (C5)")):  # fmt: skip
        r = ev[key]
        out.append({
            "id": cid,
            "claim": f"{what} proves a region of attraction for every plant mass ratio "
            f"{box} (controller designed for delta = 1)",
            "paper": paper,
            "ours": _verdict_text(r),
            "verdict": "beyond the paper" if r["status"] in ("certified", "refuted") else "inconclusive",
            "evidence": E,
        })  # fmt: skip
    r = ev["robust_quadratic"]
    txt = _verdict_text(r)
    if r["status"] == "certified":
        txt += (f"; sector |theta(0)| <= {r['sector_deg']:.2f} deg at q = q' = theta' = 0 (certified "
                f"lower bound), reference-box share {box_share(r['box'])}; x1.001 of the "
                f"worst sampled optimum: {r['above']}")  # fmt: skip
    if "design" in r:
        txt += (f" (P nearest C5 with A'P + PA <= -2 alpha P at both ends of 1/delta_plant, "
                f"alpha = {r['design']['alpha']:g}; nominal sampled optimum of this V "
                f"{r['nominal_sampled_optimum']:.4g})")  # fmt: skip
    out.append({
        "id": "R3",
        "claim": f"a quadratic V designed for the box certifies a region for every {box}",
        "paper": paper,
        "ours": txt,
        "verdict": "beyond the paper" if r["status"] == "certified" else "inconclusive",
        "evidence": E,
    })  # fmt: skip
    s = ev["sector60"]
    if not s["k"]:
        ours, verdict = s.get("why", "not run"), "inconclusive"
    else:
        parts = [f"[1/{k}, {k}]: {row['status']}" + (
            f" (witness at delta_plant = {row['witness_parameters']['delta_plant']:.4g})"
            if row.get("witness_parameters") else f" ({row['boxes']} boxes, {row['seconds']} s)")
            for k, row in s["k"].items()]  # fmt: skip
        certified = [float(k) for k, row in s["k"].items() if row["status"] == "certified"]
        widest = f"widest certified: [1/{max(certified):g}, {max(certified):g}]" if certified else (
            "no interval certified")  # fmt: skip
        ours = (f"degree-4 V of D2 at V <= {s['level']:.6g} (holds the 60 deg sector): "
                + "; ".join(parts) + f"; {widest}")  # fmt: skip
        verdict = "beyond the paper" if certified or any(
            row["status"] == "refuted" for row in s["k"].values()) else "inconclusive"  # fmt: skip
    out.append({
        "id": "R4",
        "claim": "the widest interval [1/k, k] of the plant's mass ratio around the design's "
        "delta = 1 for which the paper's 60 deg sector (q = q' = theta' = 0) is still certified",
        "paper": "60 deg at the nominal delta (Section 3.2.1)",
        "ours": ours,
        "verdict": verdict,
        "evidence": E,
    })  # fmt: skip
    return out


def figure(ev: dict[str, Any], path: Path, *, quick: bool = False) -> None:
    """Write :func:`robust_figure` to ``path``."""
    import matplotlib.pyplot as plt

    from roa.io import atomic_savefig

    fig = robust_figure(ev, quick=quick)
    atomic_savefig(fig, path)
    plt.close(fig)


#: Height (axes fraction) of the markers of a V without a level, in a band at the bottom of panel
#: (a) (one row per V, 0.035 apart).
NO_LEVEL_Y = 0.04


def log_ticks(lo: float, hi: float) -> list[float]:
    """Ticks of a log axis over ``[lo, hi]``: both ends, 1 when inside, and for a range wider than
    a factor 2 the geometric midpoints between an end and 1 (the box ends, e.g. 1.25, are labelled
    even when no power of ten lies inside)."""
    ticks = {float(lo), float(hi)}
    if lo < 1.0 < hi:
        ticks.add(1.0)
        if hi / lo > 2.0:
            ticks |= {float(np.sqrt(lo)), float(np.sqrt(hi))}
    return sorted(ticks)


def robust_figure(ev: dict[str, Any], *, quick: bool = False) -> Any:
    """(a) Each V's sampled optimum against delta_plant, the robust certified level drawn, a V
    with no level marked on the bottom edge; (b) the certified sets on the (theta, theta') slice
    at q = q' = 0, or a note saying why there is none."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

    from ipc_paper.system import physical_to_flat_or_inf
    from ipc_paper.system.lyapunov import P_Q, T

    fig, axes = plt.subplots(1, 2, figsize=(11.5, 4.8))
    ax = axes[0]
    c = ev["curves"]
    d = np.asarray(c["delta_plant"])
    labels = {"paper": "paper's V (3.11)", "box_optimised": "box-optimised V (C5)",
              "robust_quadratic": "V designed for the box"}  # fmt: skip
    edge = ax.get_xaxis_transform()  # x in data, y in axes fraction
    for k, name in enumerate(labels):
        lv = np.array([np.nan if v is None else v for v in c[name]], dtype=float)
        ax.plot(d, lv, "o-", color=f"C{k}", label=f"{labels[name]}: sampled optimum")
        none = np.isnan(lv)
        if none.any():
            ax.plot(d[none], np.full(none.sum(), NO_LEVEL_Y + 0.035 * k), "x", color=f"C{k}", ms=8,
                    transform=edge, clip_on=False,
                    label=f"{labels[name]}: no level (V' >= 0 next to x_eq), on the bottom edge")  # fmt: skip
    r = ev["robust_quadratic"]
    if r["status"] == "certified":
        ax.axhline(r["level"], color="C2", ls="--",
                   label=f"certified for every delta_plant: {r['level']:.4g}")  # fmt: skip
    ax.axvline(1.0, color="k", lw=0.6, ls=":", label="design delta = 1")
    ax.set_xscale("log")
    ax.set_yscale("log")
    drawn = [v for name in labels for v in c[name] if v is not None and v > 0]
    if r["status"] == "certified":
        drawn.append(r["level"])
    if drawn:  # an empty band at the bottom for the markers of a V without a level
        ax.set_ylim(bottom=min(drawn) / 2.0)
    plain = FuncFormatter(lambda v, _: f"{v:.3g}")
    ax.xaxis.set_major_locator(FixedLocator(log_ticks(float(d.min()), float(d.max()))))
    ax.xaxis.set_major_formatter(plain)
    ax.xaxis.set_minor_locator(NullLocator())
    ax.yaxis.set_major_formatter(plain)
    ax.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:.3g}" if
                                               f"{v:.1g}"[0] in "25" else ""))  # fmt: skip
    ax.set_xlabel("plant mass ratio delta_plant = M/m [-]")
    ax.set_ylabel("largest level with V' < 0 (sampled) [-]")
    ax.set_title("(a) each V's level against the plant's mass ratio")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0.0, -0.13), frameon=False)
    ax = axes[1]
    th = np.linspace(-np.pi / 2 + 0.02, np.pi / 2 - 0.02, 301)
    thd = np.linspace(-3.0, 3.0, 241)
    TH, THD = np.meshgrid(th, thd)
    X = np.stack([np.zeros_like(TH), np.zeros_like(TH), TH, THD], axis=-1).reshape(-1, 4)
    Y = physical_to_flat_or_inf(X)
    sets = []
    if r["status"] == "certified":
        sets.append(
            (np.asarray(r["P"]), r["level"], "C2", "V designed for the box, every delta_plant")
        )
    if ev["paper"]["status"] == "certified":
        sets.append((T.T @ P_Q @ T, ev["paper"]["level"], "C0", "paper's V, every delta_plant"))
    for P, level, color, label in sets:
        with np.errstate(invalid="ignore"):
            Vv = np.einsum("ij,jk,ik->i", Y, P, Y).reshape(TH.shape)
        ax.contour(np.degrees(TH), THD, Vv, [level], colors=[color])
        ax.plot([], [], color=color, label=f"{label}: V <= {level:.4g}")
    ax.axvline(60, color="k", ls=":", lw=0.8, label="paper's 60 deg sector")
    ax.axvline(-60, color="k", ls=":", lw=0.8)
    ax.set_xlim(-90, 90)
    ax.set_ylim(-3, 3)
    if not sets:
        lines = ["no certified set to draw"]
        for key in ("paper", "robust_quadratic"):
            st = ev[key]["status"]
            if st == "not run":
                st = "not run (quick mode: not among its cases)" if quick else ev[key]["message"]
            lines.append(f"{labels[key]}: {st}")
        ax.text(0.5, 0.5, "\n".join(lines), transform=ax.transAxes, ha="center", va="center",
                fontsize=8.5, bbox={"facecolor": "white", "edgecolor": "0.6"})  # fmt: skip
    ax.set_xlabel("theta(0) [deg]")
    ax.set_ylabel("theta'(0) [rad/s]")
    ax.set_title("(b) certified sets at q = q' = 0, delta_plant in "
                 f"[{ev['box'][0]:g}, {ev['box'][1]:g}]")  # fmt: skip
    ax.legend(fontsize=7.5, loc="upper left", bbox_to_anchor=(0.0, -0.13), frameon=False)
    fig.tight_layout()
    return fig
