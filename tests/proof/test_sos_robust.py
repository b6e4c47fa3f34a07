"""Exact SOS certificates for a parameter box (:class:`roa.proof.ParameterBox`).

Optima are independent of roa: Van der Pol's from multistart SLSQP of min V s.t. V' = 0 at both
ends of the box (V' is affine in mu, so for each state the largest V' over the box is at an end:
the worst level is the lower of the two ends'); the two-parameter example's in closed form (its
docstring), confirmed by SLSQP at the four vertices.
"""

from __future__ import annotations

import json
import math
from fractions import Fraction

import numpy as np
import pytest
from references import VDP_P as P, ring_slsqp, vdp_optimum

import roa
import roa.io
from roa.certification import Certificate
from roa.model._system import System
from roa.proof._sos_stored import recheck as recheck_stored
from roa.search._candidate import as_lyapunov
from roa.search._rays import ray_box
from roa.status import Verdict


def _vdp(low: float, high: float) -> System:
    return roa.load_system("vanderpol").with_ranges(mu=(low, high))


@pytest.fixture(scope="module")
def worst() -> float:
    w = min(vdp_optimum(0.8), vdp_optimum(1.2))
    assert w == pytest.approx(2.0357, rel=2e-4)  # at mu = 0.8 (the figure)
    assert vdp_optimum(0.8) < vdp_optimum(1.2)
    return w


@pytest.fixture(scope="module")
def box_cert(worst):
    s = _vdp(0.8, 1.2)
    V = as_lyapunov(s, P)
    cert = roa.certify(s, V, level=0.95 * worst, validator=roa.SosValidator(fallback=False))
    return s, V, cert


def test_vdp_box_certified_at_095_of_the_worst_case(box_cert, worst):
    s, V, cert = box_cert
    assert cert.status is Verdict.CERTIFIED and cert.method == "sos-exact", cert.message
    assert "for every mu in [0.8, 1.2]" in cert.message
    assert cert.validation.meta["min_pivot"] > 0
    assert cert.validation.meta["certificate"]["parameters"] == {
        "mu": [str(Fraction(0.8)), str(Fraction(1.2))]
    }


def test_vdp_box_never_above_the_worst_case(worst):
    s = _vdp(0.8, 1.2)
    V = as_lyapunov(s, P)
    above = roa.SosValidator(fallback=False).check(s, V, 1.01 * worst)
    assert above.status is Verdict.INCONCLUSIVE  # no certificate can exist there
    # the level the SOS route finds itself: between 0.95 x and 1 x the worst case, and the
    # branch and bound refutes 1 % above it with a witness at mu = 0.8
    found = roa.certify(s, V, validator=roa.SosValidator(fallback=False), check_above=1.01)
    assert found.status is Verdict.CERTIFIED and found.method == "sos-exact", found.message
    assert 0.95 * worst <= found.level <= worst
    assert found.above is not None and found.above.status is Verdict.REFUTED
    assert found.above.witness_parameters == {"mu": 0.8}


def test_stored_box_certificate_rechecked_and_tampering_refused(box_cert, worst):
    s, V, cert = box_cert
    data = json.loads(roa.io.to_json(cert.to_dict()))
    assert data["parameters"] == {"mu": {"low": 0.8, "nominal": 1.0, "high": 1.2}}
    again = Certificate.from_dict(data, s).reverify()
    assert again.certified and again.method == "sos-exact", again.message

    def refused(d: dict, words: str) -> None:
        r = Certificate.from_dict(d, s).reverify()
        assert r.status is Verdict.INCONCLUSIVE and words in r.message, r.message

    refused({**data, "level": 1.01 * worst}, "refused")  # raised above the worst case
    grams = data["certificate"]["parts"][0]["grams"]
    # sigma0, lambda, the box multiplier (no other constraint), split by sign symmetry
    assert sorted({g["multiplies"] for g in grams}) == [0, 1, 2]
    # the multiplier of the box constraint negated
    bad = json.loads(json.dumps(data))
    g = next(g for g in bad["certificate"]["parts"][0]["grams"] if g["multiplies"] == 2)
    g["Q"] = [[v[1:] if v.startswith("-") else f"-{v}" for v in row] for row in g["Q"]]
    refused(bad, "not positive definite")  # checked as stored, nothing projected
    # Q0 indefinite with every coefficient of the identity unchanged: +a on the (y0^2, y1^2)
    # pair, -2a on (y0 y1, y0 y1)
    forged = json.loads(json.dumps(data))
    mons = ((2, 0, 0), (1, 1, 0), (0, 2, 0))
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
    refused(forged, "projected Gram matrix")
    # a narrower box written in the file: the system's box decides, the file's is refused
    narrow = json.loads(json.dumps(data))
    narrow["certificate"]["parameters"] = {"mu": ["9/10", "11/10"]}
    refused(narrow, "made for the parameter box")
    # and no stored box at all (a certificate of one field presented for the box)
    del narrow["certificate"]["parameters"]
    refused(narrow, "made for the parameter box")


def test_certificate_of_a_narrower_box_refused_for_the_wider_one():
    """A certificate proved for mu in [1.0, 1.2] at a level above the worst case of [0.8, 1.2]
    is refused for the wider box: by the fingerprint of the file, and by the exact check itself
    when its stored box is forged to the wider one (no certificate can exist there)."""
    top = vdp_optimum(0.8)
    narrow_sys = _vdp(1.0, 1.2)
    level = 1.02 * top
    assert level < 0.98 * min(vdp_optimum(1.0), vdp_optimum(1.2))  # valid for [1.0, 1.2]
    V = as_lyapunov(narrow_sys, P)
    cert = roa.certify(narrow_sys, V, level=level, validator=roa.SosValidator(fallback=False))
    assert cert.status is Verdict.CERTIFIED, cert.message
    wide = _vdp(0.8, 1.2)
    data = json.loads(roa.io.to_json(cert.to_dict()))
    with pytest.raises(roa.RoaInputError, match="another system"):
        Certificate.from_dict(data, wide)
    meta = json.loads(json.dumps(cert.validation.meta, default=str))
    meta["certificate"]["parameters"] = {"mu": [str(Fraction(0.8)), str(Fraction(1.2))]}
    r = recheck_stored(wide, V, level, meta, cover_estimate=ray_box)
    assert r.status is Verdict.INCONCLUSIVE and "does not hold exactly" in r.message, r.message


def test_box_reaching_mu_05_is_never_certified():
    """At mu = 0.5 the linearisation's A'P + PA has a positive eigenvalue (computed here):
    V' > 0 arbitrarily near the equilibrium, so no level holds for a box containing 0.5."""
    A = np.array([[0.0, -1.0], [1.0, -0.5]])  # d/dx of (-x2, x1 + mu (x1^2 - 1) x2) at 0
    assert np.linalg.eigvalsh(A.T @ P + P @ A).max() > 0.05
    s = _vdp(0.5, 1.2)
    V = as_lyapunov(s, P)
    for level in (0.01, 0.5):
        v = roa.SosValidator(fallback=False).check(s, V, level)
        assert v.status is Verdict.INCONCLUSIVE, v.message


def two_parameter_system(b_high: float = 1.0) -> System:
    """``x1' = -a x1 + x2``, ``x2' = -x1 - x2 + b x1^2 x2`` with V = x1^2 + x2^2:
    ``V' = -2 a x1^2 - 2 x2^2 + 2 b x1^2 x2^2``. On ``V' = 0`` (``u = x1^2``, ``v = x2^2``):
    ``v = a u / (b u - 1)``, ``V = u + v`` is least at ``b u - 1 = sqrt(a)``, where
    ``V = (1 + sqrt(a))^2 / b``; V' is affine in (a, b), so over a < 1 box the worst case is
    the least of that at the vertices: a = 0.5, b = 1 gives (1 + sqrt(0.5))^2 = 2.9142."""

    def field(t, x, xp, p):
        return (-p.a * x[0] + x[1], -x[0] - x[1] + p.b * x[0] * x[0] * x[1])

    return System("two", field, (0.0, 0.0), ("x1", "x2"),
                  parameters={"a": (0.5, 1.0, 1.5), "b": (0.5, 0.75, b_high)})  # fmt: skip


def test_two_parameter_polynomial_box():
    s = two_parameter_system()
    V = as_lyapunov(s, np.eye(2))
    closed = (1 + math.sqrt(0.5)) ** 2
    vertices = []
    for a in (0.5, 1.5):
        for b in (0.5, 1.0):

            def vdot(x, a=a, b=b):
                return float(-2 * a * x[0] ** 2 - 2 * x[1] ** 2 + 2 * b * x[0] ** 2 * x[1] ** 2)

            vertices.append(ring_slsqp(vdot, np.eye(2), starts=40))
    assert min(vertices) == pytest.approx(closed, rel=1e-6)
    ok = roa.certify(s, V, level=0.95 * closed, validator=roa.SosValidator(fallback=False))
    assert ok.status is Verdict.CERTIFIED and ok.method == "sos-exact", ok.message
    assert "a in [0.5, 1.5], b in [0.5, 1.0]" in ok.message
    grams = ok.validation.meta["certificate"]["parts"][0]["grams"]
    assert sorted({g["multiplies"] for g in grams}) == [0, 1, 2, 3]  # one multiplier per parameter
    data = json.loads(roa.io.to_json(ok.to_dict()))
    assert Certificate.from_dict(data, s).reverify().certified
    above = roa.SosValidator(fallback=False).check(s, V, 1.01 * closed)
    assert above.status is Verdict.INCONCLUSIVE
    # b up to 1.2: the worst case drops to closed / 1.2, below the level, which is not certified
    wider = two_parameter_system(b_high=1.2)
    assert (1 + math.sqrt(0.5)) ** 2 / 1.2 < 0.95 * closed
    v = roa.SosValidator(fallback=False).check(wider, V, 0.95 * closed)
    assert v.status is Verdict.INCONCLUSIVE


def _pendulum_field(t, x, xp, p):
    return (x[1], -xp.sin(x[0]) - p.b * x[1])


@pytest.mark.slow
def test_recast_pendulum_with_uncertain_damping():
    """sin recast and a parameter box together: the damped pendulum with b in [0.8, 1.2] and
    the V of A'P + PA = -I at b = 1 (P = [[1.5, 0.5], [0.5, 1]]). V' is affine in b, so the
    worst case is the lower of the two ends' SLSQP optima (8.5608 at b = 0.8): 0.95 x it is
    certified and re-checked from the file, 1.005 x it is not."""
    Pp = np.array([[1.5, 0.5], [0.5, 1.0]])

    def optimum(b: float) -> float:
        def vdot(x):
            return float(2 * x @ Pp @ np.array([x[1], -np.sin(x[0]) - b * x[1]]))

        return ring_slsqp(vdot, Pp, starts=40)

    worst = min(optimum(0.8), optimum(1.2))
    assert worst == pytest.approx(8.5608, rel=1e-4) and optimum(0.8) < optimum(1.2)
    box = System("pendulum-b", _pendulum_field, (0.0, 0.0), ("theta", "omega"),
                 parameters={"b": (0.8, 1.0, 1.2)})  # fmt: skip
    V = as_lyapunov(box, Pp)
    cert = roa.certify(box, V, level=0.95 * worst, validator=roa.SosValidator(fallback=False))
    assert cert.status is Verdict.CERTIFIED and cert.method == "sos-exact", cert.message
    assert "sin/cos(d0)" in cert.message and "for every b in [0.8, 1.2]" in cert.message
    data = json.loads(roa.io.to_json(cert.to_dict()))
    assert Certificate.from_dict(data, box).reverify().certified
    above = roa.SosValidator(fallback=False).check(box, V, 1.005 * worst)
    assert above.status is Verdict.INCONCLUSIVE


def _poly_field(t, x, xp, p):
    A = 1 - (2 * p.a - 1) ** 2
    return (-x[0] + A * x[0] ** 3 + p.c * x[0] * x[1] ** 2 / 2,
            -x[1] + p.b * x[1] ** 3 + p.c * x[0] ** 2 * x[1] / 2)  # fmt: skip


def test_worst_case_inside_the_box_with_three_parameters():
    """V' quadratic (not affine) in a: ``x1' = -x1 + A(a) x1^3 + (c/2) x1 x2^2``,
    ``x2' = -x2 + b x2^3 + (c/2) x1^2 x2``, ``A(a) = 1 - (2a - 1)^2``, V = |x|^2 (the benchmark
    of benchmarks/bench_robust.py). With ``x1^2 = s r``, ``x2^2 = (1 - s) r``, ``r = V``:
    ``V'/2 = -r + r^2 q(s)``, ``q = A s^2 + b (1 - s)^2 + c s (1 - s)``, increasing in A, b, c:
    the worst case is A = 1 (a = 1/2, inside the box), b = 0.6, c = 3, where max q = q(1/2) =
    33/28, so the largest level is 28/33. Certified at 0.99 x it, not at 1.01 x it."""
    s = System("poly3", _poly_field, (0.0, 0.0), ("x1", "x2"),
               parameters={"a": (0.0, 0.25, 1.0), "b": (0.2, 0.4, 0.6), "c": (2.0, 2.5, 3.0)})  # fmt: skip
    q = np.linspace(0, 1, 100001)
    assert (q * q + 0.6 * (1 - q) ** 2 + 3 * q * (1 - q)).max() == pytest.approx(33 / 28)
    V = as_lyapunov(s, np.eye(2))
    worst = 28 / 33
    sos = roa.SosValidator(fallback=False)
    ok = sos.check(s, V, 0.99 * worst)
    assert ok.status is Verdict.CERTIFIED, ok.message
    factors = {g["multiplies"] for g in ok.meta["certificate"]["parts"][0]["grams"]}
    assert sorted(factors) == [0, 1, 2, 3, 4]  # sigma0, lambda, 3 boxes
    assert sos.check(s, V, 1.01 * worst).status is Verdict.INCONCLUSIVE


def test_cli_verify_rechecks_a_box_certificate(box_cert, worst, tmp_path, capsys):
    """``roa verify CERT --system vanderpol --param mu=0.8..1.2`` re-checks the stored SOS
    certificate with the box from the command line; a raised level is refused, and another box
    is refused by the fingerprint."""
    from roa.cli import main

    s, V, cert = box_cert
    data = json.loads(roa.io.to_json(cert.to_dict()))
    good, raised = tmp_path / "good.json", tmp_path / "raised.json"
    good.write_text(json.dumps(data))
    raised.write_text(json.dumps({**data, "level": 1.01 * worst}))
    box = ["--system", "vanderpol", "--param", "mu=0.8..1.2", "--json"]
    assert main(["verify", str(good), *box]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "certified" and out["method"] == "sos-exact"
    assert main(["verify", str(raised), *box]) != 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "inconclusive" and "refused" in out["message"]
    rc = main(["verify", str(good), "--system", "vanderpol", "--param", "mu=0.9..1.2"])
    assert rc != 0 and "another system" in capsys.readouterr().err


def test_cli_certify_box_with_the_sos_validator(worst, capsys):
    """``roa certify --system vanderpol --param mu=0.8..1.2 --validator sos``: the exact SOS
    certificate decides for the box (method sos-exact), at most the worst case, and the branch
    and bound refutes 1 % above it naming mu = 0.8."""
    from roa.cli import main

    rc = main(["certify", "--system", "vanderpol", "--param", "mu=0.8..1.2", "--validator",
               "sos", "--check-above", "1.01", "--json"])  # fmt: skip
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and out["status"] == "certified" and out["method"] == "sos-exact"
    assert 0.95 * worst <= out["level"] <= worst
    assert out["certificate"]["parameters"] == {"mu": [str(Fraction(0.8)), str(Fraction(1.2))]}
    assert out["above"]["status"] == "refuted" and out["above"]["witness_parameters"] == {"mu": 0.8}
