"""Docs and figures as a first-day user meets them (#37 item 6).

The site build itself is CI's ``sphinx-build -W`` (the pages were looked at in headless Chromium);
these tests keep what the build does not check: option names stay two hyphens, each default is
stated once (by the help text, every option with a default says it), the examples' tables hold the
JSON's numbers, the robust figure labels its box ends and explains an empty panel, and the
``plot()`` of a result survives a plain ``savefig`` with nothing cut and the legend off the curve.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import roa  # noqa: E402
from roa.cli import build_parser  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"


def test_cli_page_keeps_double_hyphens_and_states_defaults_once():
    conf = (DOCS / "conf.py").read_text()
    assert "smartquotes = False" in conf
    assert ":nodefault:" in (DOCS / "cli.rst").read_text()  # no second "Default: ..." line
    parser = build_parser()
    subs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    missing = [
        (name, a.option_strings)
        for name, sp in subs.choices.items()
        for a in sp._actions
        if a.default not in (None, False, [], argparse.SUPPRESS)
        and a.help
        and "default" not in a.help.lower()
    ]
    assert missing == []


def test_code_blocks_wrap_instead_of_clipping():
    conf = (DOCS / "conf.py").read_text()
    assert 'html_css_files = ["roa.css"]' in conf
    css = (DOCS / "_static" / "roa.css").read_text()
    assert "white-space: pre-wrap" in css


def _rows(name: str) -> dict[str, str]:
    sys.path.insert(0, str(DOCS / "_ext"))
    try:
        from roa_docs import rows_of
    finally:
        sys.path.remove(str(DOCS / "_ext"))
    return dict(rows_of(json.loads((DOCS / "examples" / f"{name}.json").read_text())))


def test_example_tables_hold_the_json_numbers():
    doc = json.loads((DOCS / "examples" / "vanderpol.json").read_text())
    rows = _rows("vanderpol")
    assert rows["certificate (interval, level from candidate)"] == "certified: 2.30217"
    assert rows["1.001 x the level found"] == "refuted"
    # the share, from the region's converged count over the slice's (an older JSON: computed)
    k = doc["basin_slice"]["regions"][1]["slice"]["converged"]
    m = doc["basin_slice"]["counts"]["converged"]
    (share,) = [v for key, v in rows.items() if key.startswith("share of")]
    assert share.startswith(f"{100 * k / m:.2f} % ({k} of {m}; 95 % CI")
    cart = _rows("cartpole_lqr")
    assert cart["certificate (interval, level from candidate)"].startswith("certified: 3.39")
    assert cart["V of A'P + PA = -I: certificate (interval, level from candidate)"].startswith(
        "certified: 0.0874"
    )
    assert sum(key.startswith("share of the slice") for key in cart) == 2
    assert sum(key.startswith("share of the box") for key in cart) == 2


def _quick_evidence() -> dict:
    """The robust experiment's evidence as a quick run leaves it (no certificate run)."""
    return {
        "box": [0.8, 1.25],
        "paper": {"status": "not run", "message": "not run (cases)"},
        "box_optimised": {"status": "inconclusive", "message": "V' is not negative definite"},
        "robust_quadratic": {"status": "not run", "message": "not run (cases)"},
        "curves": {"delta_plant": [0.8, 1.25], "paper": [2.13, 2.33],
                   "box_optimised": [8.69, None], "robust_quadratic": [3.91, 4.16]},
    }  # fmt: skip


def test_robust_figure_labels_box_ends_and_explains_an_empty_panel():
    from ipc_paper.robust_report import NO_LEVEL_Y, log_ticks, robust_figure

    assert log_ticks(0.8, 1.25) == [0.8, 1.0, 1.25]
    assert log_ticks(0.5, 2.0) == pytest.approx([0.5, 0.5**0.5, 1.0, 2**0.5, 2.0])
    fig = robust_figure(_quick_evidence(), quick=True)
    a, b = fig.axes[:2]
    fig.canvas.draw()
    assert [t.get_text() for t in a.get_xticklabels()] == ["0.8", "1", "1.25"]
    note = " ".join(t.get_text() for t in b.texts)
    assert "no certified set to draw" in note and "quick mode" in note
    # the "no level" marker sits in the empty band at the bottom, in axes coordinates
    (marks,) = [ln for ln in a.get_lines() if ln.get_marker() == "x"]
    assert marks.get_transform() == a.get_xaxis_transform()
    assert 0 < marks.get_ydata()[0] <= NO_LEVEL_Y + 0.1
    lo = a.get_ylim()[0]
    assert lo <= 2.13 / 2.0 * (1 + 1e-12)  # the band is below every drawn level
    y_band = a.transAxes.transform((0, NO_LEVEL_Y + 0.1))[1]
    assert a.transData.transform((1.0, 2.13))[1] > y_band
    plt.close(fig)


def _inside(fig, artist) -> bool:
    r = fig.canvas.get_renderer()
    box, page = artist.get_window_extent(r), fig.bbox
    return box.x0 >= page.x0 and box.y0 >= page.y0 and box.x1 <= page.x1 and box.y1 <= page.y1


def test_result_plots_survive_a_plain_savefig(tmp_path):
    system = roa.load_system("vanderpol")
    V = roa.default_lyapunov(system)
    search = roa.level_search(system, V, shape="level", method="sampled")
    ax = search.plot()
    ax.figure.savefig(tmp_path / "search.png")  # plain savefig: no bbox_inches="tight"
    assert _inside(ax.figure, ax.xaxis.label) and _inside(ax.figure, ax.yaxis.label)
    plt.close(ax.figure)
    cert = roa.certify(system, V, level=2.3)
    ax = cert.plot()
    ax.figure.savefig(tmp_path / "cert.png")
    fig = ax.figure
    legend = ax.get_legend()
    assert _inside(fig, ax.xaxis.label) and _inside(fig, legend)
    # the legend covers no point of the curve
    box = legend.get_window_extent(fig.canvas.get_renderer())
    (curve,) = [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 2]
    pts = ax.transData.transform(np.column_stack([curve.get_xdata(), curve.get_ydata()]))
    assert not np.any(
        (pts[:, 0] >= box.x0)
        & (pts[:, 0] <= box.x1)
        & (pts[:, 1] >= box.y0)
        & (pts[:, 1] <= box.y1)
    )
    assert ax.get_aspect() == 1.0  # x1 and x2 share their unit
    plt.close(fig)
