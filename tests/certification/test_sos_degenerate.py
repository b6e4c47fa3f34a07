"""Degenerate equilibria (V' starting at degree 4): Drake's non-convex example, certified exactly.

``examples/systems/drake_nonconvex.py`` derives ``rho = sqrt(d / max_{|u|=1} |A1 u|^2 |A2 u|^2)``;
the maximum is computed here independently (a fine grid of the unit circle polished by scipy).
"""

from __future__ import annotations

import importlib.util
import json
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import roa
import roa.io
from roa.certification._result import Certificate
from roa.proof._sos_check import exact_data
from roa.search._sos_program import degrees, propose
from roa.status import Verdict

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "systems" / "drake_nonconvex.py"
_spec = importlib.util.spec_from_file_location("drake_nonconvex", EXAMPLE)
assert _spec is not None and _spec.loader is not None
dn = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(dn)


def _rho(d: float) -> float:
    def U0(t: float) -> float:
        u = np.array([np.cos(t), np.sin(t)])
        return float(np.sum((dn.A1 @ u) ** 2) * np.sum((dn.A2 @ u) ** 2))

    grid = np.linspace(0, np.pi, 20001)
    t0 = grid[np.argmax([U0(t) for t in grid])]
    best = minimize_scalar(lambda t: -U0(t), bracket=(t0 - 1e-3, t0, t0 + 1e-3), tol=1e-12)
    return float(np.sqrt(d / -best.fun))


@pytest.mark.parametrize("system,d", [(dn.D1, 1.0), (dn.D100, 100.0)], ids=["d1", "d100"])
def test_drake_nonconvex_certified_at_0995_of_rho_and_refuted_above(system, d):
    rho = _rho(d)
    assert rho == pytest.approx(0.05 if d == 1 else 0.5, rel=1e-9)  # the docstring's values
    cert = roa.certify(system, level=0.995 * rho, validator=roa.SosValidator(fallback=False))
    assert cert.certified and cert.method == "sos-exact", cert.message
    data = json.loads(roa.io.to_json(cert.to_dict()))
    assert Certificate.from_dict(data, system).reverify().certified
    above = roa.certify(system, level=1.001 * rho)
    assert above.status is Verdict.REFUTED, above.message


def test_the_multiplier_basis_starts_where_the_identity_allows():
    """V' starts at degree 2k = 4: lambda's terms below degree 4 are forced to zero, so its Gram
    basis starts at degree k = 2 (a basis with degree-1 monomials has no strictly feasible
    point)."""
    V = roa.default_lyapunov(dn.D100)
    data = exact_data(dn.D100, V)
    assert data.low == 4
    k, _, L = degrees(data)
    assert k == 2 and L >= k
    cand = propose(data, 0.4)
    for factor in (0, 1):  # the SOS part and the level's multiplier, over all their blocks
        assert min(sum(m) for b, _ in cand.certificate.blocks(factor) for m in b) == 2


def test_a_rescaled_certificate_is_refused_with_another_scale_or_none(monkeypatch):
    """The check in rescaled variables ``d = diag(scale) y`` (taken when the unscaled check
    fails; made to fail here, since whether it does depends on the solver's version): its stored
    certificate holds the scale, and another scale, a negated one or none is refused."""
    from roa.certification._strategies import SosValidator

    prove, calls = SosValidator._prove_data, []

    def unscaled_fails(self, data, V, level, out, recast=None):
        calls.append(data)
        if len(calls) == 1:
            return out(Verdict.INCONCLUSIVE, "the unscaled check is made to fail")
        return prove(self, data, V, level, out, recast)

    monkeypatch.setattr(SosValidator, "_prove_data", unscaled_fails)
    cert = roa.certify(dn.D1, level=0.995 * 0.05, validator=roa.SosValidator(fallback=False))
    monkeypatch.undo()
    assert cert.certified, cert.message
    assert len(calls) == 2 and "diag(scale)" in cert.message
    data = json.loads(roa.io.to_json(cert.to_dict()))
    assert data["certificate"]["scale"] == ["1/4", "1/4"]
    for bad in (["1/2", "1/4"], ["-1/4", "1/4"], None, ["1/4"]):
        forged = json.loads(json.dumps(data))
        if bad is None:
            del forged["certificate"]["scale"]
        else:
            forged["certificate"]["scale"] = bad
        r = Certificate.from_dict(forged, dn.D1).reverify()
        assert r.status is Verdict.INCONCLUSIVE, (bad, r.message)
    assert Fraction(data["certificate"]["scale"][0]) ** 2 * 16 == 1
