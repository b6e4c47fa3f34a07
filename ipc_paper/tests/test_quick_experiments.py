"""Every committed experiment runs in quick mode, once, and its Figures are readable.

The configs run into one results directory, each after the ones it depends on; each leaves a
summary and a manifest, a second run is served from the cache. The Figures of the
basin maps and of the summary are inspected before they are saved (``save_figure`` is wrapped):
every legend has at most six entries, every axis label carries a unit in brackets, region kinds
keep one line style, certificates are drawn only on the loop they certify, and q has one unit.
"""

import re
import shutil
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import roa.plotting  # noqa: E402
from ipc_paper import (
    summary_figure as sf,  # noqa: E402
    system as ipc,  # noqa: E402
)
from ipc_paper.figures import IPC_LABELS  # noqa: E402
from roa.integration import _dopri as I  # noqa: E402, N812
from roa.lyapunov._regions import Region  # noqa: E402
from roa.montecarlo._sampling import grid_slice  # noqa: E402
from roa.plotting import _basin as pb  # noqa: E402
from roa.plotting._trajectories import state_labels  # noqa: E402
from roa.studies._experiment import list_experiments, load_config, run_experiment  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
UNIT = re.compile(r"\[[^\]]+\]")
BASIN_EXPERIMENTS = ("basin_q_theta", "basin_q_theta_saturated", "basin_theta_thetadot")
CONFIGS = list_experiments(ROOT / "experiments")
#: The slowest quick experiments run with ``-m slow`` (and in ``roa reproduce --quick``, the
#: README's main command); an experiment of the default suite that depends on one reads its
#: committed results. Their parts are tested in the default suite: the errata in test_symbolic,
#: the certificates in test_certify_*, the robust level in tests/certification/test_robust, the
#: robust basin in tests/montecarlo/test_robust_basin, Khalil's search in test_levelset and
#: tests/api/test_api; bound and figure2 run in quick mode in test_report.
SLOW_CONFIGS = frozenset(
    {"certify", "degrees", "robust", "errata", "basin_robust", "khalil", "bound", "figure2"}
)


def _legends(fig):
    out = list(fig.legends)
    for ax in fig.axes:
        if ax.get_legend() is not None:
            out.append(ax.get_legend())
    return out


def _texts(fig):
    return [t.get_text() for leg in _legends(fig) for t in leg.get_texts()]


def check_readable(fig):
    """At most six entries per legend, a unit in brackets on every axis label, no jargon."""
    for leg in _legends(fig):
        assert len(leg.get_texts()) <= 6, [t.get_text() for t in leg.get_texts()]
    labels = [lab for ax in fig.axes for lab in (ax.get_xlabel(), ax.get_ylabel()) if lab]
    assert labels, "a figure without axis labels"
    for lab in labels:
        assert UNIT.search(lab), f"axis label without a unit: {lab!r}"
    for text in _texts(fig):
        assert not re.search(r"\bours\b|Phi", text), text


class QuickRun:
    """The committed configs run in quick mode into one results directory, each at most once and
    after its ``depends``. A dependency in :data:`SLOW_CONFIGS` that was not run itself is read
    from the committed ``results/`` (copied). The Figures of the basin maps and of the summary
    are kept as ``save_figure`` receives them."""

    def __init__(self, results: Path) -> None:
        self.results = results
        self.summaries: dict[str, object] = {}  # name: summary, or the exception it raised
        self.figures: dict[str, list] = {}
        self.copied: set[str] = set()

    def run(self, name: str):
        if name not in self.summaries:
            config = ROOT / "experiments" / f"{name}.toml"
            for dep in load_config(config).get("depends", []):
                if dep in self.summaries or dep in self.copied:
                    continue
                if dep in SLOW_CONFIGS:
                    shutil.copytree(ROOT / "results" / dep, self.results / dep)
                    self.copied.add(dep)
                else:
                    self.run(dep)
            if name in self.copied:  # run now after all: the committed copy gives way
                shutil.rmtree(self.results / name)
                self.copied.discard(name)
            self.summaries[name] = self._run(name, config)
        summary = self.summaries[name]
        if isinstance(summary, Exception):
            raise summary
        return summary

    def _run(self, name: str, config: Path) -> object:
        def keep(fig, path):
            if name in (*BASIN_EXPERIMENTS, "summary"):
                self.figures.setdefault(name, []).append(fig)
            return real(fig, path)

        real = pb.save_figure
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(pb, "save_figure", keep)
            mp.setattr(roa.plotting, "save_figure", keep)  # the study imports the public name
            mp.setattr(sf, "save_figure", keep)
            try:
                return run_experiment(config, results=self.results, quick=True)
            except Exception as exc:  # raised again by every test that needs it
                return exc


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    return QuickRun(tmp_path_factory.mktemp("results-quick"))


@pytest.fixture(scope="module")
def experiment_figures(quick):
    for name in (*BASIN_EXPERIMENTS, "summary"):
        quick.run(name)
    return quick.figures


@pytest.mark.parametrize(
    "config",
    [pytest.param(p, marks=[pytest.mark.slow] if p.stem in SLOW_CONFIGS else []) for p in CONFIGS],
    ids=[p.stem for p in CONFIGS],
)
def test_experiment_runs_in_quick_mode(config, quick):
    summary = quick.run(config.stem)
    out = quick.results / config.stem
    assert (out / "summary.json").is_file() and (out / "manifest.json").is_file()
    for fig in summary.get("figures", []):
        assert (quick.results / fig.removeprefix("results/")).is_file(), fig
    again = run_experiment(config, results=quick.results, quick=True)
    assert again["cached"] is True


@pytest.mark.parametrize("name", (*BASIN_EXPERIMENTS, "summary"))
def test_experiment_figures_are_readable(experiment_figures, name):
    figs = experiment_figures.get(name)
    assert figs, f"{name} drew no figure"
    for fig in figs:
        check_readable(fig)


@pytest.mark.parametrize("name", BASIN_EXPERIMENTS)
def test_basin_maps_colour_time_and_say_where_the_basin_ends(experiment_figures, name):
    (fig,) = experiment_figures[name]
    title = fig._suptitle.get_text()
    assert "the basin is the whole slice" in title or "basin edge inside the slice" in title
    bars = [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel().startswith("time to ")]
    assert bars and all("[-]" in b for b in bars), "no colorbar of the time to converge"
    panels = [ax for ax in fig.axes if ax.get_legend() is not None]
    assert panels and all(len(ax.get_legend().get_texts()) <= 6 for ax in panels)


def test_the_saturated_loop_carries_only_its_own_certificate(experiment_figures):
    """The saturated map shows the certificate of the saturated loop (C11), never one of the loop
    without saturation."""
    (fig,) = experiment_figures["basin_q_theta_saturated"]
    title = fig._suptitle.get_text()
    assert "certified set" in title and "of the saturated loop" in title, title
    certified = [t for t in _texts(fig) if "certified" in t]
    assert certified and all("saturat" in t for t in certified), certified
    (unsat,) = experiment_figures["basin_q_theta"]
    assert [t for t in _texts(unsat) if "our certified" in t], (
        "unsaturated map lost its certificates"
    )


def _synthetic():
    system = ipc.closed_loop()
    grid = grid_slice(system, ["q", "theta"], [(-3.0, 3.0), (-1.0, 1.0)], (12, 10))
    rng = np.random.default_rng(0)
    code = np.where(rng.random(grid.n) < 0.2, I.LEFT_DOMAIN, I.CONVERGED).astype(np.int8)
    code[:3] = I.DIVERGED
    t_end = rng.uniform(0.0, 30.0, grid.n)
    P = np.diag([1.0, 1.0, 4.0, 1.0])
    regs = [Region(f"{s} set", P, lvl, s, None, {"label": f"a level set {lvl:g} [-]"})
            for s, lvl in (("claimed", 2.0), ("sampled", 1.5), ("certified", 1.0), ("refuted", 0.5))]  # fmt: skip
    return system, grid, code, t_end, regs


def test_slice_figure_on_synthetic_data():
    system, grid, code, t_end, regs = _synthetic()
    lines = [("theta", s * np.pi / 3, "paper's claimed sector") for s in (-1, 1)]
    fig = pb.slice_figure(system, grid, code, t_end=t_end, panels=[("(a)", regs[:2]), ("(b)", regs[2:])],
                          lines=lines, title="synthetic", zoom=[0])  # fmt: skip
    check_readable(fig)
    texts = _texts(fig)
    assert any(t.startswith("left the domain") for t in texts)
    assert any(t.startswith("diverged") for t in texts)
    assert any("[refuted]" in t for t in texts), "a refuted level must say so"
    plt.close(fig)
    # the one-axis drawing of `roa basin --plot` and BasinResult.plot keeps working
    fig, ax = plt.subplots()
    pb.draw_slice(ax, system, grid, code, regions=regs, t_end=t_end)
    check_readable(fig)
    plt.close(fig)


def test_kinds_have_one_line_style_each():
    *_, regs = _synthetic()
    style = {r.status: pb.region_style(r) for r in regs}
    assert style["claimed"]["ls"] != style["sampled"]["ls"] != style["certified"]["ls"]
    assert style["certified"]["ls"] == "-"
    assert style["refuted"]["ls"] != style["certified"]["ls"]
    assert style["refuted"]["lw"] < style["certified"]["lw"]
    colours = pb.region_colours(regs + regs)
    assert len(set(colours.values())) == len(regs)


def test_summary_figure_on_synthetic_rows():
    rows = [
        {"label": "paper's ball", "kind": "claimed", "sector_deg": 25.9, "box_share": 0.3},
        {"label": "our sampled level", "kind": "sampled", "sector_deg": 24.6, "box_share": 0.27},
        {"label": "our certified V", "kind": "certified", "sector_deg": 56.5, "box_share": 0.87},
        {"label": "a refuted level", "kind": "refuted", "sector_deg": 60.0, "box_share": 0.9},
        {"label": "empirical", "kind": "empirical", "sector_deg": None, "box_share": 1.0,
         "box_share_ci95": [0.99, 1.0]},
    ]  # fmt: skip
    fig = sf.summary_figure(rows, title="synthetic")
    check_readable(fig)
    plt.close(fig)


def test_q_has_one_unit_everywhere():
    system = ipc.closed_loop()
    assert IPC_LABELS[0] == "q [-]"
    assert state_labels(system)[0] == "q [-]"
    assert pb._label(system, 0) == "q [-]"
