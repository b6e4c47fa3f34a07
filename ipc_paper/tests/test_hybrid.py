"""The IPC closed loop in hybrid coordinates (q, z2, w1, w2) and the interval arsinh it needs.

References: the flat closed loop (3.8) (``ipc_paper.system.transformed``, itself checked against the
physical model in ipc_paper/tests/test_ipc.py) pushed through the exact Jacobian of ``q = z1 - arsinh(w1)``;
trajectories of the physical closed loop by solve_ivp.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from ipc_paper import system as ipc
from ipc_paper.system.hybrid import (
    flat_to_hybrid,
    hybrid,
    hybrid_to_flat,
    hybrid_to_physical,
    physical_to_hybrid_or_inf,
)
from roa.integration._simulation import simulate
from roa.proof._interval import INTERVAL, Interval
from roa.proof._jet import Jet
from roa.proof._jet_net import JET
from roa.status import StopRules


def _pushed_flat_field(flat, y: np.ndarray, t: float = 0.0) -> np.ndarray:
    """d/dt flat_to_hybrid(xi) = J(xi) f_flat(xi), J exact: dq = dz1 - dw1 / sqrt(1 + w1^2)."""
    xi = hybrid_to_flat(y)
    f = flat.f(xi, t)
    out = f.copy()
    out[..., 0] = f[..., 0] - f[..., 2] / np.sqrt(1 + xi[..., 2] ** 2)
    return out


@pytest.mark.parametrize("reference", [None, "sin:0.5,1.3"])
def test_hybrid_field_is_the_pushed_flat_field(reference):
    rng = np.random.default_rng(7)
    y = rng.uniform(-3, 3, size=(200, 4)) * np.array([1, 1, 3, 1])
    h, flat = hybrid(reference=reference), ipc.transformed(reference=reference)
    for t in (0.0, 0.7):
        np.testing.assert_allclose(h.f(y, t), _pushed_flat_field(flat, y, t), rtol=0, atol=1e-10)


def test_coordinate_maps_round_trip_and_straighten_the_sector():
    rng = np.random.default_rng(3)
    x = rng.uniform([-2, -2, -1.5, -3], [2, 2, 1.5, 3], size=(100, 4))
    y = physical_to_hybrid_or_inf(x)
    np.testing.assert_allclose(hybrid_to_physical(y), x, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(flat_to_hybrid(ipc.to_flat(x)), y, rtol=1e-12, atol=1e-12)
    th = np.linspace(-1.5, 1.5, 31)
    z = np.zeros_like(th)
    line = physical_to_hybrid_or_inf(np.stack([z, z, th, z], axis=-1))
    np.testing.assert_allclose(line, np.stack([z, z, np.tan(th), z], axis=-1), atol=1e-15)
    assert np.all(np.isinf(physical_to_hybrid_or_inf(np.array([0.0, 0.0, 1.6, 0.0]))))


@pytest.mark.parametrize("x0", [(0.4, 0.25, 0.2, 2.0), (0.0, 0.0, 1.2, 0.2), (1.0, 0.0, -0.8, 0.0)])
def test_physical_and_hybrid_simulations_agree(x0):
    rules = StopRules(t_final=15.0, converge_tol=1e-12)
    t_eval = np.linspace(0, 15, 151)
    a = simulate(ipc.closed_loop(delta=0.7), x0, rules=rules, t_eval=t_eval, rtol=1e-11, atol=1e-12)
    b = simulate(
        hybrid(),
        physical_to_hybrid_or_inf(np.array(x0)),
        rules=rules,
        t_eval=t_eval,
        rtol=1e-11,
        atol=1e-12,
    )
    np.testing.assert_allclose(hybrid_to_physical(b.x), a.x, rtol=1e-6, atol=1e-6)


def test_hybrid_equilibrium_is_exact_and_linearisation_hurwitz():
    from roa.proof._exact import exact_equilibrium
    from roa.search._levelset import jacobian

    h = hybrid()
    assert exact_equilibrium(h, h.x_eq)
    assert np.max(np.linalg.eigvals(jacobian(h)).real) < 0


wide = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(wide, wide, st.floats(0, 1))
def test_interval_arsinh_encloses_value_and_derivatives(a, b, t):
    lo, hi = min(a, b), max(a, b)
    w = min(max(lo + t * (hi - lo), lo), hi)
    X = INTERVAL.arcsinh(Interval(lo, hi))
    assert X.lo <= np.arcsinh(w) <= X.hi
    J = JET.arcsinh(Jet.variables(np.array([[lo]]), np.array([[hi]]), order=2)[0])
    v, g, h = Interval.of(J.v), Interval.of(J.g[0]), Interval.of(J.h[0][0])
    assert v.lo[0] <= np.arcsinh(w) <= v.hi[0]
    assert g.lo[0] <= 1 / np.sqrt(1 + w * w) <= g.hi[0]
    assert h.lo[0] <= -w / (1 + w * w) ** 1.5 <= h.hi[0]


def test_interval_arsinh_is_tight_on_a_point():
    X = INTERVAL.arcsinh(Interval(1.0, 1.0))
    assert X.lo < np.log(1 + np.sqrt(2)) < X.hi and X.hi - X.lo < 1e-14
