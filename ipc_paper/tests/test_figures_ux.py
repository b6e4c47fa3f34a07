"""Figures a reader takes in at a glance (#25): the basin map's legends hold the estimates only (no
swatch for points coloured by time, no caption repeating the legend, a short colourbar label), and
no figure has an empty panel."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import matplotlib
import numpy as np

matplotlib.use("Agg")

RESULTS = Path(__file__).resolve().parents[2] / "results"


def _labels(fig):
    legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes if ax.get_legend())]
    return [[t.get_text() for t in leg.get_texts()] for leg in legends]


def test_basin_map_legend_and_colourbar():
    import matplotlib.pyplot as plt

    from ipc_paper import system as ipc
    from ipc_paper.basins import regions, slice_map
    from roa.montecarlo._sampling import grid_slice

    system = ipc.closed_loop()
    g = grid_slice(system, ["theta", "theta_dot"], [(-1.5, 1.5), (-6.0, 6.0)], (6, 5),
                   fixed={"q": 0.0, "q_dot": 0.0})  # fmt: skip
    run = SimpleNamespace(code=np.zeros(g.n, np.int8), t_end=np.linspace(0.1, 5.0, g.n))
    regs, _ = regions(RESULTS)
    terminal = {"used": True, "level": 26.886, "label": "our certified optimised V: V <= 26.89"}
    fig = slice_map(system, g, run, regs, title="t", saturation=None, converge_tol=1e-3,
                    terminal=terminal)  # fmt: skip
    texts = [t for leg in _labels(fig) for t in leg]
    assert not any("converged grid points" in t or "runs stop on entering" in t for t in texts)
    panel_a, panel_b, strip = _labels(fig)[1], _labels(fig)[2], _labels(fig)[0]
    assert len(panel_a) == 4 and len(panel_b) <= 3 and len(strip) == 1
    colourbar = [ax for ax in fig.axes if ax.get_ylabel().startswith("time")]
    assert [ax.get_ylabel() for ax in colourbar] == ["time to reach the certified set [-]"]
    plt.close(fig)


def test_degrees_figure_has_no_empty_panel(tmp_path, monkeypatch):
    import roa.io
    from ipc_paper.degrees_report import figure

    saved = {}
    monkeypatch.setattr(roa.io, "atomic_savefig", lambda fig, path: saved.update(fig=fig))
    ev = json.loads((RESULTS / "degrees" / "evidence.json").read_text())
    figure(ev, tmp_path / "full.png")
    assert len(saved["fig"].axes) == 2
    ev["ipc"]["degrees"], ev["ipc_hybrid"] = {}, None  # quick mode: the IPC is not run
    figure(ev, tmp_path / "quick.png")
    (ax,) = saved["fig"].axes
    assert ax.get_title() == "Van der Pol: certified level sets by degree"
