"""SOS V-s iteration (roa.search._vs_iteration) and roa.certify(..., degree=...).

Reference: the reversed-time Van der Pol oscillator (mu = 1, Chesi 2011; Topcu, Packard, Seiler
2008), whose region of attraction is bounded by its unstable limit cycle. The limit cycle's area is
computed here independently (scipy solve_ivp on the forward-time oscillator, one period, shoelace
formula): 13.72 (rtol 1e-11). Every certified set must lie inside it (soundness), and every state
sampled in a certified set must converge (solve_ivp).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import roa
from roa.cli import main
from roa.search._vs_iteration import vs_search
from roa.status import SosStatus, Verdict


@pytest.fixture(scope="module")
def vdp():
    return roa.load_system("vanderpol")


@pytest.fixture(scope="module")
def limit_cycle(vdp):
    sol = solve_ivp(lambda t, x: -vdp.f(x[None])[0], (0, 60), [2.0, 0.0], rtol=1e-11,
                    atol=1e-12, dense_output=True)  # fmt: skip
    X = sol.sol(np.linspace(40, 60, 200_001)).T
    i = np.where((X[:-1, 1] < 0) & (X[1:, 1] >= 0))[0]
    seg = X[i[0] : i[1] + 1]
    area = 0.5 * abs(seg[:, 0] @ np.roll(seg[:, 1], 1) - seg[:, 1] @ np.roll(seg[:, 0], 1))
    return seg, area


def _area(V, level, n=801, half=3.0):
    g = np.linspace(-half, half, n)
    G = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    return float(np.count_nonzero(V.value(G) <= level)) * (g[1] - g[0]) ** 2, G[V.value(G) <= level]


def test_limit_cycle_area_reference(limit_cycle):
    assert limit_cycle[1] == pytest.approx(13.72, abs=0.01)


def test_vs_rounds_never_lose_shape_level(vdp):
    res = vs_search(vdp, roa.default_lyapunov(vdp), degree=4, shape=np.eye(2), rounds=5)
    assert res.status is SosStatus.SOLVED
    b = np.array(res.betas)
    # round 0's gamma is the seed's SOS level (roa.search.sos_level: 2.30448) in units of the
    # seed's sampled level (the same 2.30448 for this V): 1
    assert res.rounds[0].gamma == pytest.approx(1.0, abs=1e-3)
    assert np.all(np.diff(b) > -1e-4 * b[:-1])  # the previous V stays feasible in each V step
    assert b[-1] > 1.3 * b[0]
    assert res.candidates[0].degree == 2  # round 0: the seed, rescaled to level 1
    assert all(c.degree == 4 for c in res.candidates[1:])


@pytest.mark.parametrize(
    "degree,min_share,rounds",
    [pytest.param(4, 0.0, 2, marks=pytest.mark.slow),
     pytest.param(4, 0.75, 10, marks=pytest.mark.slow),
     pytest.param(6, 0.9, 10, marks=pytest.mark.slow)],
)  # fmt: skip
def test_certified_degree_inside_limit_cycle(vdp, limit_cycle, degree, min_share, rounds):
    """Soundness (inside the true region, states converge) and the issue's target at degree 6."""
    from matplotlib.path import Path

    vs = roa.VsOptions(shape=np.eye(2), rounds=rounds)
    cert = roa.certify(vdp, degree=degree, vs=vs, check_above=1.001)
    assert cert.status is Verdict.CERTIFIED and cert.above.status is Verdict.REFUTED
    area, inside = _area(cert.V, cert.level)
    seg, lc_area = limit_cycle
    assert Path(seg).contains_points(inside).all()  # the certified set is inside the limit cycle
    assert min_share * lc_area <= area < lc_area
    # more than the quadratic benchmark's ellipse {x'Px <= 2.3045} (area pi rho / sqrt(det P))
    P = roa.default_lyapunov(vdp).P
    assert area > 1.1 * np.pi * 2.3045 / np.sqrt(np.linalg.det(P))
    pts = inside[np.random.default_rng(0).choice(len(inside), 20, replace=False)]
    for x0 in pts:
        end = solve_ivp(lambda t, x: vdp.f(x[None])[0], (0, 40), x0, rtol=1e-9, atol=1e-12).y[:, -1]
        assert np.linalg.norm(end) < 1e-3


def test_cli_degree_json_round_trips(tmp_path, capsys):
    code = main(["certify", "--system", "vanderpol", "--degree", "2", "--rounds", "2", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["status"] == "certified"
    assert out["vs_search"]["degree"] == 2 and len(out["vs_search"]["rounds"]) >= 2
    kind = out["candidate_kind"]
    assert kind["kind"] == "PolynomialLyapunov" and kind["degree"] == 2
    path = tmp_path / "V.json"
    path.write_text(
        json.dumps({"monomials": kind["monomials"], "coefficients": kind["coefficients"]})
    )
    code = main(["certify", "--system", "vanderpol", "--lyapunov", str(path), "--level",
                 str(out["level"]), "--json"])  # fmt: skip
    assert code == 0 and json.loads(capsys.readouterr().out)["status"] == "certified"


@pytest.mark.parametrize(
    "argv,needle",
    [
        (["--degree", "4", "--level", "1"], "drop --level"),
        (["--degree", "4", "--rounds", "0"], "--rounds must be in [1, 50]"),
        (["--degree", "4", "--budget", "0"], "--budget must be"),
    ],
)
def test_cli_degree_bad_input(argv, needle, capsys):
    assert main(["certify", "--system", "vanderpol", *argv]) == 2
    assert needle in capsys.readouterr().err


def test_degree_needs_quadratic_seed(vdp):
    V = roa.FunctionLyapunov(lambda x, xp: xp.log(1 + x[0] ** 2 + x[1] ** 2), [0.0, 0.0])
    with pytest.raises(roa.RoaInputError, match="quadratic seed"):
        roa.certify(vdp, V, degree=4)
    with pytest.raises(roa.RoaInputError, match="degree must be one of"):
        roa.certify(vdp, degree=5)


@pytest.mark.parametrize(
    "kw,needle",
    [
        ({"rounds": 0}, "VsOptions.rounds must be in [1, 50]"),
        ({"solver": "mosek"}, "VsOptions.solver must be"),
        (
            {"shape": [[1.0, 2.0], [2.0, 1.0]]},
            "VsOptions.shape must be symmetric positive definite",
        ),
        ({"tol": 0.0}, "VsOptions.tol must be in (0, 1)"),
        ({"validate": 21}, "VsOptions.validate must be in [1, 20]"),
        ({"budget": -1.0}, "VsOptions.budget must be"),
    ],
)
def test_vs_options_name_the_field(kw, needle):
    with pytest.raises(roa.RoaInputError) as err:
        roa.VsOptions(**kw)
    assert needle in str(err.value)


def test_saturated_field_is_refused_by_sos():
    """min/max/clip (saturation) cannot be recast into a polynomial: a status, not a crash."""
    sat = roa.System(
        "saturated",
        lambda t, x, xp: (x[1], -x[0] - xp.clip(x[1], -1.0, 1.0)),
        (0.0, 0.0),
        ("a", "b"),
    )
    res = vs_search(sat, roa.default_lyapunov(sat), degree=2, rounds=1)
    assert res.status is SosStatus.NOT_POLYNOMIAL and "saturation" in res.message


@pytest.mark.slow
def test_degrees_hybrid_row_matches_the_certify_case():
    """The degrees experiment's hybrid-coordinate row at degree 2 (ipc_paper.degrees._ipc_hybrid)
    certifies the certify experiment's quadratic V there (C9, results/certify/evidence.json) at the
    same level, refutes 1.001 x its sampled optimum, and its sector and box share are those of C9
    (computed there by other code: ipc_paper/certify_runs.py) within the box share's CI."""
    import dataclasses
    import json
    from pathlib import Path

    from ipc_paper import degrees

    root = Path(__file__).resolve().parents[2] / "results"
    c9 = json.loads((root / "certify" / "evidence.json").read_text())["ipc_hybrid_box"]
    p = dataclasses.asdict(degrees.DegreeParams()) | {"hybrid_degrees": (2,), "n_box": 20000}
    row = degrees._ipc_hybrid(p, root)["degrees"]["2"]
    assert row["status"] == "certified" and row["above"] == "refuted"
    assert row["level"] == pytest.approx(c9["below"]["level"], rel=1e-9)
    assert row["above_level"] > row["candidate"] > row["level"]
    phys = c9["physical"]
    assert row["sector_deg"] == pytest.approx(phys["sector_deg"], abs=0.01)
    lo, hi = row["box"]["ci95"]
    assert lo - 0.01 < phys["box"]["fraction"] < hi + 0.01


def test_a_spent_budget_stops_the_iteration_with_what_it_has(vdp):
    """A budget already spent starts no SDP: no candidate, status failed, and the message says
    why (the search stops with the rounds it completed, here none)."""
    res = vs_search(vdp, roa.default_lyapunov(vdp), degree=4, budget=1e-12)
    assert res.status is SosStatus.FAILED and res.candidates == []
    assert "time budget of 1e-12 s spent before round 0" in res.message
