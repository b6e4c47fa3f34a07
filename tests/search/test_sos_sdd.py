"""Dense coupled systems: sign-symmetry Gram blocks and scaled diagonally dominant (SDSOS) ones.

The SDSOS pattern (:func:`roa.search._sos_program.sdsos`, ``cone="sdd"`` blocks of the one
program :class:`roa.search._sdp.Program`) proposes; the one exact check
(:func:`roa.proof._putinar.check_identity`) proves an SDD block by exact scaled diagonal
dominance; the one stored form flags it (``"cone": "sdd"`` with its scaling). The dense cubic
example's closed-form optimum ``1 / lambda_max(B)`` is checked against SLSQP; tampered SDSOS
certificates are refused.
"""

from __future__ import annotations

import copy
import importlib.util
import json
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

import roa
import roa.io
from roa.certification import Certificate
from roa.proof._putinar import check_level, dd_scaling, dominance_margin
from roa.proof._sos_check import exact_data
from roa.search._sdp import monomials
from roa.search._sos_program import FixedLevel, choose_route, sdsos, sign_symmetries, split
from roa.status import Verdict

ROOT = Path(__file__).resolve().parents[2]


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
    classes = split(monomials(6, 2, 1), sign_symmetries([data.Vdot, data.V], 6))
    # V' = -2|x|^2 + 2 (x'Bx)|x|^2 with B dense: parities of x_i x_j x_k^2 span the even-weight
    # vectors, so the classes are odd (6 linear monomials) and even (21 quadratic ones)
    assert sorted(len(c) for c in classes) == [6, 21]
    assert {frozenset(sum(m) for m in c) for c in classes} == {frozenset({1}), frozenset({2})}


def test_sign_classes_of_a_field_with_more_symmetry():
    # x1' = -x1 + x1 x2^2, x2' = -x2: V = |x|^2, V' = -2 x1^2 + 2 x1^2 x2^2 - 2 x2^2 is even in
    # each variable separately: every monomial of degree 1..2 has its own parity class but
    # x1^2 and x2^2, which share the class 0
    system = roa.System("sym2", lambda t, x, xp: (-x[0] + x[0] * x[1] ** 2, -x[1]), (0.0, 0.0),
                        ("a", "b"), lyapunov=np.eye(2))  # fmt: skip
    data = exact_data(system, roa.default_lyapunov(system))
    classes = split(monomials(2, 2, 1), sign_symmetries([data.Vdot, data.V], 2))
    assert sorted(len(c) for c in classes) == [1, 1, 1, 2]


def test_dominance_check_is_exact():
    S = [[Fraction(2), Fraction(-1)], [Fraction(-1), Fraction(2)]]
    assert dominance_margin(S, [Fraction(1), Fraction(1)]) == 1
    # [[1, 2], [2, 5]] is positive definite and scaled diagonally dominant with w = (w1, 1) for
    # w1 in (2, 2.5) only (row 1: w1 - 2 > 0; row 2: 5 - 2 w1 > 0): w = (9/4, 1) gives 1/4, 1/2
    T = [[Fraction(1), Fraction(2)], [Fraction(2), Fraction(5)]]
    assert dominance_margin(T, [Fraction(9, 4), Fraction(1)]) == Fraction(1, 4)
    assert dominance_margin(T, [Fraction(1), Fraction(1)]) < 0
    w = dd_scaling(T)
    assert w is not None and dominance_margin(T, w) > 0
    assert dominance_margin(T, [Fraction(1), Fraction(0)]) is None  # not positive
    assert (
        dd_scaling([[Fraction(1), Fraction(2)], [Fraction(2), Fraction(1)]]) is None
    )  # indefinite


def test_sdsos_plan_makes_the_largest_blocks_sdd_until_the_estimate_fits(monkeypatch):
    import roa.search._sos_program as sparse
    from roa.search._sdp import sdd_bytes, sdp_bytes

    data = exact_data(DC.dense_cubic(6), roa.default_lyapunov(DC.dense_cubic(6)))
    p, why = sdsos(data)
    assert p is not None and not any(p.sdd), why  # the dense program fits: nothing SDD
    assert [len(b) for b in p.sigma] == [21, 6] and [len(b) for b in p.lam] == [6]
    # a budget between the SDD and the PSD estimate of the 21 block: that block only is SDD
    budget = sdd_bytes(21) + 2 * sdp_bytes(6)
    assert budget < sdp_bytes(21) + 2 * sdp_bytes(6)
    monkeypatch.setattr(sparse, "MAX_SDP_BYTES", budget)
    p, why = sdsos(data)
    assert p is not None and p.sdd == (True, False), why
    assert p.bytes == sdd_bytes(21) + 2 * sdp_bytes(6)
    monkeypatch.setattr(sparse, "MAX_SDP_BYTES", sdd_bytes(21))
    p, why = sdsos(data)
    assert p is None and "even with" in why
    route, _, why = choose_route(data)
    assert route == "too_large" and "SDSOS" in why


@pytest.mark.parametrize("factor, ok", [(0.99, True), (1.01, False)])
def test_sdd_program_certifies_below_the_optimum_only(factor, ok):
    system = DC.dense_cubic(6)
    data = exact_data(system, roa.default_lyapunov(system))
    p, why = sdsos(data, force=True)
    assert p is not None, why
    assert p.sdd == (True, False) and [len(b) for b in p.sigma] == [21, 6]
    prog = FixedLevel(data, p)
    level = factor * DC.optimum(6)
    cand = prog.solve(level)
    assert cand.margin is not None and (cand.margin > 0) == ok
    if cand.certificate is None:
        return
    assert cand.certificate.cones.count("sdd") == 1
    res = check_level(data, level, cand.eps, cand.certificate)
    assert res.ok == ok
    if ok:  # the SDD block is proved by dominance, with the scaling the certificate stores
        assert res.certificate is not None
        w = [c for c in res.certificate.cones if c != "psd"]
        assert len(w) == 1 and all(v > 0 for v in w[0])
        assert "scaled diagonally dominant" in res.reason


def test_sdsos_route_certifies_reverifies_and_refuses_tampering():
    system = DC.dense_cubic(6)
    opt = DC.optimum(6)
    sdsos = roa.SosValidator(route="sdsos")
    cert = roa.certify(system, level=0.99 * opt, validator=sdsos)
    assert cert.status is Verdict.CERTIFIED, cert.message
    meta = cert.validation.meta
    assert meta["route"] == "sdsos" and meta["blocks"]["sdd_blocks"] == [21]
    data = json.loads(roa.io.to_json(cert.to_dict()))
    assert Certificate.from_dict(data, system).reverify().status is Verdict.CERTIFIED
    grams = data["certificate"]["parts"][0]["grams"]
    flagged = [i for i, g in enumerate(grams) if g.get("cone") == "sdd"]
    assert len(flagged) == 1 and len(grams[flagged[0]]["scaling"]) == 21
    assert all("scaling" not in g for i, g in enumerate(grams) if i not in flagged)
    k = flagged[0]

    def refused(edit) -> str:
        bad = copy.deepcopy(data)
        edit(bad["certificate"]["parts"][0]["grams"][k])
        v = Certificate.from_dict(bad, system).reverify()
        assert v.status is not Verdict.CERTIFIED
        return v.message

    def entry(g):  # one off-diagonal pair of the SDD block (identity broken)
        Q = g["Q"]
        Q[0][1] = Q[1][0] = str(Fraction(Q[0][1]) + Fraction(1, 2**20))

    assert "identity" in refused(entry)

    def weights(g):  # a scaling that does not dominate: one weight made tiny
        g["scaling"][0] = "1/1000000000"

    assert "dominant" in refused(weights)

    def negative(g):
        g["scaling"][1] = "-1"

    assert "dominant" in refused(negative)

    def short(g):
        g["scaling"].pop()

    assert "malformed" in refused(short)

    def unflagged(g):  # a scaling without the flag, or a cone of another name
        del g["cone"]

    assert "malformed" in refused(unflagged)

    def other(g):
        g["cone"] = "dsos"

    assert "malformed" in refused(other)

    def dropped(g):  # without flag and scaling the block must pass the exact LDL' instead
        del g["cone"], g["scaling"]
        g["Q"][0][0] = "-1"

    assert "not" in refused(dropped)
    # a level above the optimum: V' > 0 at sqrt(1.001 opt) times the top eigenvector of B
    B = DC.matrices(6)[1]
    v = np.linalg.eigh(B)[1][:, -1]
    x = np.sqrt(1.001 * opt) * v
    assert 2 * float(x @ np.asarray(system.f(x), float)) > 0
    above = roa.certify(system, level=1.001 * opt, validator=sdsos)
    assert above.status is not Verdict.CERTIFIED


def test_an_sdd_block_without_its_flag_is_proved_by_ldl():
    """The flag only chooses the proof of definiteness: a stored SDSOS certificate whose flags
    and scalings are removed passes the exact LDL' (an SDD matrix is positive definite)."""
    system = DC.dense_cubic(6)
    cert = roa.certify(system, level=0.9 * DC.optimum(6), validator=roa.SosValidator(route="sdsos"))
    assert cert.status is Verdict.CERTIFIED, cert.message
    data = json.loads(roa.io.to_json(cert.to_dict()))
    for g in data["certificate"]["parts"][0]["grams"]:
        g.pop("cone", None), g.pop("scaling", None)
    v = Certificate.from_dict(data, system).reverify()
    assert v.status is Verdict.CERTIFIED and "dominant" not in v.message


def test_auto_route_takes_sdsos_when_the_dense_program_is_over_budget(monkeypatch):
    import roa.search._sos_program as sparse
    from roa.search._sdp import sdd_bytes, sdp_bytes

    # below the dense 27-monomial block's estimate, above the SDSOS pattern's
    monkeypatch.setattr(sparse, "MAX_SDP_BYTES", sdd_bytes(21) + 2 * sdp_bytes(6))
    system = DC.dense_cubic(6)
    v = roa.SosValidator().check(system, roa.default_lyapunov(system), 0.99 * DC.optimum(6))
    assert v.status is Verdict.CERTIFIED, v.message
    assert v.meta["route"] == "sdsos" and v.meta["blocks"]["sdd_blocks"] == [21]


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
    import roa.proof._fast_poly as fp

    system = roa.load_system(path if ":" not in path else f"{ROOT / path}")
    V = roa.default_lyapunov(system)
    fast = exact_data(system, V)
    monkeypatch.setattr(fp, "field_polys", lambda *a, **k: None)
    assert exact_data(system, V) == fast


def test_ring_arithmetic_route_declines_what_is_not_polynomial():
    import sympy as sp

    from roa.proof._fast_poly import field_polys

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
