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
from roa.control_system import closed_loop
from roa.linearisation import jacobian

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

    for mod in ("roa.control_system", "roa.system"):
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
