"""Exact recasts of non-polynomial fields for the SOS validator (:mod:`roa.proof.recast`).

Optima are independent of roa: the pendulum's from a scipy multistart of min V s.t. V' = 0 in the
test; the rational system's is 1 (its docstring: V' = 0 at (1, 0), V = 1).
"""

from __future__ import annotations

import json
import math
from fractions import Fraction

import numpy as np
import pytest
from scipy.optimize import minimize

import roa
from roa.certification import Certificate
from roa.proof.recast import angle_constraints, positive_everywhere, recast_exact
from roa.proof.sos_check import NotPolynomial


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
    lam = bad["certificate"]["putinar"]["grams"][1]["Q"]
    bad["certificate"]["putinar"]["grams"][1]["Q"] = [
        [v[1:] if v.startswith("-") else f"-{v}" for v in row] for row in lam
    ]
    r = Certificate.from_dict(bad, system).reverify()
    assert r.status is roa.Verdict.INCONCLUSIVE and "not positive definite" in r.message
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
        "sqrt": lambda t, x, xp: (-x[0] * xp.sqrt(1 + x[1] ** 2), -x[1]),
        "denominator": lambda t, x, xp: (-x[0] / (1 + x[0]), -x[1]),
    }
    for word, f in cases.items():
        with pytest.raises(NotPolynomial, match=word.replace("(", r"\(").replace(")", r"\)")):
            recast_exact(roa.System("s", f, (0.0, 0.0), ("a", "b")), V)
    shifted = roa.System("s", lambda t, x, xp: (-(x[0] - 1) * xp.cos(x[0]), -x[1]), (1.0, 0.0),
                         ("a", "b"))  # fmt: skip
    with pytest.raises(NotPolynomial, match="equilibrium value is exactly 0"):
        recast_exact(shifted, roa.QuadraticLyapunov(np.eye(2), [1.0, 0.0]))
