"""The model in roa is the Lagrangian one, and (2.2) maps it exactly into the structure of (2.3)."""

import numpy as np
import pytest
import sympy as sp

from ipc_paper import symbolic as S
from ipc_paper.errata import analyse
from ipc_paper.system import model


@pytest.fixture(scope="module")
def derived():
    qdd, thdd = S.lagrangian_model()
    return qdd, thdd, S.transform(qdd, thdd)


def test_transformation_gives_structure_2_3(derived):
    _, _, tr = derived
    phi0 = S.w1 / (1 + S.w1**2) ** sp.Rational(3, 2)
    assert sp.simplify(tr.z1_dot - S.z2) == 0
    assert S.is_zero(tr.z2_dot - (S.w1 + phi0 * S.w2**2))
    assert sp.simplify(tr.w1_dot - S.w2) == 0
    assert sp.simplify(tr.w2_dot.diff(S.u, 2)) == 0  # affine in u
    assert sp.simplify(tr.z2_dot.diff(S.u)) == 0  # the input does not reach z2


def test_numeric_model_is_the_lagrangian_one(derived):
    qdd, thdd, _ = derived
    f = sp.lambdify((S.q_s, S.qd_s, S.th_s, S.thd_s, S.u, S.delta), (qdd, thdd), "numpy")
    rng = np.random.default_rng(1)
    for _ in range(20):
        qd, th, thd, u = rng.normal(size=4)
        th = np.clip(th, -1.5, 1.5)
        d = rng.uniform(0.1, 5)
        ref = f(0.0, qd, th, thd, u, d)
        got = model.accelerations(qd, th, thd, u, d)
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12)


def test_numeric_phis_match_the_derivation(derived):
    phis = S.phi_from_model(derived[2])
    fns = {k: sp.lambdify((S.w, S.delta), e, "numpy") for k, e in phis.items()}
    w = np.linspace(-20, 20, 101)
    for d in (0.05, 1.0, 7.0):
        np.testing.assert_allclose(model.phi0(w), fns["phi0"](w, d), rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(model.phi1(w, d), fns["phi1"](w, d), rtol=1e-12)
        np.testing.assert_allclose(model.phi2(w, d), fns["phi2"](w, d), rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(model.phi3(w, d), fns["phi3"](w, d), rtol=1e-12, atol=1e-14)


def test_errata_of_the_printed_formulas():
    res = analyse()
    # (2.1) as printed cannot be mapped to (2.3): the input would reach z2'
    assert res["structure_2_3_printed_model"]["z2_dot free of u (printed 2.1)"] is False
    assert all(res["structure_2_3_derived_model"].values())
    cmp = res["printed_phi_equals_derived"]
    assert cmp["phi0"] and cmp["phi3"]
    assert not cmp["phi1"] and not cmp["phi2"]
    # the printed (2.5) (with the printed phis) does not produce w2' = v
    assert res["printed_2_5_gives_v"] is False
    assert res["printed_sign_with_derived_phis_gives_minus_v"] is True


def test_inverse_gudermannian_identity():
    th = np.linspace(-1.5, 1.5, 301)
    np.testing.assert_allclose(
        2 * np.arctanh(np.tan(th / 2)), np.arcsinh(np.tan(th)), rtol=1e-12, atol=1e-13
    )
