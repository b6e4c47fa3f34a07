"""IPC coordinates, controller and closed loop."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from ipc_paper import system as ipc
from ipc_paper.system.controller import ExpressionReference, Gains, SineReference, make_reference
from roa.integration._simulation import simulate
from roa.status import RunStatus, StopRules

finite = st.floats(-50, 50, allow_nan=False)
angle = st.floats(-1.55, 1.55, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(finite, finite, angle, finite)
def test_round_trip_physical_flat(q, qd, th, thd):
    x = np.array([q, qd, th, thd])
    np.testing.assert_allclose(ipc.from_flat(ipc.to_flat(x)), x, rtol=1e-9, atol=1e-9)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(-30, 30, allow_nan=False), min_size=4, max_size=4))
def test_round_trip_flat_physical(xi):
    xi = np.array(xi)
    np.testing.assert_allclose(ipc.to_flat(ipc.from_flat(xi)), xi, rtol=1e-9, atol=1e-8)


def test_coordinates_vectorised():
    rng = np.random.default_rng(0)
    x = rng.uniform(-1.4, 1.4, size=(7, 3, 4))
    y = ipc.to_flat(x)
    assert y.shape == x.shape
    np.testing.assert_allclose(y[2, 1], ipc.to_flat(x[2, 1]))


@pytest.mark.parametrize(
    "state, match",
    [
        ([0, 0, 1.7, 0], "theta = 1.7 rad is outside"),
        ([0, 0, -np.pi / 2, 0], "outside the domain"),
        ([0, np.nan, 0.1, 0], "finite"),
        ([0, 0, 0.1], "4 components"),
    ],
)
def test_bad_states_rejected(state, match):
    with pytest.raises(ValueError, match=match):
        ipc.to_flat(np.array(state, dtype=float))


def test_non_hurwitz_rejected():
    with pytest.raises(ValueError, match="not Hurwitz"):
        Gains.from_poles([-1, -1, 0.5, -2])
    with pytest.raises(ValueError, match="not Hurwitz"):
        Gains.from_coefficients([1, 0, 6, 4])
    with pytest.raises(ValueError, match="conjugate"):
        Gains.from_poles([-1 + 1j, -1 + 1j, -1, -1])
    assert Gains.default().h == pytest.approx((1, 4, 6, 4))  # (s+1)^4 = s^4 + 4s^3 + 6s^2 + 4s + 1


def test_expression_reference_derivatives_exact():
    ref = ExpressionReference("2*sin(t/2)")
    t = np.linspace(0, 10, 17)
    for a, b in zip(ref.derivatives(t), SineReference(2.0, 0.5).derivatives(t), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-14)
    with pytest.raises(ValueError, match="unknown symbols"):
        make_reference("sin(x)")


def test_force_linearises_exactly():
    """With the corrected (2.5), d/dt w2 along the physical model equals the designed v."""
    rng = np.random.default_rng(3)
    x = rng.uniform([-2, -2, -1.4, -3], [2, 2, 1.4, 3], size=(50, 4))
    for delta in (0.2, 1.0, 10.0):
        sys_p = ipc.closed_loop(delta=delta)
        f = sys_p.f(x)
        xi = ipc.to_flat(x)
        # w2 = theta' sec^2 theta: w2' = theta'' sec^2 + 2 theta'^2 sec^2 tan
        sec2 = 1 / np.cos(x[:, 2]) ** 2
        w2dot = f[:, 3] * sec2 + 2 * x[:, 3] ** 2 * sec2 * np.tan(x[:, 2])
        v = -(xi @ np.array([1.0, 4.0, 6.0, 4.0]))
        np.testing.assert_allclose(w2dot, v, rtol=1e-10, atol=1e-9)


def test_transformed_closed_loop_is_independent_of_delta():
    """Pushing the physical field through the Jacobian of (2.2) gives (3.8) for every delta."""
    rng = np.random.default_rng(4)
    x = rng.uniform([-2, -2, -1.4, -3], [2, 2, 1.4, 3], size=(40, 4))
    flat = ipc.transformed()
    eps = 1e-6
    for delta in (0.1, 1.0, 25.0):
        fp = ipc.closed_loop(delta=delta).f(x)
        # directional derivative of to_flat along fp (central differences, step 1e-6)
        d_flat = (ipc.to_flat(x + eps * fp) - ipc.to_flat(x - eps * fp)) / (2 * eps)
        np.testing.assert_allclose(d_flat, flat.f(ipc.to_flat(x)), rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("x0", [(0.4, 0.25, 0.2, 2.0), (0.0, 0.0, 1.2, 0.2), (1.0, 0.0, -0.8, 0.0)])
def test_physical_and_flat_simulations_agree(x0):
    rules = StopRules(t_final=15.0, converge_tol=1e-12)
    t_eval = np.linspace(0, 15, 151)
    a = simulate(ipc.closed_loop(delta=0.7), x0, rules=rules, t_eval=t_eval, rtol=1e-11, atol=1e-12)
    b = simulate(
        ipc.transformed(),
        ipc.to_flat(np.array(x0)),
        rules=rules,
        t_eval=t_eval,
        rtol=1e-11,
        atol=1e-12,
    )
    np.testing.assert_allclose(ipc.from_flat(b.x), a.x, rtol=1e-6, atol=1e-6)


def test_paper_initial_conditions_converge_for_several_deltas():
    for delta in (0.1, 1.0, 10.0):
        tr = simulate(ipc.closed_loop(delta=delta), (0.0, 0.0, 1.2, 0.2))
        assert tr.status is RunStatus.CONVERGED


def test_leaving_the_domain_is_a_status():
    # with an actuator limit |u| <= 1 the pendulum started at p2 falls over
    tr = simulate(
        ipc.closed_loop(saturation=1.0), (0.0, 0.0, 1.2, 0.2), rules=StopRules(t_final=20)
    )
    assert tr.status is RunStatus.LEFT_DOMAIN
    assert abs(tr.final_state[2]) == pytest.approx(np.pi / 2, abs=1e-6)
    assert np.all(np.isfinite(tr.x))


def test_bad_parameters():
    with pytest.raises(ValueError, match="delta"):
        ipc.closed_loop(delta=0.0)
    with pytest.raises(ValueError, match="saturation"):
        ipc.closed_loop(saturation=-1)
    with pytest.raises(ValueError, match="rules.t_final"):
        StopRules(t_final=np.nan)
