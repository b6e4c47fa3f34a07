"""Figures of a robust basin (:mod:`roa.montecarlo._robust_basin`): two maps of one 2-D slice.

* left, the **converged share**: per initial state, the share of the sampled parameter values from
  which it converges (one colour per possible share, ``0, 1/m, ..., 1``);
* right, the **worst-case map**: converged for every sampled parameter value, for some, for none.

Both panels draw the robust certified set (the run's terminal set, proved for every parameter of
the box) and the regions given to the run (e.g. ``--lyapunov-level``, validated for the box), in
the line styles of :mod:`roa.plotting._basin` (certified solid, refuted grey dash-dot), and one
legend below names every estimate and every category with its count.
"""

from __future__ import annotations

from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from roa.lyapunov._regions import Region
from roa.model._parameters import ParameterBox
from roa.plotting._basin import (
    _extent,
    _fixed_text,
    _label,
    draw_regions,
    save_figure,
    set_equal_aspect,
)

__all__ = ["robust_figure", "save_figure", "terminal_region", "WORST_COLOURS"]

#: Colours of the worst-case map: converged for every / some / none of the sampled values.
WORST_COLOURS = ("#5cb85c", "#f0c419", "#7b3294")
WORST_WORDS = ("converged for every sampled parameter value",
               "converged for some sampled parameter values only",
               "converged for none of the sampled parameter values")  # fmt: skip


def terminal_region(result: Any) -> Region | None:
    """The run's terminal set as a region to draw (a quadratic V; None without one or for a
    polynomial terminal set, which is named in the legend instead)."""
    from roa.integration._terminal import coords_map
    from roa.lyapunov import QuadraticLyapunov

    T = result.terminal
    if T is None or not T.quadratic:
        return None
    V = QuadraticLyapunov(np.asarray(T.P), np.asarray(T.center))
    label = (f"robust certified set V <= {T.level:.5g} (every parameter of the box; "
             "terminal set)")  # fmt: skip
    return Region.from_lyapunov(f"terminal {T.name}", V, float(T.level), "certified",
                                coords_map(result.system, T.coords), {"label": label})  # fmt: skip


def robust_figure(result: Any, *, title: str | None = None) -> Any:
    """The converged-share map and the worst-case map of ``result`` (a
    :class:`~roa.montecarlo.RobustBasinResult` on a grid slice), returned unsaved."""
    system, grid = result.system, result.sampler
    m, n = len(result.samples), result.n
    count = result.converged_count.reshape(grid.shape)
    regions = list(result.regions)
    T = terminal_region(result)
    if T is not None:
        regions.insert(0, T)
    fig = plt.figure(figsize=(12.2, 6.4 + 0.22 * len(regions)), layout="constrained")
    ax_share, ax_worst = fig.subplots(1, 2)
    extent = _extent(grid)
    ia, ib = grid.axes

    cmap = ListedColormap(plt.get_cmap("RdYlGn")(np.linspace(0.05, 0.9, m + 1)))
    norm = BoundaryNorm(np.arange(-0.5, m + 1.5), m + 1)
    image = ax_share.imshow(count, origin="lower", extent=extent, aspect="auto", cmap=cmap,
                            norm=norm, interpolation="nearest")  # fmt: skip
    bar = fig.colorbar(image, ax=ax_share, fraction=0.05, pad=0.02)
    ticks = sorted({0, m // 2, m} | ({m // 4, 3 * m // 4} if m >= 8 else set(range(m + 1))))
    bar.set_ticks(ticks)
    bar.set_ticklabels([f"{j}/{m}" for j in ticks])
    bar.set_label(f"converged share of the {m} sampled parameter values [-]")

    worst = np.where(count == m, 0, np.where(count > 0, 1, 2))
    ax_worst.imshow(worst, origin="lower", extent=extent, aspect="auto",
                    cmap=ListedColormap(WORST_COLOURS), norm=BoundaryNorm([-0.5, 0.5, 1.5, 2.5], 3),
                    interpolation="nearest")  # fmt: skip
    tally = np.bincount(worst.ravel(), minlength=3)
    handles: list[Any] = [Patch(color=c, label=f"{w} ({k} of {n})")
                          for c, w, k in zip(WORST_COLOURS, WORST_WORDS, tally, strict=True)]  # fmt: skip
    for ax in (ax_share, ax_worst):
        lines = draw_regions(ax, grid, regions)
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        set_equal_aspect(ax, system, grid, extent)
        ax.set_xlabel(_label(system, ia))
        ax.set_ylabel(_label(system, ib))
    handles += lines
    if result.terminal is not None and T is None:
        handles.append(Line2D([], [], color="k", label=f"terminal set {result.terminal.name} "
                              "(polynomial V; used, not drawn)"))  # fmt: skip
    ax_share.set_title("converged share over the sampled parameter values", fontsize=10,
                       loc="left")  # fmt: skip
    ax_worst.set_title(f"worst case over the {m} sampled parameter values", fontsize=10,
                       loc="left")  # fmt: skip
    fig.legend(handles=handles, loc="outside lower center", ncol=1, fontsize=8.5, frameon=False,
               handlelength=3.0)  # fmt: skip
    box = ParameterBox.of(system).describe()
    kinds = {k: sum(s.kind == k for s in result.samples) for k in ("vertex", "random")}
    head = title or f"robust basin of {system.name}"
    head += (f"\nparameters {box}: nominal, {kinds['vertex']} vertices, {kinds['random']} "
             f"seeded uniform samples (seed {result.param_seed}); no claim between samples")  # fmt: skip
    fixed = _fixed_text(system, grid)
    fig.suptitle(head + (f"\n(fixed: {fixed})" if fixed else ""), fontsize=10.5)
    return fig
