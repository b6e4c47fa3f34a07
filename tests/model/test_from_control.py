"""roa.System.from_control and roa.closed_loop (#25): python-control models under u = -K x.

A damped pendulum x'' = -g sin x - 0.1 x' + u as a ``control.nlsys`` with numpy's sin, and K from
``control.lqr`` on its exact linearisation A = [[0, 1], [-g, -0.1]], B = [0, 1]': the traced closed
loop's Jacobian (CasADi AD, exact) equals A - B K to 1e-12, its numpy values equal a hand-written
closed loop's, and an updfcn that branches on the state or a field= with other equations is refused
with a message saying what to write. ``control`` is in the ``test`` extra, so these run in CI.
"""

from __future__ import annotations

import control  # in the test extra, so these tests run (and are never skipped) in CI
import numpy as np
import pytest

import roa
from roa import closed_loop
from roa.model._linearisation import jacobian

G = 9.81
A = np.array([[0.0, 1.0], [-G, -0.1]])
B = np.array([[0.0], [1.0]])


def _pendulum(t, x, u, params):
    return [x[1], -params["g"] * np.sin(x[0]) - 0.1 * x[1] + u[0]]


PLANT = control.nlsys(_pendulum, None, inputs=1, states=2, params={"g": G}, name="pendulum")
K = control.lqr(A, B, np.diag([10.0, 1.0]), np.eye(1))[0]


def _hand_written(t, x, xp):
    u = -(K[0, 0] * x[0] + K[0, 1] * x[1])
    return (x[1], -G * xp.sin(x[0]) - 0.1 * x[1] + u)


def test_traced_closed_loop_linearises_to_A_minus_BK():
    cl = roa.System.from_control(PLANT, K)
    np.testing.assert_allclose(jacobian(cl), A - B @ K, rtol=0, atol=1e-12)
    assert cl.state_names == ("x0", "x1") and cl.name == "pendulum"


def test_traced_closed_loop_equals_a_hand_written_one():
    cl = roa.System.from_control(PLANT, K)
    X = np.random.default_rng(3).uniform(-3, 3, size=(200, 2))
    ref = roa.System("hand", _hand_written, (0.0, 0.0), ("x0", "x1")).f(X)
    np.testing.assert_allclose(cl.f(X), ref, rtol=1e-13, atol=1e-13)


def test_field_and_closed_loop_give_the_same_system():
    def field(t, x, u, xp):
        return (x[1], -G * xp.sin(x[0]) - 0.1 * x[1] + u[0])

    via_control = roa.System.from_control(PLANT, K, field=field)
    direct = closed_loop(field, K, ("theta", "omega"))
    X = np.random.default_rng(4).uniform(-2, 2, size=(50, 2))
    np.testing.assert_array_equal(via_control.f(X), direct.f(X))
    np.testing.assert_allclose(jacobian(direct), A - B @ K, rtol=0, atol=1e-12)


def test_shifted_equilibrium_and_input():
    # the pendulum held at theta = 0.3 by u_eq = g sin(0.3); u = u_eq - K (x - x_eq)
    x_eq, u_eq = (0.3, 0.0), (G * np.sin(0.3),)
    A_eq = np.array([[0.0, 1.0], [-G * np.cos(0.3), -0.1]])
    K_eq = control.lqr(A_eq, B, np.eye(2), np.eye(1))[0]
    cl = roa.System.from_control(PLANT, K_eq, equilibrium=x_eq, u_eq=u_eq)
    np.testing.assert_allclose(cl.f(np.array(x_eq)), [0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(jacobian(cl), A_eq - B @ K_eq, rtol=0, atol=1e-12)


def test_certify_the_traced_closed_loop():
    cert = roa.certify(roa.System.from_control(PLANT, K))
    assert cert.status is roa.Verdict.CERTIFIED and cert.level > 0


def test_state_space_plant_is_affine():
    ss = control.ss(A, B, np.eye(2), 0)
    cl = roa.System.from_control(ss, K)
    np.testing.assert_allclose(jacobian(cl), A - B @ K, rtol=0, atol=1e-12)


def test_branching_updfcn_is_refused_with_the_remedy():
    def upd(t, x, u, params):
        return [x[1], -np.sin(x[0]) + u[0] if x[0] > 0 else u[0]]

    plant = control.nlsys(upd, None, inputs=1, states=2, name="branchy")
    with pytest.raises(roa.RoaInputError, match=r"branchy's updfcn cannot be traced.*field="):
        roa.System.from_control(plant, K)


def test_unsupported_ufunc_is_named():
    def upd(t, x, u, params):
        return [x[1], -np.cbrt(x[0]) + u[0]]

    plant = control.nlsys(upd, None, inputs=1, states=2, name="cbrt")
    with pytest.raises(roa.RoaInputError, match=r"cbrt.*field="):
        roa.System.from_control(plant, K)


def test_field_with_other_equations_is_refused():
    def wrong(t, x, u, xp):
        return (x[1], -9.8 * xp.sin(x[0]) - 0.1 * x[1] + u[0])  # g = 9.8, not 9.81

    with pytest.raises(roa.RoaInputError, match=r"field= differs from pendulum's updfcn"):
        roa.System.from_control(PLANT, K, field=wrong)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"K": np.ones((2, 2))}, r"K must be a finite 1x2 matrix"),
        ({"K": [[np.nan, 1.0]]}, r"K must be a finite 1x2 matrix"),
        ({"K": K, "equilibrium": (0.0,)}, r"equilibrium must be 2 finite numbers"),
        ({"K": K, "u_eq": (0.0, 1.0)}, r"u_eq must be 1 finite numbers"),
    ],
)
def test_bad_shapes_name_the_argument(kwargs, match):
    with pytest.raises(roa.RoaInputError, match=match):
        roa.System.from_control(PLANT, **kwargs)


def test_not_a_control_system_and_discrete_time_are_refused():
    with pytest.raises(roa.RoaInputError, match=r"NonlinearIOSystem or StateSpace"):
        roa.System.from_control("pendulum", K)
    discrete = control.nlsys(_pendulum, None, inputs=1, states=2, params={"g": G}, dt=0.1)
    with pytest.raises(roa.RoaInputError, match=r"discrete-time"):
        roa.System.from_control(discrete, K)


def test_docstring_examples_run():
    import doctest
    import importlib

    for mod in ("roa.model._system",):
        failed, tried = doctest.testmod(importlib.import_module(mod), optionflags=doctest.ELLIPSIS)
        assert failed == 0 and tried > 0, mod


def test_closed_loops_pickle():
    import pickle

    for cl in (
        roa.System.from_control(PLANT, K),
        roa.System.from_control(control.ss(A, B, np.eye(2), 0), K),
    ):
        back = pickle.loads(pickle.dumps(cl))
        np.testing.assert_array_equal(back.f([0.3, -0.2]), cl.f([0.3, -0.2]))


# --- time dependence (issue 39, item 1) -------------------------------------------------------


def _damping_flips(t, x, u, params):
    """Damping 0.5 until t = 1, then -15: the closed loop under K_FLIP is unstable for t > 1."""
    c = 0.5 if t <= 1 else -15.0
    return [x[1], -np.sin(x[0]) - c * x[1] + u[0]]


def _t_times_x(t, x, u, params):
    return [x[1], -np.sin(x[0]) - 0.5 * x[1] + t * x[0] + u[0]]


def _decaying_into_zeros(t, x, u, params):
    dx = np.zeros(2)  # float conversion of the symbolic t, as python-control models often do
    dx[0] = x[1]
    dx[1] = -x[0] - np.exp(-t) * x[1] + u[0]
    return dx


K_FLIP = np.array([[1.0, 1.0]])


def _simulate(updfcn, frozen: bool, t_final: float) -> np.ndarray:
    from scipy.integrate import solve_ivp

    def rhs(t, x):
        return updfcn(0.0 if frozen else t, x, -K_FLIP @ x, {})

    sol = solve_ivp(rhs, (0.0, t_final), [0.05, 0.0], rtol=1e-9, atol=1e-12)
    return sol.y[:, -1]


def test_a_plant_whose_damping_flips_after_t_1_is_refused():
    """The field frozen at t = 0 (what a trace at t = 0 analysed) converges from x0 = (0.05, 0);
    the plant itself diverges from there (simulated): the frozen field's certificate would be
    wrong, so from_control refuses the plant, traced or with a field= of the frozen equations."""
    assert np.linalg.norm(_simulate(_damping_flips, frozen=True, t_final=20.0)) < 1e-3
    assert np.linalg.norm(_simulate(_damping_flips, frozen=False, t_final=3.0)) > 1.0
    plant = control.nlsys(_damping_flips, None, inputs=1, states=2, name="flip")
    with pytest.raises(roa.RoaInputError, match=r"flip's updfcn depends on the time t"):
        roa.System.from_control(plant, K_FLIP)

    def frozen(t, x, u, xp):
        return (x[1], -xp.sin(x[0]) - 0.5 * x[1] + u[0])

    with pytest.raises(roa.RoaInputError, match=r"depends on the time t"):
        roa.System.from_control(plant, K_FLIP, field=frozen)


@pytest.mark.parametrize("updfcn", [_t_times_x, _decaying_into_zeros])
def test_a_plant_with_t_in_its_arithmetic_is_refused(updfcn):
    plant = control.nlsys(updfcn, None, inputs=1, states=2, name="tv")
    with pytest.raises(roa.RoaInputError, match=r"tv's updfcn depends on the time t"):
        roa.System.from_control(plant, K_FLIP)


def test_a_time_dependence_only_numeric_probes_see_is_refused():
    """An updfcn that hides t from the symbolic probe (a float() of it) but changes with it."""

    def hidden(t, x, u, params):
        try:
            tt = float(t)
        except Exception:  # noqa: BLE001 - the symbolic t of the probe is taken as 0
            tt = 0.0
        return [x[1], -x[0] - (0.5 if tt < 50 else -3.0) * x[1] + u[0]]

    plant = control.nlsys(hidden, None, inputs=1, states=2, name="hidden")
    with pytest.raises(roa.RoaInputError, match=r"at t = 0 and .* at t = 100"):
        roa.System.from_control(plant, K_FLIP)


def test_a_field_that_depends_on_t_is_refused_for_an_autonomous_plant():
    def field(t, x, u, xp):
        return (x[1], -G * xp.sin(x[0]) - 0.1 * x[1] + u[0] + t * x[0])

    with pytest.raises(roa.RoaInputError, match=r"differs from pendulum's updfcn at t = 0.5"):
        roa.System.from_control(PLANT, K, field=field)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"K": K + 1e-3j}, r"K must be real, got the complex entry"),
        ({"K": K, "equilibrium": [0.0, 1j]}, r"equilibrium must be real"),
        ({"K": K, "u_eq": [2j]}, r"u_eq must be real"),
    ],
)
def test_complex_inputs_are_refused_not_truncated(kwargs, match):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning: refused before any cast
        with pytest.raises(roa.RoaInputError, match=match):
            roa.System.from_control(PLANT, **kwargs)
        with pytest.raises(roa.RoaInputError, match=match):
            closed_loop(_hand_written_plant, **kwargs, states=("a", "b"))


def _hand_written_plant(t, x, u, xp):
    return (x[1], -G * xp.sin(x[0]) - 0.1 * x[1] + u[0])


def test_a_complex_gain_with_zero_imaginary_parts_is_its_real_gain():
    real = roa.System.from_control(PLANT, K)
    cplx = roa.System.from_control(PLANT, K + 0j)
    X = np.random.default_rng(5).uniform(-2, 2, size=(20, 2))
    np.testing.assert_array_equal(cplx.f(X), real.f(X))
