"""The example gallery (#25): every script in examples/ runs in quick settings and writes its JSON
and its figure; the numbers are checked against what is known independently.

* Van der Pol: the published largest level 2.3045 of the benchmark P (Tedrake's course notes).
* Planar quadrotor under LyZNet's gain: the largest level 0.1303 of V from A'P + PA = -I (the
  interval certificate of 0.1303 with 15e6 boxes, issue #25).
* Two-machine power system: the saddle at x1 = pi/3 (sin(x1 + pi/3) = sin(pi/3)) lies outside the
  certified set, whose level is below V(saddle).
* Every example: the slice's grid points inside the certified set all converged, the counts add up
  to the grid, the certificate is proved independently (interval or exact SOS).
"""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest

import roa

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
NAMES = ("vanderpol", "quadrotor2d_sympy", "power_system", "lyznet_10d", "control_pendulum")
#: The two large-system examples run with ``-m slow`` (their levels are also measured by
#: ``benchmarks/bench_scale.py``); the other three stay in the default suite.
SLOW_EXAMPLES = frozenset({"quadrotor2d_sympy", "lyznet_10d"})


def _case(name: str):
    return pytest.param(name, marks=[pytest.mark.slow] if name in SLOW_EXAMPLES else [], id=name)


@pytest.fixture(scope="module")
def gallery(tmp_path_factory):
    """``(out, run)``: ``run(name)`` runs the example's ``main(["--quick"])`` once, writing into
    ``out``, and returns ``(module, its JSON document)``."""
    out = tmp_path_factory.mktemp("gallery")
    docs: dict = {}

    def run(name: str):
        if name not in docs:
            sys.path.insert(0, str(EXAMPLES))
            try:
                module = importlib.import_module(name)
                docs[name] = (module, module.main(["--quick", "--out", str(out)]))
            finally:
                sys.path.remove(str(EXAMPLES))
        return docs[name]

    return out, run


@pytest.mark.parametrize("name", [_case(n) for n in NAMES])
def test_example_writes_json_and_figure(gallery, name):
    out, run = gallery
    returned = run(name)[1]
    doc = json.loads((out / f"{name}.json").read_text())
    assert doc == returned
    png = (out / f"{name}.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    cert, basin = doc["certificate"], doc["basin_slice"]
    assert cert["status"] == "certified" and cert["method"] in ("interval", "sos-exact")
    assert 0 < cert["level"] <= doc["level_search"]["level"]
    assert sum(basin["counts"].values()) == basin["n"] > 0
    (certified,) = [r for r in basin["regions"] if r["status"] == "certified"]
    assert certified["slice"]["points_in_region"] > 0 and certified["slice"]["all_converged"]


def test_vanderpol_matches_the_published_level(gallery):
    doc = gallery[1]("vanderpol")[1]
    assert doc["level_search"]["level"] == pytest.approx(2.3045, abs=5e-4)
    assert doc["certificate"]["above"] == "refuted"


@pytest.mark.slow
def test_quadrotor_level(gallery):
    doc = gallery[1]("quadrotor2d_sympy")[1]
    assert doc["level_search"]["level"] == pytest.approx(0.1303, rel=2e-3)
    assert doc["states"] == ["x", "y", "theta", "vx", "vy", "omega"]


def test_power_system_certified_set_stops_before_the_saddle(gallery):
    module, doc = gallery[1]("power_system")
    system = module.power_system()
    saddle = np.array([np.pi / 3, 0.0])
    np.testing.assert_allclose(system.f(saddle), [0.0, 0.0], atol=1e-15)
    V = roa.default_lyapunov(system)
    assert doc["certificate"]["level"] < float(V.value(saddle))
    assert doc["certificate"]["above"] == "refuted"


def test_control_pendulum_gain_is_lqr(gallery):
    module, doc = gallery[1]("control_pendulum")
    import control

    A = np.array([[0.0, 1.0], [9.81 / 0.5, -0.1]])
    B = np.array([[0.0], [-1.0 / 0.5]])
    K = control.lqr(A, B, np.diag([1.0, 0.1]), np.eye(1))[0]
    np.testing.assert_allclose(
        doc["gain"], K, rtol=1e-5
    )  # python-control's linearize: finite differences
    assert doc["certificate"]["above"] == "refuted"
