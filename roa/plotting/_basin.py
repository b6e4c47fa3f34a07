"""Basin maps: statuses over a 2D slice, with region estimates drawn as contours.

A region is the level set ``V(coords(x)) = level`` of any Lyapunov candidate
(:class:`roa.lyapunov.Region`: quadratic, polynomial or any function), drawn by contouring V on a
fine grid of the slice; legends name a non-quadratic V's degree (:func:`kind_text`).

Converged points are coloured by their time to converge (a colormap with a colorbar) when the stop
times ``t_end`` are given, failures by status (solid colours). Region estimates are drawn with one
line style per kind (:data:`KIND_STYLES`: claimed dashed, sampled dotted, certified solid, refuted
and inconclusive thin grey dash-dot) and one colour family per kind, so a reader can tell a claim
from a proof in every figure. :func:`slice_figure` returns the matplotlib Figure (several panels,
legends below the axes, a shared strip) before :func:`save_figure` writes it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import BoundaryNorm, LinearSegmentedColormap, ListedColormap, Normalize
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from roa.integration import _dopri as I  # noqa: N812  (status codes, without numba)
from roa.io import atomic_savefig
from roa.lyapunov._regions import Region
from roa.model._system import System

if TYPE_CHECKING:
    from roa.montecarlo._sampling import GridSlice


#: Colour per status display index (step-size failures are drawn as undecided); converged points
#: are drawn with :data:`TIME_CMAP` instead when stop times are given.
STATUS_COLOURS = {
    I.CONVERGED: "#9fd89b",
    I.LEFT_DOMAIN: "#f08a24",
    I.DIVERGED: "#9e5fc0",
    I.UNDECIDED: "#8a8a8a",
    4: "#a6761d",  # display index of CONVERGED_ELSEWHERE
}
#: Plain words per status display index, for legends.
STATUS_WORDS = ("converged", "left the domain", "diverged", "undecided at t_final",
                "converged to another equilibrium")  # fmt: skip
#: Converged points by time to converge: light (fast) to dark green (slow), light enough that the
#: region lines stay visible.
TIME_CMAP = LinearSegmentedColormap.from_list(
    "time_to_converge", plt.get_cmap("YlGn")(np.linspace(0.06, 0.62, 256))
)
TIME_LABEL = "time to converge t [-] (normalised)"

#: Line style, width and colour family per region status (the kind of an estimate).
KIND_STYLES: dict[str, dict[str, Any]] = {
    "claimed": {"ls": (0, (6, 3)), "lw": 1.9, "colours": ("#d62728", "#ff7f0e", "#8c1a11", "#f781bf")},
    "sampled": {"ls": (0, (1.2, 1.6)), "lw": 2.3, "colours": ("#1f5fb4", "#17becf", "#08306b", "#6baed6")},
    "certified": {"ls": "-", "lw": 1.7, "colours": ("#000000", "#c51b7d", "#6a3d9a", "#b35806", "#01665e",
                                                   "#4d4d4d", "#8e0152")},
    "refuted": {"ls": (0, (5, 2, 1, 2)), "lw": 1.0, "colours": ("#7f7f7f",)},
    "inconclusive": {"ls": (0, (5, 2, 1, 2)), "lw": 1.0, "colours": ("#7f7f7f",)},
}  # fmt: skip
#: Words a legend uses for the kinds.
KIND_WORDS = {"claimed": "claimed (paper)", "sampled": "sampled (no proof)",
              "certified": "certified (proof)", "refuted": "refuted", "inconclusive": "inconclusive"}  # fmt: skip
#: Marker lines (e.g. the paper's claimed sector): claimed, so dashed, in a claimed colour.
LINE_STYLE: dict[str, Any] = {"color": "#8c1a11", "ls": (0, (3, 2)), "lw": 1.1}
MAX_LEGEND = 6
_UNITLESS = {"1", ""}


def unit_text(unit: str) -> str:
    """A unit for an axis label: dimensionless (``"1"``, ``"-"``) is written ``-``."""
    return "-" if unit in _UNITLESS else unit


def _label(system: System, i: int) -> str:
    unit = system.state_units[i] if i < len(system.state_units) else ""
    return f"{system.state_names[i]} [{unit_text(unit)}]"


#: Equal aspect only up to this ratio of the axes' spans (beyond, the map would be a thin strip).
MAX_EQUAL_ASPECT = 8.0


def shared_units(system: System, ia: int, ib: int) -> bool:
    """Whether slice axes ``ia`` and ``ib`` are declared with the same unit (both dimensionless
    ``"1"``/``"-"`` counts as the same; an undeclared or empty unit never does)."""
    units = system.state_units
    if max(ia, ib) >= len(units) or not units[ia] or not units[ib]:
        return False
    return unit_text(units[ia]) == unit_text(units[ib])


def set_equal_aspect(ax: Any, system: System, grid: GridSlice, extent: Sequence[float]) -> bool:
    """One unit is as long on both axes (``ax.set_aspect("equal")``) when the slice's axes share
    their unit (:func:`shared_units`) and their spans differ by at most
    :data:`MAX_EQUAL_ASPECT`; returns whether it was set."""
    ia, ib = grid.axes
    wx, wy = extent[1] - extent[0], extent[3] - extent[2]
    if not shared_units(system, ia, ib) or not (wx > 0 and wy > 0):
        return False
    if max(wx / wy, wy / wx) > MAX_EQUAL_ASPECT:
        return False
    ax.set_aspect("equal", adjustable="box")
    return True


def kind_text(region: Region) -> str:
    """What V a region is a level set of, in words: ``quadratic``, ``degree-4 polynomial``, or
    the candidate's class for any other V."""
    degree = region.degree
    if region.lyapunov.is_quadratic:
        return "quadratic"
    if degree is not None:
        return f"degree-{degree} polynomial"
    return type(region.lyapunov).__name__


def region_label(region: Region) -> str:
    """The legend text of a region: its plain label (``meta["label"]``, else its name), the
    kind of a non-quadratic V when the label does not say it, and the status when the line style
    alone does not say it (refuted, inconclusive)."""
    label = str(region.meta.get("label") or region.name)
    quadratic = region.lyapunov.is_quadratic
    if not quadratic and "degree" not in label and "polynomial" not in label:
        label += f" ({kind_text(region)} V)"
    if region.status in ("refuted", "inconclusive") and region.status not in label:
        label += f" [{region.status}]"
    return label


def region_colours(regions: Sequence[Region]) -> dict[str, str]:
    """A colour per region name, from its kind's family in the order given: pass the whole list
    once so that a region keeps its colour in every panel and figure."""
    out: dict[str, str] = {}
    rank: dict[str, int] = {}
    for r in regions:
        if r.name in out:
            continue
        fam = KIND_STYLES.get(r.status, KIND_STYLES["inconclusive"])["colours"]
        k = rank.get(r.status, 0)
        out[r.name] = fam[k % len(fam)]
        rank[r.status] = k + 1
    return out


def region_style(region: Region, colours: Mapping[str, str] | None = None) -> dict[str, Any]:
    """``color``, ``ls``, ``lw`` of a region's line (see :data:`KIND_STYLES`)."""
    kind = KIND_STYLES.get(region.status, KIND_STYLES["inconclusive"])
    colour = (colours or {}).get(region.name) or kind["colours"][0]
    return {"color": colour, "ls": kind["ls"], "lw": kind["lw"]}


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


def _display(code: np.ndarray) -> np.ndarray:
    shown = np.where(code == I.STEP_FAILURE, I.UNDECIDED, code)
    return np.where(code == I.CONVERGED_ELSEWHERE, 4, shown)


def _extent(grid: GridSlice) -> tuple[float, float, float, float]:
    dx = (grid.xs[-1] - grid.xs[0]) / (len(grid.xs) - 1) / 2
    dy = (grid.ys[-1] - grid.ys[0]) / (len(grid.ys) - 1) / 2
    return (grid.xs[0] - dx, grid.xs[-1] + dx, grid.ys[0] - dy, grid.ys[-1] + dy)


def draw_statuses(
    ax: Any,
    grid: GridSlice,
    code: np.ndarray,
    t_end: np.ndarray | None = None,
    *,
    t_max: float | None = None,
) -> tuple[Any, list[Any]]:
    """The slice's statuses as an image: converged points by time to converge (``t_end`` given)
    or in one colour, failures by status. Returns the time image (None without ``t_end``) and the
    legend handles of the statuses present (failures only when the time image is drawn)."""
    shown = _display(np.asarray(code)).reshape(grid.shape)
    extent = _extent(grid)
    counts = np.bincount(shown.ravel().astype(np.int64), minlength=5)
    n = shown.size
    cmap = ListedColormap([STATUS_COLOURS[c] for c in range(5)])
    norm = BoundaryNorm(np.arange(-0.5, 5.5), 5)
    if t_end is None:
        ax.imshow(shown, origin="lower", extent=extent, aspect="auto", cmap=cmap, norm=norm,
                  interpolation="nearest")  # fmt: skip
        handles = [Patch(color=STATUS_COLOURS[c], label=f"{STATUS_WORDS[c]} ({counts[c]} of {n})")
                   for c in range(5) if c == 0 or counts[c]]  # fmt: skip
        return None, handles
    conv = shown == I.CONVERGED
    fail = np.ma.masked_where(conv, shown)
    ax.imshow(fail, origin="lower", extent=extent, aspect="auto", cmap=cmap, norm=norm,
              interpolation="nearest")  # fmt: skip
    times = np.ma.masked_where(~conv, np.asarray(t_end, dtype=float).reshape(grid.shape))
    # the colours span the times present (from a whole number below the fastest run)
    top = t_max if t_max is not None else (float(times.max()) if conv.any() else 1.0)
    low = float(np.floor(times.min())) if conv.any() else 0.0
    low = low if low < top else 0.0
    image = ax.imshow(times, origin="lower", extent=extent, aspect="auto", cmap=TIME_CMAP,
                      norm=Normalize(low, max(top, low + 1e-9)), interpolation="nearest")  # fmt: skip
    handles = [Patch(color=STATUS_COLOURS[c], label=f"{STATUS_WORDS[c]} ({counts[c]} of {n})")
               for c in range(1, 5) if counts[c]]  # fmt: skip
    return image, handles


def _slice_points(grid: GridSlice, resolution: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    ia, ib = grid.axes
    xs = np.linspace(grid.xs[0], grid.xs[-1], resolution)
    ys = np.linspace(grid.ys[0], grid.ys[-1], resolution)
    XX, YY = np.meshgrid(xs, ys)
    pts = np.repeat(grid.base[None, :], XX.size, axis=0)
    pts[:, ia], pts[:, ib] = XX.ravel(), YY.ravel()
    return XX, YY, pts


def draw_regions(
    ax: Any,
    grid: GridSlice,
    regions: Sequence[Region],
    *,
    colours: Mapping[str, str] | None = None,
    contour_resolution: int = 401,
) -> list[Any]:
    """Each region's boundary ``V(coords(x)) = level`` (``region.form``, any V) on the slice
    (finer grid); returns the legend handles (a region that does not meet the slice says so)."""
    if not regions:
        return []
    colours = dict(region_colours(regions), **(colours or {}))
    XX, YY, pts = _slice_points(grid, contour_resolution)
    handles = []
    for region in regions:
        style = region_style(region, colours)
        with np.errstate(all="ignore"):
            form = region.form(pts).reshape(XX.shape)
        form = np.where(np.isfinite(form), form, 10 * region.level + 1)
        meets = bool((form <= region.level).any())
        if meets:
            ax.contour(XX, YY, form, levels=[region.level], colors=[style["color"]],
                       linestyles=[style["ls"]], linewidths=style["lw"])  # fmt: skip
        note = "" if meets else " (not on this slice)"
        handles.append(Line2D([], [], **style, label=region_label(region) + note))
    return handles


def regions_extent(
    grid: GridSlice, regions: Sequence[Region], *, resolution: int = 201, margin: float = 0.2
) -> tuple[float, float, float, float] | None:
    """``(x0, x1, y0, y1)``: the part of the slice the regions cover, widened by ``margin`` of
    its size on each side and clipped to the slice (None when no region meets the slice)."""
    XX, YY, pts = _slice_points(grid, resolution)
    inside = np.zeros(XX.shape, dtype=bool)
    for region in regions:
        with np.errstate(all="ignore"):
            inside |= (region.form(pts) <= region.level).reshape(XX.shape)
    if not inside.any():
        return None
    x0, x1 = float(XX[inside].min()), float(XX[inside].max())
    y0, y1 = float(YY[inside].min()), float(YY[inside].max())
    dx = margin * max(x1 - x0, (grid.xs[-1] - grid.xs[0]) / 50)
    dy = margin * max(y1 - y0, (grid.ys[-1] - grid.ys[0]) / 50)
    return (max(x0 - dx, grid.xs[0]), min(x1 + dx, grid.xs[-1]),
            max(y0 - dy, grid.ys[0]), min(y1 + dy, grid.ys[-1]))  # fmt: skip


def draw_lines(
    ax: Any, system: System, grid: GridSlice, lines: Sequence[tuple[str, float, str]]
) -> list[Any]:
    """Marker lines ``(state name, value, label)`` at a value of a slice axis; lines with the same
    label share one legend handle. Lines outside the slice are left out."""
    ia, ib = grid.axes
    handles, seen = [], set()
    for name, value, label in lines:
        i = system.state_names.index(name)
        if i not in (ia, ib):
            continue
        values = grid.xs if i == ia else grid.ys
        if not values[0] <= value <= values[-1]:
            continue
        (ax.axvline if i == ia else ax.axhline)(value, **LINE_STYLE)
        if label not in seen:
            handles.append(Line2D([], [], label=label, **LINE_STYLE))
            seen.add(label)
    return handles


#: Line colour of an overlaid trajectory per status display index (visible on the map's colours).
TRAJECTORY_COLOURS = {I.CONVERGED: "#0b3d0b", I.LEFT_DOMAIN: "#4d2600", I.DIVERGED: "#f5d000",
                      I.UNDECIDED: "#000000", 4: "#1f3a93"}  # fmt: skip
#: Most trajectories a map overlays.
MAX_TRAJECTORIES = 400


def trajectory_starts(grid: GridSlice, k: int) -> np.ndarray:
    """``k`` initial states spread over the slice: the cell centres of an ``m x m`` sub-grid
    (``m = ceil(sqrt(k))``) of the slice's ranges, ``k`` of them evenly by index; the states off
    the slice at the slice's fixed values. Shape ``(k, n)``."""
    from roa.errors import RoaInputError

    if isinstance(k, bool) or not isinstance(k, int | np.integer) or not 1 <= k <= MAX_TRAJECTORIES:
        raise RoaInputError(
            f"trajectories must be an integer in [1, {MAX_TRAJECTORIES}], got {k!r}"
        )
    m = int(np.ceil(np.sqrt(k)))
    ia, ib = grid.axes
    fr = (np.arange(m) + 0.5) / m
    xs = grid.xs[0] + fr * (grid.xs[-1] - grid.xs[0])
    ys = grid.ys[0] + fr * (grid.ys[-1] - grid.ys[0])
    XX, YY = np.meshgrid(xs, ys)
    pick = np.unique(np.linspace(0, m * m - 1, k).round().astype(int))
    pts = np.repeat(grid.base[None, :], len(pick), axis=0)
    pts[:, ia], pts[:, ib] = XX.ravel()[pick], YY.ravel()[pick]
    return pts


def draw_trajectories(ax: Any, system: System, grid: GridSlice, runs: Sequence[Any]) -> list[Any]:
    """Overlay simulated runs (:class:`roa.integration.Trajectory`) on the slice: each run's path
    in the slice's two coordinates (projected onto the slice when the system has more states),
    a dot at its start, coloured by how it ended; one legend handle per status present."""
    from roa.status import RunStatus

    ia, ib = grid.axes
    index = {RunStatus.CONVERGED: I.CONVERGED, RunStatus.LEFT_DOMAIN: I.LEFT_DOMAIN,
             RunStatus.DIVERGED: I.DIVERGED, RunStatus.CONVERGED_ELSEWHERE: 4}  # fmt: skip
    counts: dict[int, int] = {}
    for run in runs:
        c = index.get(run.status, I.UNDECIDED)
        counts[c] = counts.get(c, 0) + 1
        colour = TRAJECTORY_COLOURS[c]
        ax.plot(run.x[:, ia], run.x[:, ib], color=colour, lw=0.8, alpha=0.85)
        ax.plot(run.x[0, ia], run.x[0, ib], "o", color=colour, ms=2.5)
    where = " (projected onto the slice)" if system.n > 2 else ""
    return [Line2D([], [], color=TRAJECTORY_COLOURS[c], lw=0.8, marker="o", ms=2.5,
                   label=f"trajectories, {STATUS_WORDS[c]}: {counts[c]}{where}")
            for c in sorted(counts)]  # fmt: skip


def _fixed_text(system: System, grid: GridSlice, names: Sequence[str] | None = None) -> str:
    ia, ib = grid.axes
    names = names or system.state_names
    return ", ".join(f"{names[i]} = {grid.base[i]:g}" for i in range(system.n) if i not in (ia, ib))


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
    t_end: np.ndarray | None = None,
    colours: Mapping[str, str] | None = None,
    trajectories: Sequence[Any] = (),
) -> Any:
    """Draw the statuses of ``grid`` into ``ax`` with region boundaries and marker lines, and one
    legend below the axes (a colorbar beside it when ``t_end`` colours the converged points);
    ``trajectories`` (simulated runs) are overlaid (:func:`draw_trajectories`).

    ``lines`` are ``(state name, value, label)``: a line at that value of a slice axis (e.g. the
    paper's claimed sector theta = +-60 deg); lines with the same label share one legend entry.
    """
    ia, ib = grid.axes
    image, handles = draw_statuses(ax, grid, code, t_end)
    handles += draw_regions(ax, grid, regions, colours=colours,
                            contour_resolution=contour_resolution)  # fmt: skip
    handles += draw_lines(ax, system, grid, lines)
    handles += draw_trajectories(ax, system, grid, trajectories)
    x0, x1, y0, y1 = _extent(grid)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    set_equal_aspect(ax, system, grid, (x0, x1, y0, y1))
    ax.set_xlabel(_label(system, ia))
    ax.set_ylabel(_label(system, ib))
    fixed = _fixed_text(system, grid)
    ax.set_title(f"{title}\n({fixed})" if fixed else title, fontsize=10)
    if image is not None:
        ax.figure.colorbar(image, ax=ax, label=TIME_LABEL, fraction=0.05, pad=0.02)
    if handles:
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.13),
                  ncol=1 if len(handles) <= 4 else 2, fontsize=8, frameon=False)  # fmt: skip
    return ax


def slice_figure(
    system: System,
    grid: GridSlice,
    code: np.ndarray,
    *,
    panels: Sequence[tuple[str, Sequence[Region]]],
    t_end: np.ndarray | None = None,
    lines: Sequence[tuple[str, float, str]] = (),
    title: str = "",
    axis_labels: Sequence[str] | None = None,
    state_names: Sequence[str] | None = None,
    colours: Mapping[str, str] | None = None,
    time_label: str = TIME_LABEL,
    extra_handles: Sequence[Any] = (),
    contour_resolution: int = 301,
    panel_size: tuple[float, float] = (4.8, 3.7),
    zoom: Sequence[int] = (),
) -> Any:
    """A basin map with one panel per ``(subtitle, regions)`` of ``panels``, returned unsaved.

    Every panel shows the same statuses (converged points by time to converge when ``t_end`` is
    given, with one shared colorbar) and its own regions, with its legend below the axes; the
    failures, the marker ``lines`` and ``extra_handles`` share one strip at the bottom.
    ``axis_labels`` are the n state axis labels (default ``name [unit]``), ``state_names`` the
    names used in the title's fixed states. ``colours`` (see :func:`region_colours`) keep each
    region's colour across panels and figures. Panels whose index is in ``zoom`` show only the
    part of the slice their regions cover (:func:`regions_extent`), said in their title.
    """
    k = max(len(panels), 1)
    n_leg = max((len(regs) for _, regs in panels), default=0)
    leg_h = 0.22 * n_leg + (0.35 if n_leg else 0.0)
    w, h = panel_size
    fig = plt.figure(figsize=(w * k + 1.1, h + leg_h + 1.5), layout="constrained")
    axes = fig.subplots(1, k, squeeze=False)[0]
    labels = list(axis_labels) if axis_labels else [_label(system, i) for i in range(system.n)]
    all_regions = [r for _, regs in panels for r in regs]
    colours = dict(region_colours(all_regions), **(colours or {}))
    ia, ib = grid.axes
    image, strip = None, []
    for j, (ax, (subtitle, regs)) in enumerate(zip(axes, panels, strict=False)):
        image, fails = draw_statuses(ax, grid, code, t_end)
        handles = draw_regions(ax, grid, regs, colours=colours,
                               contour_resolution=contour_resolution)  # fmt: skip
        marks = draw_lines(ax, system, grid, lines)
        if j == 0:
            strip = fails + marks + list(extra_handles)
        x0, x1, y0, y1 = _extent(grid)
        box = regions_extent(grid, regs) if j in zoom else None
        if box is not None and (
            box[1] - box[0] < 0.7 * (x1 - x0) or box[3] - box[2] < 0.7 * (y1 - y0)
        ):
            x0, x1, y0, y1 = box
            subtitle += " (zoomed in)"
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        set_equal_aspect(ax, system, grid, (x0, x1, y0, y1))
        ax.set_xlabel(labels[ia])
        ax.set_ylabel(labels[ib])
        ax.set_title(subtitle, fontsize=10, loc="left")
        if handles:
            ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(-0.12, -0.15), ncol=1,
                      fontsize=8.5, frameon=False, borderaxespad=0.0, handlelength=3.2)  # fmt: skip
    if image is not None:
        fig.colorbar(image, ax=list(axes), label=time_label, fraction=0.04, pad=0.02, aspect=25)
    if strip:
        fig.legend(handles=strip, loc="outside lower center", ncol=min(len(strip), 3),
                   fontsize=8.5, frameon=False, handlelength=3.0)  # fmt: skip
    fixed = _fixed_text(system, grid, state_names)
    head = f"{title}\n(fixed: {fixed})" if fixed else title
    fig.suptitle(head, fontsize=11)
    return fig


def save_figure(fig: Any, path: str | Path) -> Path:
    """Write ``fig`` atomically and close it."""
    out = atomic_savefig(fig, path)
    plt.close(fig)
    return out


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
    t_end: np.ndarray | None = None,
    trajectories: Sequence[Any] = (),
) -> Path:
    """Heatmap of statuses over ``grid`` with region boundaries ``V(coords(x)) = level`` (any V),
    marker lines and overlaid ``trajectories``, saved to ``path`` (see :func:`draw_slice`)."""
    fig, ax = plt.subplots(figsize=(8.6, 6.0))
    draw_slice(ax, system, grid, code, regions=regions, lines=lines, title=title,
               contour_resolution=contour_resolution, t_end=t_end,
               trajectories=trajectories)  # fmt: skip
    fig.tight_layout()
    return save_figure(fig, path)
