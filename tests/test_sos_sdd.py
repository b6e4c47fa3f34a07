"""Dense coupled systems: sign-symmetry blocks and scaled diagonally dominant (SDSOS) Gram blocks
(roa.search.sos_sdd proposes, roa.proof.sos_sdd proves exactly); the dense cubic example's
closed-form optimum 1 / lambda_max(B); tampered SDSOS certificates refused."""

from __future__ import annotations

import copy
import importlib.util
import json
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

import roa
from roa.certification import Certificate
from roa.proof.sos_check import exact_data
from roa.proof.sos_sdd import check_sdd, dominance_margin, scaling
from roa.search.polysdp import monomials
from roa.search.sos_sdd import SddProgram, plan, sign_classes
from roa.status import Verdict

ROOT = Path(__file__).resolve().parents[1]


def _module():
    spec = importlib.util.spec_from_file_location("dense_cubic",
                                                  ROOT / "examples/systems/dense_cubic.py")  # fmt: skip
    mod = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(mod)
    return mod


DC = _module()


def test_closed_form_optimum_against_scipy():
    from scipy.optimize import minimize

    system = DC.dense_cubic(6)
    opt = DC.optimum(6)

    def vdot(x):
        return 2 * float(x @ np.asarray(system.f(x), float))

    best = np.inf
    rng = np.random.default_rng(0)
    for _ in range(20):
        res = minimize(lambda x: x @ x, rng.standard_normal(6), method="SLSQP",
                       constraints=[{"type": "eq", "fun": lambda x: vdot(x) / (x @ x)}],
                       options={"ftol": 1e-14, "maxiter": 500})  # fmt: skip
        if res.success and abs(vdot(res.x)) < 1e-9:
            best = min(best, float(res.x @ res.x))
    assert best == pytest.approx(opt, rel=1e-6)


def test_sign_classes_of_an_even_polynomial_split_odd_from_even():
    data = exact_data(DC.dense_cubic(6), roa.default_lyapunov(DC.dense_cubic(6)))
    classes = sign_classes(data, monomials(6, 2, 1))
    # V' = -2|x|^2 + 2 (x'Bx)|x|^2 with B dense: parities of x_i x_j x_k^2 span the even-weight
    # vectors, so the classes are odd (6 linear monomials) and even (21 quadratic ones)
    assert sorted(len(c) for c in classes) == [6, 21]
    assert all(sum(m) == 2 for m in classes[0]) and all(sum(m) == 1 for m in classes[1])


def test_sign_classes_of_a_field_with_more_symmetry():
    # x1' = -x1 + x1 x2^2, x2' = -x2: V = |x|^2, V' = -2 x1^2 + 2 x1^2 x2^2 - 2 x2^2 is even in
    # each variable separately: every monomial of degree 1..2 has its own parity class but
    # x1^2, x2^2 and 1, which share the class 0
    system = roa.System("sym2", lambda t, x, xp: (-x[0] + x[0] * x[1] ** 2, -x[1]), (0.0, 0.0),
                        ("a", "b"), lyapunov=np.eye(2))  # fmt: skip
    data = exact_data(system, roa.default_lyapunov(system))
    classes = sign_classes(data, monomials(2, 2, 1))
    assert sorted(len(c) for c in classes) == [1, 1, 1, 2]


def test_dominance_check_is_exact():
    S = [[Fraction(2), Fraction(-1)], [Fraction(-1), Fraction(2)]]
    assert dominance_margin(S, [Fraction(1), Fraction(1)]) == 1
    # [[1, 2], [2, 5]] is positive definite and scaled diagonally dominant with w = (2, 1)
    # (1 * 2 - 2 * 1 = 0 is not strict; w = (3, 1): 3 - 2 = 1 > 0 and 5 - 2 * 3 < 0), so only
    # w in (2, 2.5) works: w = (9/4, 1) gives 1/4 and 1/2
    T = [[Fraction(1), Fraction(2)], [Fraction(2), Fraction(5)]]
    assert dominance_margin(T, [Fraction(9, 4), Fraction(1)]) == Fraction(1, 4)
    assert dominance_margin(T, [Fraction(1), Fraction(1)]) < 0
    w = scaling(T)
    assert w is not None and dominance_margin(T, w) > 0
    assert dominance_margin(T, [Fraction(1), Fraction(0)]) is None  # not positive
    assert scaling([[Fraction(1), Fraction(2)], [Fraction(2), Fraction(1)]]) is None  # indefinite


@pytest.mark.parametrize("factor, ok", [(0.99, True), (1.01, False)])
def test_sdd_program_certifies_below_the_optimum_only(factor, ok):
    system = DC.dense_cubic(6)
    data = exact_data(system, roa.default_lyapunov(system))
    p, why = plan(data, mode="largest")
    assert p is not None, why
    assert p.sdd == [True, False] and [len(b) for b in p.sigma] == [21, 6]
    prog = SddProgram(data, p)
    level = factor * DC.optimum(6)
    cand = prog.solve(level)
    assert cand.margin is not None and (cand.margin > 0) == ok
    if cand.sigma is None:
        return
    sigma = [(b, Q, "fresh" if s else None) for b, Q, s in zip(p.sigma, cand.sigma, p.sdd,
                                                                strict=True)]  # fmt: skip
    res = check_sdd(data, level, cand.eps, sigma, list(zip(p.lam, cand.lam, strict=True)))
    assert res.ok == ok


@pytest.fixture
def small_budget(monkeypatch):
    """A memory budget below the dense 6-state program's: the SDSOS route is taken."""
    import roa.search.sos_sdd as sdd
    import roa.search.sos_sparse as sparse

    monkeypatch.setattr(sparse, "MAX_SDP_BYTES", 2**16)
    # the 21-monomial even block needs 24 * 231^2 bytes (1.2 MiB) as a PSD block: over 1 MiB
    monkeypatch.setattr(sdd, "MAX_SDP_BYTES", 2**20)
    from roa.certification import sdd_route

    sdd_route._PROGRAMS.clear()
    yield
    sdd_route._PROGRAMS.clear()


def test_sdsos_route_certifies_reverifies_and_refuses_tampering(small_budget):
    system = DC.dense_cubic(6)
    opt = DC.optimum(6)
    cert = roa.certify(system, level=0.99 * opt, validator=roa.SosValidator())
    assert cert.status is Verdict.CERTIFIED, cert.message
    meta = cert.validation.meta
    assert meta["route"] == "sdsos" and meta["sdd_blocks"] == [21]
    data = json.loads(roa.io.to_json(cert.to_dict()))
    assert Certificate.from_dict(data, system).reverify().status is Verdict.CERTIFIED
    sdd = data["certificate"]["sdd"]
    assert "scaling" in sdd["sigma"][0] and "scaling" not in sdd["sigma"][1]

    def refused(edit) -> str:
        bad = copy.deepcopy(data)
        edit(bad["certificate"]["sdd"])
        v = Certificate.from_dict(bad, system).reverify()
        assert v.status is not Verdict.CERTIFIED
        return v.message

    def entry(s):  # one off-diagonal pair of the SDD block (identity broken)
        Q = s["sigma"][0]["Q"]
        Q[0][1] = Q[1][0] = str(Fraction(Q[0][1]) + Fraction(1, 2**20))

    assert "identity" in refused(entry)

    def weights(s):  # a scaling that does not dominate: one weight made tiny
        s["sigma"][0]["scaling"][0] = "1/1000000000"

    assert "dominant" in refused(weights)

    def negative(s):
        s["sigma"][0]["scaling"][1] = "-1"

    assert "dominant" in refused(negative)

    def dropped(s):  # without its scaling the block must pass the exact LDL' instead
        del s["sigma"][0]["scaling"]
        s["sigma"][0]["Q"][0][0] = "-1"

    assert "not" in refused(dropped)
    # a level above the optimum: V' > 0 at sqrt(1.001 opt) times the top eigenvector of B
    B = DC.matrices(6)[1]
    v = np.linalg.eigh(B)[1][:, -1]
    x = np.sqrt(1.001 * opt) * v
    assert 2 * float(x @ np.asarray(system.f(x), float)) > 0
    above = roa.certify(system, level=1.001 * opt, validator=roa.SosValidator())
    assert above.status is not Verdict.CERTIFIED


@pytest.mark.slow
def test_dense_cubic_20_states_certified_at_099_of_the_optimum():
    system = DC.dense_cubic(20)
    opt = DC.optimum(20)
    cert = roa.certify(system, validator=roa.SosValidator())
    assert cert.status is Verdict.CERTIFIED, cert.message
    assert 0.99 * opt <= cert.level <= opt
    assert cert.validation.meta["route"] == "sdsos"


@pytest.mark.parametrize("path", ["examples/systems/poly2d.py:SYSTEM",
                                  "examples/systems/shifted.py:SYSTEM",
                                  "examples/systems/ring.py:SYSTEM", "vanderpol"])  # fmt: skip
def test_ring_arithmetic_route_gives_the_generic_routes_polynomials(path, monkeypatch):
    import roa.proof.fast_poly as fp

    system = roa.load_system(path if ":" not in path else f"{ROOT / path}")
    V = roa.default_lyapunov(system)
    fast = exact_data(system, V)
    monkeypatch.setattr(fp, "field_polys", lambda *a, **k: None)
    assert exact_data(system, V) == fast


def test_ring_arithmetic_route_declines_what_is_not_polynomial():
    import sympy as sp

    from roa.proof.fast_poly import field_polys

    x, d = sp.symbols("x0"), sp.symbols("d0")
    with sp.evaluate(False):
        exprs = [sp.sin(x), x**-1, sp.sqrt(x), x * sp.Symbol("p")]
    for e in exprs:
        assert field_polys([e], [x], (Fraction(0),), [d]) is None
    with sp.evaluate(False):
        e = 0.1 * x**2 + sp.Rational(1, 3) * (x - 1) ** 3
    (p,) = field_polys([e], [x], (Fraction(1, 2),), [d])
    expected = sp.Poly(sp.expand(sp.Rational(0.1) * (d + sp.Rational(1, 2)) ** 2
                                 + sp.Rational(1, 3) * (d - sp.Rational(1, 2)) ** 3), d,
                       domain="QQ")  # fmt: skip
    assert p == expected
