"""The declared domain is a precondition of every certificate, on every route and re-check.

The boundary levels are derived in ``examples/systems/domain.py``: 0.3125 for Van der Pol on
``|x1| < 0.5`` (``0.25 / (P^-1)_11``), 0.09 for the 5-cell ring on ``|x1| < 0.3``.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import roa
import roa.io
from roa.certification._result import Certificate
from roa.cli import main
from roa.errors import RoaInputError
from roa.montecarlo._certified_set import terminal_from_certificate
from roa.proof._preconditions import PRECONDITIONS, Route, check_preconditions
from roa.search._outside import domain_witness
from roa.search._rays import ray_box
from roa.status import Verdict

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "systems" / "domain.py"
_spec = importlib.util.spec_from_file_location("domain_example", EXAMPLE)
assert _spec is not None and _spec.loader is not None
dom = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(dom)

VALIDATORS = ("auto", "sos", "interval")
CASES = [(dom.VDP, dom.BOUNDARY_VDP), (dom.RING, dom.BOUNDARY_RING)]


def test_the_boundary_levels_are_what_the_docstring_derives():
    P = np.array(dom.P_VDP)
    assert dom.BOUNDARY_VDP == pytest.approx(0.25 / np.linalg.inv(P)[0, 0], rel=1e-15)
    # the minimiser of d'Pd on d1 = 0.5: d2 = -P12 d1 / P22 = 0.25, V = 0.3125
    d = np.array([0.5, 0.25])
    assert d @ P @ d == pytest.approx(dom.BOUNDARY_VDP, rel=1e-15)


@pytest.mark.parametrize("validator", VALIDATORS)
@pytest.mark.parametrize("system,boundary", CASES, ids=["vanderpol-strip", "ring-5-slab"])
def test_a_level_above_the_boundary_is_refuted_on_every_route(system, boundary, validator):
    for level in (1.001 * boundary, 0.5 if system is dom.RING else 2.0):
        cert = roa.certify(system, level=level, validator=validator)
        assert cert.status is Verdict.REFUTED, cert.message
        assert "leaves the domain" in cert.message
        w = np.asarray(cert.validation.meta["domain_witness"])
        assert not system.inside(w[None])[0]
        assert cert.validation.meta["domain_check"]["confirmed"]


@pytest.mark.parametrize("system,boundary", CASES, ids=["vanderpol-strip", "ring-5-slab"])
def test_the_found_level_stays_below_the_boundary_and_just_above_is_refuted(system, boundary):
    cert = roa.certify(system, check_above=1.001)
    assert cert.certified, cert.message
    assert 0.99 * boundary < cert.level <= boundary  # certified up to the boundary, not past it
    assert "outside the domain" in cert.message  # the SOS proposal (2.3 / 0.93) was refuted
    sos_form = cert.validation.meta.get("certificate")
    if cert.method == "sos-exact":
        assert sos_form["domain"]["Q0"]  # the domain's Putinar certificate travels with it
    # refute just above: the witness of the domain's boundary
    above = roa.certify(system, level=min(1.001 * cert.level, 1.001 * boundary))
    assert above.status is Verdict.REFUTED


def _old_certificate(system, level):
    """The certificate file the SOS route wrote before the domain was a precondition: the
    route's own proof without any precondition (what ``roa certify`` printed as certified)."""
    V = roa.default_lyapunov(system)
    v = roa.SosValidator()._prove(system, V, level)
    assert v.status is Verdict.CERTIFIED  # V' < 0 does hold on the set: only the domain fails
    cert = Certificate(status=v.status, level=level, method="sos-exact", level_source="given",
                       seconds=0.0, message=v.message, validation=v, system=system, V=V)  # fmt: skip
    return json.loads(roa.io.to_json(cert.to_dict()))


@pytest.mark.parametrize("system,level", [(dom.VDP, 2.0), (dom.RING, 0.5)],
                         ids=["vanderpol-strip", "ring-5-slab"])  # fmt: skip
def test_old_certificate_files_are_refused_by_verify_and_terminal_set(system, level, tmp_path,
                                                                      capsys):  # fmt: skip
    data = _old_certificate(system, level)
    path = tmp_path / "old.json"
    path.write_text(json.dumps(data))
    arg = f"{EXAMPLE}:{'VDP' if system is dom.VDP else 'RING'}"
    assert main(["verify", str(path), "--system", arg, "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "refuted" and "leaves the domain" in out["message"]
    with pytest.raises(RoaInputError, match="re-verification failed"):
        terminal_from_certificate(data, system)


def test_a_stored_domain_certificate_is_rechecked_as_stored_and_tampering_is_refused():
    level = 0.3
    cert = roa.certify(dom.VDP, level=level, validator="sos")
    assert cert.certified and cert.method == "sos-exact", cert.message
    data = json.loads(roa.io.to_json(cert.to_dict()))
    domain = data["certificate"]["domain"]
    again = Certificate.from_dict(data, dom.VDP).reverify()
    assert again.certified and "Putinar certificate" in again.message, again.message
    # independent check of the stored identity in sympy: margin - eps - lambda (c - V) = m0'Q0m0
    d = sp.symbols("d0:2")
    mono = lambda b: sp.Mul(*(di**k for di, k in zip(d, b, strict=True)))  # noqa: E731

    def gram(basis, Q):
        return sum(
            sp.Rational(Q[i][j]) * mono(bi) * mono(bj)  # noqa: E731
            for i, bi in enumerate(basis)
            for j, bj in enumerate(basis)
        )

    P = [[sp.Rational(Fraction(v)) for v in row] for row in dom.P_VDP]
    V = sum(P[i][j] * d[i] * d[j] for i in range(2) for j in range(2))
    margin = (d[0] + sp.Rational(1, 2)) * (sp.Rational(1, 2) - d[0])
    lam = gram(domain["basis1"], domain["Q1"])
    lhs = margin - sp.Rational(domain["eps"]) - lam * (sp.Rational(Fraction(level)) - V)
    assert sp.expand(lhs - gram(domain["basis0"], domain["Q0"])) == 0
    for Q in (domain["Q0"], domain["Q1"]):
        assert all(ev > 0 for ev in sp.Matrix([[sp.Rational(v) for v in r] for r in Q]).eigenvals())
    # one Gram entry of the domain certificate edited: refused, nothing projected back
    bad = json.loads(json.dumps(data))
    q = bad["certificate"]["domain"]["Q0"]
    q[1][1] = str(Fraction(q[1][1]) + Fraction(1, 1000))
    r = Certificate.from_dict(bad, dom.VDP).reverify()
    assert r.status is Verdict.INCONCLUSIVE and "domain certificate refused" in r.message
    # its level raised past the boundary: refuted by the witness, whatever the file says
    raised = {**data, "level": 0.32}
    assert Certificate.from_dict(raised, dom.VDP).reverify().status is Verdict.REFUTED


def test_a_tampered_gram_entry_of_the_sos_certificate_is_refused():
    cert = roa.certify(dom.VDP, level=0.3, validator="sos")
    data = json.loads(roa.io.to_json(cert.to_dict()))
    bad = json.loads(json.dumps(data))
    q = bad["certificate"]["parts"][0]["grams"][0]["Q"]
    q[0][0] = str(Fraction(q[0][0]) * 2)
    r = Certificate.from_dict(bad, dom.VDP).reverify()
    assert r.status is Verdict.INCONCLUSIVE and "does not hold exactly as stored" in r.message


# -- every precondition, every route ------------------------------------------------------------------
ROUTES = {
    "interval": Route("interval", parameters=True, cover=True, domain_by_boxes=True),
    "sos-exact": Route("sos-exact", parameters=True),
    "sos-recheck": Route("sos-exact", parameters=True),
}


def _broken(name):
    """(system, V, level) breaking precondition ``name`` only."""
    base = dom.VDP
    V = roa.default_lyapunov(base)
    if name == "autonomous":
        return dataclasses.replace(base, time_varying=True), V, 0.3
    if name == "equilibrium":
        return base, roa.QuadraticLyapunov(np.array(dom.P_VDP), np.array([0.1, 0.0])), 0.3
    if name == "level":
        return base, V, float("nan")
    if name == "parameters":
        return base, V, 0.3  # a route that proves one field (checked below with such a route)
    if name == "bounded":
        indefinite = roa.PolynomialLyapunov([[2, 0], [0, 2]], [1.0, -1.0], [0.0, 0.0], "saddle")
        return base, indefinite, 0.3
    if name == "invariant":  # a map, and a V with no Gram matrix: only a component cover
        from roa.systems.cubic_map import cubic_map

        V = roa.FunctionLyapunov(lambda x, xp: x[0] ** 2 + x[1] ** 2, [0.0, 0.0], "no Gram")
        return cubic_map(), V, 0.3
    return base, V, 2.0  # domain


#: 'bounded' on the branch and bound is its own cover proof (prove_cover), not a precondition
PAIRS = [(n, r) for n in PRECONDITIONS for r in sorted(ROUTES)
         if not (n == "bounded" and ROUTES[r].cover)]  # fmt: skip


@pytest.mark.parametrize("name,route", PAIRS)
def test_each_precondition_is_refused_on_each_route(name, route):
    from roa.systems.vanderpol import vanderpol

    system, V, level = _broken(name)
    r = ROUTES[route]
    if name == "parameters":  # a box of mu on a route that proves one field
        system = vanderpol().with_ranges(mu=(0.8, 1.2))
        V = roa.default_lyapunov(vanderpol())
        r = dataclasses.replace(r, parameters=False)
    pre = check_preconditions(system, V, level, r, recheck=route == "sos-recheck",
                              find_outside=domain_witness, cover_estimate=ray_box)  # fmt: skip
    assert pre.refusal is not None
    assert pre.refusal.meta["precondition"] == name, pre.refusal.message
    expected = Verdict.REFUTED if name == "domain" else Verdict.INCONCLUSIVE
    assert pre.refusal.status is expected
    ok = check_preconditions(dom.VDP, roa.default_lyapunov(dom.VDP), 0.3, r,
                             find_outside=domain_witness, cover_estimate=ray_box)  # fmt: skip
    assert ok.refusal is None


@pytest.mark.parametrize("validator", [roa.IntervalValidator(), roa.SosValidator(),
                                       roa.AutoValidator()])  # fmt: skip
def test_every_validator_refuses_a_set_leaving_the_domain(validator):
    V = roa.default_lyapunov(dom.VDP)
    v = validator.check(dom.VDP, V, 2.0)
    assert v.status is Verdict.REFUTED and v.meta["precondition"] == "domain", v.message
    assert validator.check(dom.VDP, V, 0.3).status is Verdict.CERTIFIED


def test_an_interval_certificate_raised_past_the_boundary_is_refuted_on_reverification():
    cert = roa.certify(dom.VDP, level=0.3, validator="interval")
    assert cert.certified and cert.method == "interval", cert.message
    data = json.loads(roa.io.to_json(cert.to_dict()))
    assert Certificate.from_dict(data, dom.VDP).reverify().certified
    r = Certificate.from_dict({**data, "level": 2.0}, dom.VDP).reverify()
    assert r.status is Verdict.REFUTED and "leaves the domain" in r.message
