"""Exact recasts of non-polynomial fields for the SOS validator (:mod:`roa.proof._recast`).

Optima are independent of roa: the pendulum's from a scipy multistart of min V s.t. V' = 0 in the
test; the rational system's is 1 (its docstring: V' = 0 at (1, 0), V = 1).
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from fractions import Fraction

import numpy as np
import pytest
from scipy.optimize import minimize

import roa
import roa.io
from roa.certification import Certificate
from roa.proof._recast import angle_constraints, positive_everywhere, recast_exact
from roa.proof._sos_check import NotPolynomial
from roa.search._rays import ray_box


def _pendulum():
    system = roa.load_system("examples/systems/pendulum.py:SYSTEM")
    return system, roa.default_lyapunov(system)


def _optimum(system, V) -> float:
    """min V on {V' = 0, |d| >= 0.05} by SLSQP from 40 starts (an upper bound of the largest
    level: a point with V' = 0)."""
    rng = np.random.default_rng(0)
    best = math.inf
    for _ in range(40):
        x0 = rng.uniform(-3, 3, size=V.n)
        r = minimize(lambda x: V.value(x), x0, method="SLSQP", constraints=[
            {"type": "eq", "fun": lambda x: V.derivative(system, x)},
            {"type": "ineq", "fun": lambda x: x @ x - 0.05**2}])  # fmt: skip
        if r.success and abs(V.derivative(system, r.x)) < 1e-8:
            best = min(best, float(V.value(r.x)))
    return best


def test_taylor_constraints_hold_at_sin_and_cos():
    """Every constraint of an angle, evaluated at (d, sin d, 1 - cos d) in 50-digit mpmath on
    [-8, 8] (the global ones) and on [-r, r] (the bands that use |d| <= r), is >= 0."""
    import mpmath as mp

    mp.mp.dps = 50
    for r in (None, Fraction(3, 2)):
        eqs, ineqs = angle_constraints(3, 0, 1, 2, 7, r)
        top = 8 if r is None else float(r)
        for d in np.linspace(-top, top, 801):
            z = (mp.mpf(d), mp.sin(d), 1 - mp.cos(d))

            def val(p, z=z):
                return sum(mp.mpf(c.numerator) / c.denominator * z[0] ** m[0] * z[1] ** m[1]
                           * z[2] ** m[2] for m, c in p.items())  # fmt: skip

            assert all(abs(val(h)) < mp.mpf(10) ** -40 for _, h in eqs)
            for what, g in ineqs:
                assert val(g) >= -(mp.mpf(10) ** -40), (what, d)


@pytest.mark.parametrize(
    ("name", "level"),
    [("examples/systems/pendulum.py:SYSTEM", 10.0), ("examples/systems/quadrotor2d.py:SYSTEM", 0.13),
     ("examples/systems/rational.py:SYSTEM", 1.0), ("ipc-flat", 2.28)],
)  # fmt: skip
def test_recast_agrees_with_the_field_at_points_of_the_level_set(name, level):
    """At 300 random points x of {V <= level} (and near x_eq): N(z(x)) / Den(z(x)) equals V'(x)
    of the original field (numpy), Den(z(x)) > 0, every equality vanishes and every inequality
    is >= 0 at z(x) (float tolerances relative to the terms' size)."""
    from roa.proof._recast import evaluate, level_scale

    system = roa.load_system(name)
    V = roa.default_lyapunov(system)
    data = recast_exact(system, V, scale=level_scale(V, level), level=level)
    rng = np.random.default_rng(1)
    P = np.linalg.inv(np.linalg.cholesky(V.P).T)  # V(c + P u) = |u|^2
    for k in range(300):
        u = rng.normal(size=V.n)
        u *= np.sqrt(level) * rng.uniform(0, 1) ** (1 / V.n) / np.linalg.norm(u)
        if k < 10:
            u *= 1e-3
        x = V.center + P @ u
        assert V.value(x) <= level * (1 + 1e-9)
        z = data.point(x)
        den = evaluate(data.Den, z)
        assert den > 0
        vdot = V.derivative(system, x)
        assert evaluate(data.N, z) / den == pytest.approx(vdot, rel=1e-7, abs=1e-12)
        for what, h in data.equalities:
            size = sum(abs(float(c)) * np.prod(np.abs(z) ** np.array(m)) for m, c in h.items())
            assert abs(evaluate(h, z)) <= 1e-12 * (1 + size), what
        for what, g in data.inequalities:
            size = sum(abs(float(c)) * np.prod(np.abs(z) ** np.array(m)) for m, c in g.items())
            assert evaluate(g, z) >= -1e-12 * (1 + size), what


def test_pendulum_certified_at_095_of_its_optimum_and_rechecked():
    system, V = _pendulum()
    opt = _optimum(system, V)
    assert opt == pytest.approx(10.0957, rel=1e-3)  # roa khalil: 10.09575 (both methods agree)
    cert = roa.certify(system, V, level=0.95 * opt, validator=roa.SosValidator())
    assert cert.status is roa.Verdict.CERTIFIED and cert.method == "sos-exact", cert.message
    assert "recast" in cert.message and cert.validation.meta["min_pivot"] > 0
    data = json.loads(roa.io.to_json(cert.to_dict()))
    assert Certificate.from_dict(data, system).reverify().certified
    # a raised level (above the optimum: no certificate can exist) is refused
    raised = Certificate.from_dict({**data, "level": 1.001 * opt}, system).reverify()
    assert raised.status is roa.Verdict.INCONCLUSIVE and "refused" in raised.message
    # an indefinite multiplier (the level multiplier's Gram matrix negated) is refused
    bad = json.loads(json.dumps(data))
    lam = next(g for g in bad["certificate"]["parts"][0]["grams"] if g["multiplies"] == 1)
    lam["Q"] = [[v[1:] if v.startswith("-") else f"-{v}" for v in row] for row in lam["Q"]]
    r = Certificate.from_dict(bad, system).reverify()
    assert r.status is roa.Verdict.INCONCLUSIVE and "level multiplier" in r.message
    assert "not positive definite" in r.message
    # Q0 made indefinite with the identity still exact: +a on the (y0^2, y1^2) pair and -2a on
    # (y0 y1, y0 y1) leave every coefficient unchanged (the projection does not move it)
    forged = json.loads(json.dumps(data))
    mons = ((2, 0, 0, 0), (1, 1, 0, 0), (0, 2, 0, 0))
    g0 = next(g for g in forged["certificate"]["parts"][0]["grams"]
              if g["multiplies"] == 0 and set(mons) <= {tuple(b) for b in g["basis"]})  # fmt: skip
    basis = [tuple(b) for b in g0["basis"]]
    i11, i12, i22 = (basis.index(m) for m in mons)
    Q0 = [[Fraction(v) for v in row] for row in g0["Q"]]
    a = abs(Q0[i12][i12]) + 1
    Q0[i11][i22] += a
    Q0[i22][i11] += a
    Q0[i12][i12] -= 2 * a
    g0["Q"] = [[str(v) for v in row] for row in Q0]
    r = Certificate.from_dict(forged, system).reverify()
    assert r.status is roa.Verdict.INCONCLUSIVE and "projected Gram matrix" in r.message
    assert r.validation.meta["residual"] == 0
    # a Taylor order the file cannot justify (even) is refused
    odd = json.loads(json.dumps(data))
    odd["certificate"]["taylor"] = 4
    assert not Certificate.from_dict(odd, system).reverify().certified


def test_pendulum_refuted_just_above_its_optimum():
    system, V = _pendulum()
    cert = roa.certify(system, V, level=10.5, validator=roa.SosValidator())
    assert cert.status is roa.Verdict.INCONCLUSIVE  # SOS never refutes...
    found = roa.certify(system, V, level=roa.SampledLevel(safety=0.95),
                        validator=roa.SosValidator(), check_above=1.001)  # fmt: skip
    assert found.status is roa.Verdict.CERTIFIED, found.message
    assert found.above is not None and found.above.status is roa.Verdict.REFUTED  # ...the B&B does
    assert found.above.witness_check["confirmed"]


def test_rational_field_multiplied_by_its_positive_denominator():
    system = roa.load_system("examples/systems/rational.py:SYSTEM")
    V = roa.default_lyapunov(system)
    data = recast_exact(system, V)
    assert data.denominator == "d1**2 + 1" and not data.angles
    assert roa.certify(system, V, level=0.95, validator=roa.SosValidator()).certified
    # the optimum is 1: V' = 0 at (1, 0)
    assert V.derivative(system, np.array([1.0, 0.0])) == pytest.approx(0, abs=1e-15)
    assert roa.SosValidator().check(system, V, 1.01).status is not roa.Verdict.CERTIFIED


def test_denominators_and_terms_that_cannot_be_recast_are_named():
    assert positive_everywhere({(0, 0): Fraction(1), (2, 0): Fraction(3), (2, 4): Fraction(1)})
    assert not positive_everywhere({(0, 0): Fraction(1), (1, 0): Fraction(1)})
    assert not positive_everywhere({(2, 0): Fraction(1)})
    V = roa.QuadraticLyapunov([[1.0, 0.0], [0.0, 1.0]], [0.0, 0.0])
    cases = {
        "atan(d0)": lambda t, x, xp: (-xp.arctan(x[0]), -x[1]),
        "exp(d1)": lambda t, x, xp: (-x[0], -(xp.exp(x[1]) - 1)),
        "sqrt(d1**2 + 2)": lambda t, x, xp: (-x[0] * xp.sqrt(2 + x[1] ** 2), -x[1]),
        "sqrt(1 - d1**2)": lambda t, x, xp: (-x[0] * xp.sqrt(1 - x[1] ** 2), -x[1]),
        "denominator": lambda t, x, xp: (-x[0] / (1 + x[0]), -x[1]),
    }
    for word, f in cases.items():
        with pytest.raises(NotPolynomial, match=re.escape(word)):
            recast_exact(roa.System("s", f, (0.0, 0.0), ("a", "b")), V)
    shifted = roa.System("s", lambda t, x, xp: (-(x[0] - 1) * xp.cos(x[0]), -x[1]), (1.0, 0.0),
                         ("a", "b"))  # fmt: skip
    with pytest.raises(NotPolynomial, match="equilibrium value is exactly 0"):
        recast_exact(shifted, roa.QuadraticLyapunov(np.eye(2), [1.0, 0.0]))


def test_quadrotor_certified_at_095_of_a_point_with_zero_derivative():
    """The planar quadrotor (6 states, sin/cos of the pitch): a point with V' >= 0 next to an
    SLSQP solution of min V s.t. V' = 0 (independent of roa's searches) bounds the largest level
    from above; 0.95 x its V is
    certified by the recast SOS route. The check refuses a level above the one whose angle bound
    it proved, a multiplier of a Taylor band made indefinite, and an identity off by one
    coefficient. (Changing an equality multiplier is no tampering: ``mu h`` vanishes at every
    ``z(x)``, so any ``mu`` whose projected ``Q0`` stays positive definite is a valid proof.)"""
    from roa.proof._putinar import Certificate as Putinar, check_level as check_putinar
    from roa.proof._recast import level_scale, recast_preconditions
    from roa.search._sos_program import propose

    system = roa.load_system("examples/systems/quadrotor2d.py:SYSTEM")
    V = roa.default_lyapunov(system)
    x0 = np.array([0.0012, -0.037, 0.0705, 0.00054, -0.0603, 0.0])  # near roa khalil's witness
    r = minimize(lambda x: V.value(x), x0, method="SLSQP",
                 constraints=[{"type": "eq", "fun": lambda x: V.derivative(system, x)}])  # fmt: skip
    assert r.success and abs(V.derivative(system, r.x)) < 1e-6 and np.linalg.norm(r.x) > 0.05
    t = next(t for t in np.linspace(1, 1.01, 1001) if V.derivative(system, t * r.x) >= 0)
    top = float(V.value(t * r.x))  # V' >= 0 there: the largest level is at most top
    assert top == pytest.approx(0.130338, rel=1e-4)  # roa khalil: 0.13034 (both methods agree)
    level = 0.95 * top
    cert = roa.certify(system, V, level=level, validator=roa.SosValidator())
    assert cert.status is roa.Verdict.CERTIFIED and "sin/cos(d2)" in cert.message, cert.message
    data, why = recast_preconditions(system, V, level, None, level_scale(V, level))
    assert data is not None, why
    cand = propose(data, level)
    assert cand.certificate is not None
    good = check_putinar(data, level, cand.eps, cand.certificate)
    assert good.ok and good.certificate is not None
    exact = good.certificate
    assert check_putinar(data, level, cand.eps, exact, rounded=True).ok
    assert "only" in check_putinar(data, 1.01 * level, cand.eps, exact, rounded=True).reason
    band = next(j for j, (w, _) in enumerate(data.inequalities) if "squared" in w)
    grams = list(exact.grams)
    i = next(i for i, (k, _, _) in enumerate(grams) if k == 2 + band)
    k, basis, Q = grams[i]
    grams[i] = (k, basis, [[-v for v in row] for row in Q])
    bad = check_putinar(data, level, cand.eps, Putinar(tuple(grams), exact.free), rounded=True)
    assert not bad.ok and "not positive definite" in bad.reason  # checked as stored
    assert data.inequalities[band][0] in bad.reason  # the band's multiplier is named
    # V' off by one coefficient: its y0^2 term made positive (V' > 0 near x_eq along y0, so no
    # certificate can exist); the projection must move Q0 by the mismatch and fails
    y0 = (2,) + (0,) * (data.nv - 1)
    a = data.N[y0]
    assert a < 0
    wrong = dataclasses.replace(data, N={**data.N, y0: -a})
    off = check_putinar(wrong, level, cand.eps, exact, rounded=True)
    assert not off.ok and off.residual == pytest.approx(float(-2 * a))


def test_one_field_certificate_is_not_one_for_a_box():
    """A stored SOS certificate of Van der Pol (mu = 1) is refused for the family mu in
    [0.5, 2] (it proves one field; at mu = 2 the level 2.30 is refuted): by the file's system
    fingerprint, and by the exact re-check itself; the SOS validator proves the family's box
    (tests/proof/test_sos_robust.py) and cannot at 2.30 (below mu = 0.5's V' is indefinite at 0)."""
    import json

    from roa.proof._sos_stored import recheck as recheck_stored
    from roa.systems.vanderpol import vanderpol

    cert = roa.certify(vanderpol(), level=2.30, validator=roa.SosValidator())
    assert cert.certified
    family = vanderpol().with_ranges(mu=(0.5, 2.0))
    data = json.loads(roa.io.to_json(cert.to_dict()))
    with pytest.raises(roa.RoaInputError, match="another system"):
        Certificate.from_dict(data, family)
    again = recheck_stored(family, cert.V, 2.30, cert.validation.meta, cover_estimate=ray_box)
    assert again.status is roa.Verdict.INCONCLUSIVE and "uncertain parameters" in again.message
    v = roa.SosValidator(fallback=False).check(family, roa.default_lyapunov(vanderpol()), 2.30)
    assert v.status is roa.Verdict.INCONCLUSIVE and "SOS check failed" in v.message
