"""Basin maps: statuses over a 2D slice, with every region estimate drawn as a contour."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from roa.io import atomic_savefig
from roa.montecarlo import integrator as I  # noqa: N812
from roa.montecarlo.sampling import GridSlice
from roa.regions import Region
from roa.system import System

#: Colour per status code (step-size failures are drawn as undecided).
STATUS_COLOURS = {
    I.CONVERGED: "#9fd89b",
    I.LEFT_DOMAIN: "#f4a259",
    I.DIVERGED: "#b07cc6",
    I.UNDECIDED: "#9a9a9a",
    4: "#3b8bd0",  # display index of CONVERGED_ELSEWHERE
}
REGION_COLOURS = ("#d62728", "#1f77b4", "#000000", "#17becf", "#ff7f0e", "#8c564b", "#e377c2",
                  "#2ca02c", "#7f7f7f", "#bcbd22")  # fmt: skip
REGION_STYLES = ("-", "--", "-.", ":")


def _label(system: System, i: int) -> str:
    unit = system.state_units[i] if i < len(system.state_units) else ""
    return f"{system.state_names[i]} [{unit}]" if unit else system.state_names[i]


def slice_containment(grid: GridSlice, code: np.ndarray, region: Region) -> dict[str, Any]:
    """Among the slice's grid points inside ``region``: how many, how many converged, all of them?"""
    inside = region.contains(grid.points(0, grid.n))
    k = int(inside.sum())
    conv = int(np.sum(code[inside] == I.CONVERGED))
    return {
        "region": region.name,
        "status": region.status,
        "points_in_region": k,
        "converged": conv,
        "all_converged": (conv == k) if k else None,
    }


def plot_slice(
    system: System,
    grid: GridSlice,
    code: np.ndarray,
    path: str | Path,
    *,
    regions: Sequence[Region] = (),
    lines: Sequence[tuple[str, float, str]] = (),
    title: str = "",
    contour_resolution: int = 401,
) -> Path:
    """Heatmap of statuses over ``grid`` with region boundaries ``form(x) = level`` and marker lines,
    saved to ``path`` (see :func:`draw_slice`)."""
    fig, ax = plt.subplots(figsize=(8.6, 6.0))
    draw_slice(ax, system, grid, code, regions=regions, lines=lines, title=title,
               contour_resolution=contour_resolution)  # fmt: skip
    fig.tight_layout()
    out = atomic_savefig(fig, path)
    plt.close(fig)
    return out


def draw_slice(
    ax: Any,
    system: System,
    grid: GridSlice,
    code: np.ndarray,
    *,
    regions: Sequence[Region] = (),
    lines: Sequence[tuple[str, float, str]] = (),
    title: str = "",
    contour_resolution: int = 401,
) -> Any:
    """Draw the statuses of ``grid`` into ``ax`` with region boundaries and marker lines.

    ``lines`` are ``(state name, value, label)``: a line at that value of a slice axis (e.g. the
    paper's claimed sector theta = +-60 deg); lines with the same label share one legend entry.
    """
    ia, ib = grid.axes
    shown = np.where(code == I.STEP_FAILURE, I.UNDECIDED, code)
    shown = np.where(code == I.CONVERGED_ELSEWHERE, 4, shown).reshape(grid.shape)
    cmap = ListedColormap([STATUS_COLOURS[c] for c in range(5)])
    norm = BoundaryNorm(np.arange(-0.5, 5.5), 5)
    dx = (grid.xs[-1] - grid.xs[0]) / (len(grid.xs) - 1) / 2
    dy = (grid.ys[-1] - grid.ys[0]) / (len(grid.ys) - 1) / 2
    extent = (grid.xs[0] - dx, grid.xs[-1] + dx, grid.ys[0] - dy, grid.ys[-1] + dy)
    ax.imshow(shown, origin="lower", extent=extent, aspect="auto", cmap=cmap, norm=norm,
              interpolation="nearest")  # fmt: skip
    counts = np.bincount(shown.ravel().astype(np.int64), minlength=5)
    handles: list[Any] = [
        Patch(color=STATUS_COLOURS[c], label=f"{I.STATUS_NAMES[c]} ({counts[c]} of {code.size})")
        for c in range(5)
        if c < 4 or counts[c]
    ]
    # region boundaries on a finer grid of the same slice
    xs = np.linspace(grid.xs[0], grid.xs[-1], contour_resolution)
    ys = np.linspace(grid.ys[0], grid.ys[-1], contour_resolution)
    XX, YY = np.meshgrid(xs, ys)
    pts = np.repeat(grid.base[None, :], XX.size, axis=0)
    pts[:, ia], pts[:, ib] = XX.ravel(), YY.ravel()
    for k, region in enumerate(regions):
        colour = REGION_COLOURS[k % len(REGION_COLOURS)]
        style = REGION_STYLES[(k // len(REGION_COLOURS) + k) % len(REGION_STYLES)]
        with np.errstate(all="ignore"):
            form = region.form(pts).reshape(XX.shape)
        form = np.where(np.isfinite(form), form, 10 * region.level + 1)
        meets = bool((form <= region.level).any())
        if meets:
            ax.contour(XX, YY, form, levels=[region.level], colors=[colour], linestyles=[style],
                       linewidths=1.8)  # fmt: skip
        note = "" if meets else " (does not meet this slice)"
        handles.append(Line2D([], [], color=colour, ls=style, lw=1.8,
                              label=f"{region.name} [{region.status}]{note}"))  # fmt: skip
    seen: set[str] = set()
    for name, value, label in lines:
        i = system.state_names.index(name)
        if i not in (ia, ib):
            continue
        kw: dict[str, Any] = {"color": "#444444", "ls": (0, (6, 3)), "lw": 1.3}
        (ax.axvline if i == ia else ax.axhline)(value, **kw)
        if label not in seen:
            handles.append(Line2D([], [], label=label, **kw))
            seen.add(label)
    ax.set_xlabel(_label(system, ia))
    ax.set_ylabel(_label(system, ib))
    fixed = ", ".join(
        f"{system.state_names[i]} = {grid.base[i]:g}" for i in range(system.n) if i not in (ia, ib)
    )
    ax.set_title(f"{title}\n({fixed})" if fixed else title, fontsize=10)
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.11), ncol=2,
              fontsize=8, frameon=False)  # fmt: skip
    return ax
