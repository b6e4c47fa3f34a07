"""Trajectories overlaid on a basin map on request (#37 item 3): ``BasinResult.plot(trajectories=)``
and ``roa basin --plot --trajectories N``.

Each overlaid line is a run of roa.simulate from its start, drawn in the slice's two coordinates:
its data are compared with an independent scipy solve_ivp of the hand-written Van der Pol field
(the first point, and the status: a run that converges ends near the origin, one that diverges
leaves the box), and its colour with the status it ended in.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from matplotlib.colors import to_hex
from scipy.integrate import solve_ivp

import roa
from roa.cli import main
from roa.integration import _dopri as I  # noqa: N812
from roa.plotting._basin import MAX_TRAJECTORIES, TRAJECTORY_COLOURS, trajectory_starts


def vdp_field(t, x):
    return [-x[1], x[0] + (x[0] ** 2 - 1) * x[1]]


def escape(t, x):
    return np.hypot(*x) - 50.0


escape.terminal = True


@pytest.fixture(scope="module")
def vdp_basin():
    system = roa.load_system("vanderpol")
    grid = roa.grid_slice(system, ("x1", "x2"), [(-3, 3), (-3, 3)], (12, 12))
    return system, grid, roa.basin(system, grid, run=roa.RunOptions(n_jobs=1))


def test_starts_spread_over_the_slice(vdp_basin):
    system, grid, _ = vdp_basin
    for k in (1, 5, 16, 30):
        X = trajectory_starts(grid, k)
        assert X.shape == (k, 2) and len({tuple(x) for x in X}) == k
        assert np.all((X >= -3) & (X <= 3))
    X = trajectory_starts(grid, 16)  # a 4 x 4 sub-grid of cell centres
    np.testing.assert_allclose(np.unique(X[:, 0]), [-2.25, -0.75, 0.75, 2.25])
    # off the slice: the slice's fixed values
    ipc = roa.load_system("ipc")
    g4 = roa.grid_slice(ipc, ("theta", "theta_dot"), [(-1, 1), (-2, 2)], (5, 5),
                        fixed={"q": 0.3})  # fmt: skip
    X4 = trajectory_starts(g4, 4)
    assert np.all(X4[:, ipc.state_names.index("q")] == 0.3)


@pytest.mark.parametrize("k", [0, -1, MAX_TRAJECTORIES + 1, True, 2.5])
def test_bad_counts_are_refused(vdp_basin, k):
    _, grid, _ = vdp_basin
    with pytest.raises(roa.RoaInputError, match=r"trajectories must be an integer in \[1, 400\]"):
        trajectory_starts(grid, k)


def test_overlaid_runs_match_scipy_and_are_coloured_by_status(vdp_basin):
    import matplotlib.pyplot as plt

    system, grid, res = vdp_basin
    ax = res.plot(trajectories=9)
    starts = trajectory_starts(grid, 9)
    colours = {to_hex(c): k for k, c in TRAJECTORY_COLOURS.items()}
    paths = [ln for ln in ax.get_lines() if ln.get_marker() in ("None", None, "")]
    assert len(paths) == 9  # the centre's run is one point: it starts converged
    for line, x0 in zip(paths, starts, strict=True):
        x, y = line.get_xdata(), line.get_ydata()
        np.testing.assert_array_equal([x[0], y[0]], x0)
        ref = solve_ivp(vdp_field, (0, 100), x0, rtol=1e-10, atol=1e-12, method="DOP853",
                        events=escape)  # fmt: skip
        converges = np.hypot(*ref.y[:, -1]) < 1e-2
        kind = colours[to_hex(line.get_color())]
        assert kind == (I.CONVERGED if converges else I.DIVERGED), x0
        assert (np.hypot(x[-1], y[-1]) < 1e-2) == converges
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(lab.startswith("trajectories, converged:") for lab in labels)
    plt.close(ax.figure)
    # explicit starts
    ax = res.plot(trajectories=[[0.5, 0.5], [2.5, 2.5]])
    assert sum(ln.get_marker() in ("None", None, "") for ln in ax.get_lines()) == 2
    plt.close(ax.figure)


def test_cli_trajectories(tmp_path, capsys):
    png = tmp_path / "map.png"
    base = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "12x12",
            "--box", "x1=-3:3,x2=-3:3", "--jobs", "1"]  # fmt: skip
    assert main([*base, "--plot", str(png), "--trajectories", "9", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["trajectories_drawn"]["n"] == 9 == sum(doc["trajectories_drawn"]["counts"].values())
    assert doc["state_units"] == {"x1": "1", "x2": "1"}  # the system's units, in the JSON
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main([*base, "--trajectories", "9"]) == 2
    assert "use it with --slice and --plot" in capsys.readouterr().err
    assert main([*base, "--plot", str(png), "--trajectories", "401"]) == 2
    assert "--trajectories must be an integer in [1, 400]" in capsys.readouterr().err
