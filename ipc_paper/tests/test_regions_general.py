"""Regions, basin overlays and terminal sets of any V, not only quadratic (issue 10, item 1).

Van der Pol (mu = 1) with the degree-4 V found by ``roa certify --system vanderpol --degree 4``
(V-s iteration, 3 rounds; certified there at 0.999): membership agrees with a direct evaluation of
the polynomial, a quadratic V written as a polynomial gives the region of its matrix, the CLI draws
the level set of a ``roa certify --json`` file, and that certificate is a terminal set that leaves
every status unchanged (in the numba kernels and the numpy integrator alike, bit for bit).
"""

from __future__ import annotations

import dataclasses
import json
import pickle

import numpy as np
import pytest

import roa
from ipc_paper import system as ipc
from roa.cli import main
from roa.errors import RoaInputError
from roa.integration import _integrator as I  # noqa: N812
from roa.integration._terminal import TerminalSet
from roa.lyapunov import PolynomialLyapunov
from roa.lyapunov._regions import Region
from roa.montecarlo._certified_set import terminal_from_certificate
from roa.montecarlo._engine import run_basin
from roa.montecarlo._sampling import grid_slice, region_sample
from roa.plotting._basin import region_label
from roa.search._rays import component_candidates
from roa.status import StopRules
from roa.systems.vanderpol import P_BENCHMARK, vanderpol

#: The degree-4 V of `roa certify --system vanderpol --degree 4 --rounds 3 --json` (candidate_kind).
MONOMIALS = [[4, 0], [3, 1], [2, 2], [2, 0], [1, 3], [1, 1], [0, 4], [0, 2]]
COEFFICIENTS = [0.018184637389887022, 0.03452644838715377, 0.13278653215207373,
                0.2755939083219942, -0.07916112114853094, -0.29419576130124236,
                0.02431654867586516, 0.18415583835923632]  # fmt: skip
LEVEL = 0.99  # certified (the V-s search certified 0.999)
RULES = StopRules(t_final=30.0)


def _V() -> PolynomialLyapunov:
    return PolynomialLyapunov(MONOMIALS, COEFFICIENTS, [0.0, 0.0], "V-s degree 4")


def _direct(x: np.ndarray) -> np.ndarray:
    """The polynomial evaluated term by term, independently of PolynomialLyapunov."""
    out = np.zeros(x.shape[0])
    for (a, b), c in zip(MONOMIALS, COEFFICIENTS, strict=True):
        out += c * x[:, 0] ** a * x[:, 1] ** b
    return out


@pytest.fixture(scope="module")
def certificate() -> dict:
    """What `roa certify --json` writes for the degree-4 V at LEVEL (interval validation)."""
    cert = roa.certify(vanderpol(), _V(), level=LEVEL, method="interval")
    assert cert.certified
    return json.loads(roa.io.to_json(cert.to_dict()))


def test_polynomial_region_membership_agrees_with_direct_evaluation():
    X = np.random.default_rng(3).uniform(-3, 3, (20000, 2))
    region = Region.from_lyapunov("V4", _V(), LEVEL, "certified")
    assert region.P is None and region.degree == 4
    direct = _direct(X)
    np.testing.assert_allclose(region.form(X), direct, rtol=1e-12, atol=1e-12)
    clear = np.abs(direct - LEVEL) > 1e-9
    np.testing.assert_array_equal(region.contains(X)[clear], (direct <= LEVEL)[clear])
    assert 0.1 < region.contains(X).mean() < 0.5
    # coordinates: V(coords(x)), inf where the map is undefined
    shift = np.array([0.5, -0.25])

    def coords(x: np.ndarray) -> np.ndarray:
        y = np.asarray(x, dtype=float) - shift
        return np.where((x[..., :1] > 2.0), np.inf, y)

    moved = Region("moved", _V(), LEVEL, "sampled", coords)  # a Lyapunov as the second argument
    f = moved.form(X)
    far = X[:, 0] > 2.0
    assert np.isinf(f[far]).all() and not moved.contains(X[far]).any()
    np.testing.assert_allclose(f[~far], _direct(X[~far] - shift), rtol=1e-12, atol=1e-12)
    # the legend names the degree; JSON round trip
    assert "degree-4 polynomial" in region_label(region)
    back = Region.from_json(json.loads(json.dumps(region.to_json())))
    assert back.to_json()["V"]["coefficients"] == COEFFICIENTS
    np.testing.assert_array_equal(back.contains(X), region.contains(X))
    with pytest.raises(RoaInputError, match="non-quadratic"):
        region_sample(region, 10, seed=0)


def test_quadratic_as_polynomial_gives_the_matrix_region():
    P = P_BENCHMARK
    V = PolynomialLyapunov([[2, 0], [1, 1], [0, 2]], [P[0, 0], 2 * P[0, 1], P[1, 1]], [0.0, 0.0])
    by_P = Region("P", P, 2.3, "certified")
    by_V = Region.from_lyapunov("poly", V, 2.3, "certified")
    assert by_P.P is not None and by_V.P is None and by_V.degree == 2
    X = np.random.default_rng(5).uniform(-3, 3, (50000, 2))
    # independent: x'Px written out
    q = P[0, 0] * X[:, 0] ** 2 + 2 * P[0, 1] * X[:, 0] * X[:, 1] + P[1, 1] * X[:, 1] ** 2
    clear = np.abs(q - 2.3) > 1e-9
    for region in (by_P, by_V):
        np.testing.assert_allclose(region.form(X), q, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(region.contains(X)[clear], (q <= 2.3)[clear])
    # the matrix form keeps its JSON (P) and its exact y'Py
    assert by_P.to_json() == {"name": "P", "P": P.tolist(), "level": 2.3, "status": "certified"}
    np.testing.assert_array_equal(by_P.form(X), np.einsum("ri,ij,rj->r", X, P, X))
    assert by_V.to_json()["V"]["degree"] == 2
    with pytest.raises(RoaInputError, match="P or V"):
        Region("both", P, 1.0, "claimed", None, {}, V)  # a polynomial V and P


def test_cli_basin_draws_a_certified_polynomial_v(tmp_path, capsys, certificate):
    cert = (
        tmp_path / "cert.json"
    )  # what `roa certify --lyapunov V4.json --level 0.99 --json` prints
    cert.write_text(roa.io.to_json(certificate))
    assert certificate["candidate_kind"]["degree"] == 4  # the form `roa certify --degree` writes
    png = tmp_path / "map.png"
    argv = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "20x20", "--t-final", "20",
            "--box", "x1=-3:3,x2=-3:3", "--lyapunov", str(cert), "--lyapunov-level", str(LEVEL),
            "--terminal-set", str(cert), "--plot", str(png), "--jobs", "1", "--json"]  # fmt: skip
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert png.is_file() and png.stat().st_size > 10_000
    (reg,) = out["regions"]
    assert reg["status"] == "certified" and reg["level"] == LEVEL
    assert reg["V"]["degree"] == 4 and reg["V"]["coefficients"] == COEFFICIENTS
    assert "degree-4" in reg["label"] and "certified" in reg["label"]
    assert reg["slice"]["points_in_region"] > 50 and reg["slice"]["all_converged"]
    assert out["entered_certified_set"] > 0 and out["terminal_set"]["level"] == LEVEL


def test_terminal_set_from_polynomial_certificate_keeps_statuses(certificate):
    system = vanderpol()
    term = terminal_from_certificate(certificate, system)
    assert not term.quadratic and term.degree == 4
    grid = grid_slice(system, ("x1", "x2"), [(-3, 3), (-3, 3)], (18, 18))
    X = grid.points(0, grid.n)
    plain = I.integrate_batch(system, X, rules=RULES)
    res = I.integrate_batch(system, X, rules=RULES, terminal=term)
    np.testing.assert_array_equal(res.code, plain.code)  # converged stay converged, others too
    assert res.entered.sum() > 20 and (plain.code[res.entered] == I.CONVERGED).all()
    assert res.steps.sum() < plain.steps.sum()
    # the set is {V <= level} inside a proved box of the equilibrium's component
    inside = term.contains(X)
    assert not (inside & (_direct(X) > LEVEL)).any()
    lo, hi = term.box
    assert (lo < 0).all() and (hi > 0).all()
    # picklable (joblib workers) with an exact repr (run fingerprints)
    again = pickle.loads(pickle.dumps(term))
    assert repr(again) == repr(term) and "box=" in repr(term)


@pytest.mark.slow
def test_polynomial_terminal_set_runs_in_the_numba_kernel_for_the_ipc():
    """The IPC's numba kernels (fast path and public cfuncs, bit for bit alike) stop runs in a
    polynomial terminal set where the numpy integrator does (its steps differ from the kernel's in
    the last bits: same statuses and step counts, times to 1e-6), and only ever turn undecided runs
    into converged ones.

    V = the paper's quadratic V (certified at 2.28, flat coordinates) + 0.01 z1^4 >= it, so
    {V <= 2} lies in the certified ellipsoid."""
    P = np.asarray(ipc.transformed().lyapunov)
    mono, coef = [], []
    for i in range(4):
        for j in range(i, 4):
            e = [0] * 4
            e[i] += 1
            e[j] += 1
            mono.append(e)
            coef.append(P[i, j] * (1 if i == j else 2))
    V = PolynomialLyapunov([*mono, [4, 0, 0, 0]], [*coef, 0.01], np.zeros(4), "paper V + z1^4")
    # V is convex, so {V <= 2} is one component: any frame (here the identity) bounds it
    term = TerminalSet.polynomial(V, 2.0, coords="flat", name="quartic", frame=np.eye(4),
                                  propose=component_candidates)  # fmt: skip
    system = ipc.closed_loop()
    grid = grid_slice(system, ("theta", "theta_dot"), [(-1.55, 1.55), (-10, 10)], (8, 6),
                      fixed={"q": 0.5, "q_dot": -0.5})  # fmt: skip
    X = grid.points(0, grid.n)
    on_numpy = I.integrate_batch(system, X, rules=RULES, terminal=term, backend="numpy")
    public = dataclasses.replace(system, numba_fast=None)
    fast, pub = (I.integrate_batch(s, X, rules=RULES, terminal=term, backend="numba")
                 for s in (system, public))  # fmt: skip
    for name in ("code", "t_end", "x_end", "steps", "entered"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(pub, name), name)
    for name in ("code", "steps", "entered"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(on_numpy, name), name)
    np.testing.assert_allclose(fast.t_end, on_numpy.t_end, rtol=1e-6)
    assert fast.entered.sum() > 5
    plain = run_basin(system, grid, rules=RULES, n_jobs=1, progress=False)
    res = run_basin(system, grid, rules=RULES, n_jobs=1, progress=False, terminal=term)
    assert "terminal_set_note" not in res.meta
    assert res.entered_certified_set > 0
    changed = plain.code != res.code
    assert (plain.code[changed] == I.UNDECIDED).all() and (res.code[changed] == I.CONVERGED).all()
    assert (res.code[plain.code == I.CONVERGED] == I.CONVERGED).all()


def test_polynomial_certificates_refused_or_reduced(certificate):
    system = vanderpol()
    with pytest.raises(RoaInputError, match="not 'certified'"):
        terminal_from_certificate({**certificate, "status": "refuted"}, system)
    with pytest.raises(RoaInputError, match="for system 'ipc_flat'"):
        terminal_from_certificate({**certificate, "system": "ipc_flat"}, system)
    func = {**certificate, "candidate_kind": {"lyapunov": "log V", "kind": "FunctionLyapunov"}}
    with pytest.raises(RoaInputError, match="quadratic or polynomial V only"):
        terminal_from_certificate(func, system)
    # a degree-2 polynomial is an ellipsoid: the quadratic fast path, with its matrix
    P = P_BENCHMARK
    quad = {"lyapunov": "q", "kind": "PolynomialLyapunov", "degree": 2,
            "monomials": [[2, 0], [1, 1], [0, 2]], "coefficients": [P[0, 0], 2 * P[0, 1], P[1, 1]]}  # fmt: skip
    cert = {"system": "vanderpol", "candidate_kind": quad, "level": 2.3, "status": "certified"}
    term = terminal_from_certificate(cert, system)
    assert term.quadratic
    np.testing.assert_array_equal(term.P, P)
