"""How much of the basin is certified (issue 37, item 3): the share of converged points inside
each certified region, with a Clopper-Pearson interval, over a slice or a sampled box."""

from __future__ import annotations

import json

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
from scipy import stats

import roa
from roa.cli import main
from roa.integration import _integrator as I  # noqa: N812
from roa.lyapunov._regions import Region
from roa.montecarlo._certified_share import clopper_pearson
from roa.plotting._basin import shared_units

P = np.array([[1.5, -0.5], [-0.5, 1.0]])
LEVEL = 2.30  # certified for Van der Pol (README)
ELLIPSE_AREA = np.pi * LEVEL / np.sqrt(np.linalg.det(P))  # area of {x'Px <= c}: pi c / sqrt(det P)


@pytest.mark.parametrize("k,m", [(0, 10), (10, 10), (3, 10), (1, 1), (0, 1), (47, 100),
                                 (2542, 5400), (1, 200000), (199999, 200000)])  # fmt: skip
def test_clopper_pearson_matches_scipy_binomtest(k, m):
    ci = stats.binomtest(k, m).proportion_ci(confidence_level=0.95, method="exact")
    lo, hi = clopper_pearson(k, m)
    assert lo == pytest.approx(ci.low, rel=1e-9, abs=1e-15)
    assert hi == pytest.approx(ci.high, rel=1e-9, abs=1e-15)


def test_clopper_pearson_edges():
    assert clopper_pearson(0, 0) == (0.0, 1.0)
    # k = 0: the upper end solves (1 - p)^m = alpha / 2
    assert clopper_pearson(0, 20)[1] == pytest.approx(1 - 0.025 ** (1 / 20), rel=1e-12)
    with pytest.raises(ValueError):
        clopper_pearson(5, 3)


def test_box_share_counts_independently_and_estimates_the_area_ratio():
    """A certified set lies in the basin, so every sample inside it converged: the share's
    numerator is the count of samples with x'Px <= c, recomputed here; over uniform samples of
    [-3, 3]^2 that count over n estimates the ellipse's area over 36 (binomial)."""
    system = roa.load_system("vanderpol")
    region = Region("V <= 2.3", P, LEVEL, "certified")
    sampler = roa.box_sample(system, [(-3, 3), (-3, 3)], 3000, seed=4)
    res = roa.basin(system, sampler, run=roa.RunOptions(n_jobs=1), regions=[region])
    (entry,) = res.certified_shares
    X = sampler.points(0, sampler.n)
    inside = np.einsum("ij,jk,ik->i", X, P, X) <= LEVEL
    conv = res.code == I.CONVERGED
    assert np.all(conv[inside])  # the certificate's claim, seen by simulation
    assert entry["over"] == "box" and entry["status"] == "certified"
    assert entry["converged"] == int(conv.sum()) == res.counts["converged"]
    assert entry["converged_in_region"] == int(inside.sum())
    assert entry["share"] == pytest.approx(inside.sum() / conv.sum())
    ci = stats.binomtest(int(inside.sum()), int(conv.sum())).proportion_ci(method="exact")
    assert entry["ci95"] == pytest.approx([ci.low, ci.high], rel=1e-9)
    # the in-region count over n is binomial with p = area ratio: inside its 99.9 % interval
    p = ELLIPSE_AREA / 36.0
    lo, hi = stats.binom.interval(0.999, sampler.n, p)
    assert lo <= inside.sum() <= hi
    assert res.to_dict()["certified_share"][0] == entry


def test_slice_share_and_terminal_set(tmp_path):
    system = roa.load_system("vanderpol")
    cert = roa.certify(system, level=LEVEL)
    assert cert.certified
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(cert.to_dict()))
    grid = roa.grid_slice(system, ("x1", "x2"), [(-3, 3), (-3, 3)], (41, 41))
    region = Region("V <= 2.3", P, LEVEL, "certified")
    res = roa.basin(system, grid, run=roa.RunOptions(n_jobs=1), regions=[region],
                    terminal=str(path))  # fmt: skip
    ours, term = res.certified_shares
    X = grid.points(0, grid.n)
    conv = res.code == I.CONVERGED
    q = np.einsum("ij,jk,ik->i", X, P, X)
    assert ours["over"] == "slice"
    assert ours["converged_in_region"] == int((conv & (q <= LEVEL)).sum())
    # the terminal set is the same set, with its membership margin V <= level (1 - 1e-9)
    assert term["region"].startswith("terminal set")
    assert term["converged_in_region"] == int((conv & (q <= LEVEL * (1 - 1e-9))).sum())
    assert term["converged"] == ours["converged"] == res.counts["converged"]


def test_cli_prints_one_line_per_region_and_json_field(capsys, tmp_path):
    args = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "30x30", "--box",
            "x1=-3:3,x2=-3:3", "--lyapunov-level", "2.30", "--jobs", "1"]  # fmt: skip
    assert main([*args, "--plot", str(tmp_path / "m.png")]) == 0
    out = capsys.readouterr().out
    line = [ln for ln in out.splitlines() if "of the converged points of the slice" in ln]
    assert len(line) == 1 and "[certified]" in line[0] and "Clopper-Pearson" in line[0]
    assert main([*args, "--json"]) == 0  # no --plot needed any more
    data = json.loads(capsys.readouterr().out)
    (entry,) = data["certified_share"]
    assert 0 < entry["ci95"][0] <= entry["share"] <= entry["ci95"][1] < 1
    samples = ["basin", "--system", "vanderpol", "--samples", "500", "--box", "x1=-3:3,x2=-3:3",
               "--lyapunov-level", "2.30", "--jobs", "1"]  # fmt: skip
    assert main(samples) == 0
    assert "of the converged points of the box (uniform samples)" in capsys.readouterr().out


def test_equal_aspect_where_axes_share_units(tmp_path):
    import matplotlib.pyplot as plt

    vdp = roa.load_system("examples/vanderpol_system.py:SYSTEM")  # units "1", "1"
    assert shared_units(vdp, 0, 1)
    ipc = roa.load_system("ipc")
    names = ipc.state_names
    assert not shared_units(ipc, names.index("theta"), names.index("theta_dot"))
    grid = roa.grid_slice(vdp, ("x1", "x2"), [(-3, 3), (-2, 2)], (12, 12))
    res = roa.basin(vdp, grid, run=roa.RunOptions(n_jobs=1))
    ax = res.plot()
    assert ax.get_aspect() == 1.0
    plt.close(ax.figure)
    g2 = roa.grid_slice(ipc, ("theta", "theta_dot"), [(-1, 1), (-2, 2)], (6, 6))
    ax2 = roa.basin(ipc, g2, run=roa.RunOptions(n_jobs=1)).plot()
    assert ax2.get_aspect() == "auto"
    plt.close(ax2.figure)


def test_robust_basin_share_over_the_worst_case():
    system = roa.load_system("vanderpol").with_ranges(mu=(0.8, 1.2))
    region = Region("V <= 1.5", P, 1.5, "certified")
    grid = roa.grid_slice(system, ("x1", "x2"), [(-3, 3), (-3, 3)], (20, 20))
    res = roa.basin(system, grid, param_samples=0, run=roa.RunOptions(n_jobs=1), regions=[region])
    (entry,) = res.to_dict()["certified_share"]
    X = grid.points(0, grid.n)
    inside = np.einsum("ij,jk,ik->i", X, P, X) <= 1.5
    assert entry["converged"] == int(res.worst_case.sum())
    assert entry["converged_in_region"] == int((res.worst_case & inside).sum())
    for per in res.to_dict()["per_parameter"]:
        assert per["certified_share"][0]["converged"] == per["counts"]["converged"]
