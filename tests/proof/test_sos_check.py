"""The exact SOS validator (``roa.SosValidator``, :mod:`roa.proof._sos_check`).

Van der Pol with the benchmark P has largest level 2.3045: the SOS certificate, checked in exact
rationals, certifies 2.30 and can never certify 2.31 (a point of ``{V <= 2.31}`` has ``V' = 0``).
"""

from __future__ import annotations

import re
import time
from fractions import Fraction

import numpy as np
import pytest

import roa
import roa.io
from roa.lyapunov import QuadraticLyapunov
from roa.proof._putinar import Certificate, check_level
from roa.proof._sos_check import exact_data
from roa.search._sos_program import propose
from roa.systems.vanderpol import vanderpol


def test_vanderpol_certified_at_2_30_not_at_2_31():
    system = vanderpol()
    t0 = time.perf_counter()
    cert = roa.certify(system, level=2.30, validator=roa.SosValidator())
    assert time.perf_counter() - t0 < 20
    assert cert.status is roa.Verdict.CERTIFIED
    meta = cert.validation.meta
    assert meta["method"] == "sos-exact" and meta["min_pivot"] > 0
    assert len(meta["digest"]) == 64 and meta["certificate"]["parts"][0]["grams"][0]["Q"]
    above = roa.certify(system, level=2.31, validator=roa.SosValidator())
    assert above.status is roa.Verdict.INCONCLUSIVE
    assert "not positive definite" in above.validation.message


# x' = H g(H x) + S x, g_i(y) = -y_i + y_i^3, H = I - (1/3) 1 1' (a rational Householder
# reflection: H = H' = H^-1), S skew-symmetric (a rotation in the planes (x0, x1), (x2, x3)).
H = np.eye(6) - np.ones((6, 6)) / 3.0


def _field(t, x, xp):
    y = [sum(H[i][j] * x[j] for j in range(6)) for i in range(6)]
    g = [-yi + yi * yi * yi for yi in y]
    out = [sum(H[i][j] * g[j] for j in range(6)) for i in range(6)]
    out[0] = out[0] + x[1]
    out[1] = out[1] - x[0]
    out[2] = out[2] + 2 * x[3]
    out[3] = out[3] - 2 * x[2]
    return tuple(out)


def coupled_cubic() -> roa.System:
    """Six coupled cubic states with largest level 1 for ``V = |x|^2``.

    With ``y = H x`` (``H`` orthogonal and symmetric, so ``|y| = |x|``) and ``x'Sx = 0``:
    ``V' = 2 x' H g(y) = 2 y' g(y) = -2 sum_i y_i^2 (1 - y_i^2)``. On ``{|x|^2 <= c}`` with
    ``c < 1`` every ``|y_i| < 1``, so ``V' < 0`` off the origin; at ``c = 1`` the point
    ``y = e_1`` (``x = H e_1``) has ``V = 1`` and ``V' = 0``. The largest level is exactly 1.
    (The entries of ``H`` are floats: 1 - 1/3 and -1/3 rounded; the exact field then has
    ``H`` only approximately orthogonal, so the test certifies 0.95, well inside.)
    """
    return roa.System("coupled-cubic-6", _field, tuple([0.0] * 6),
                      tuple(f"x{i}" for i in range(6)), lyapunov=np.eye(6))  # fmt: skip


def test_six_states_certified_at_095_of_the_optimum_in_seconds():
    system = coupled_cubic()
    V = QuadraticLyapunov.for_system(system, np.eye(6))
    x = H[:, 0]  # V = 1, V' = 0: the optimum is 1
    assert V.value(x) == pytest.approx(1.0)
    assert V.derivative(system, x) == pytest.approx(0, abs=1e-12)
    t0 = time.perf_counter()
    cert = roa.certify(system, V, level=0.95, validator=roa.SosValidator())
    seconds = time.perf_counter() - t0
    assert cert.status is roa.Verdict.CERTIFIED, cert.message
    assert seconds < 20
    assert roa.certify(system, V, level=1.01, validator=roa.SosValidator()).status is (
        roa.Verdict.INCONCLUSIVE
    )


def _with(cert, i, Q):
    """``cert`` with the matrix of its ``i``-th Gram block replaced by ``Q``."""
    grams = list(cert.grams)
    k, basis, _ = grams[i]
    grams[i] = (k, basis, Q)
    return Certificate(tuple(grams), cert.free)


def _vdp_certificate(level: float = 2.3):
    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, system.lyapunov)
    data = exact_data(system, V)
    cand = propose(data, level)
    res = check_level(data, level, cand.eps, cand.certificate)
    assert res.ok
    return data, cand, res


def test_tampered_certificates_are_refused():
    data, cand, res = _vdp_certificate()
    exact, eps = res.certificate, cand.eps
    again = check_level(data, 2.3, eps, exact, rounded=True)
    assert again.ok and again.residual == 0  # the exact certificate passes as it is
    # an indefinite block of the SOS part with the identity still exact: +a on the (d1^2, d2^2)
    # pair and -2a on (d1 d2, d1 d2) leave every coefficient unchanged (nothing is projected)
    i = next(i for i, (k, b, _) in enumerate(exact.grams) if k == 0 and (1, 1) in b)
    _, basis0, Q0 = exact.grams[i]
    i11, i12, i22 = (basis0.index(m) for m in ((2, 0), (1, 1), (0, 2)))
    bad = [row[:] for row in Q0]
    a = abs(Q0[i12][i12]) + 1
    bad[i11][i22] += a
    bad[i22][i11] += a
    bad[i12][i12] -= 2 * a
    r = check_level(data, 2.3, eps, _with(exact, i, bad), rounded=True)
    assert not r.ok and r.residual == 0 and "projected Gram matrix" in r.reason
    assert "not positive definite" in r.reason
    # an indefinite multiplier
    j = next(j for j, (k, _, _) in enumerate(exact.grams) if k == 1)
    bad1 = [row[:] for row in exact.grams[j][2]]
    bad1[-1][-1] = Fraction(-1, 10**6)
    r = check_level(data, 2.3, eps, _with(exact, j, bad1), rounded=True)
    assert not r.ok and "level multiplier" in r.reason and "not positive definite" in r.reason
    # an identity off by one coefficient: V' with its d1^2 coefficient -1 made 0 (V' is then not
    # negative definite): a stored certificate is checked as stored, so the identity fails
    Vdot = dict(data.Vdot)
    Vdot[(2, 0)] += 1
    wrong = type(data)(data.n, data.center, data.V, Vdot, data.low)
    r = check_level(wrong, 2.3, eps, exact, rounded=True)
    assert r.residual == 1 and not r.ok and "does not hold exactly as stored" in r.reason
    assert "(2, 0)" in r.reason  # the monomial whose coefficient differs is named
    # a coefficient outside the Gram basis cannot be matched at all
    Vdot = dict(data.Vdot)
    Vdot[(5, 1)] = Fraction(1)
    wrong = type(data)(data.n, data.center, data.V, Vdot, data.low)
    r = check_level(wrong, 2.3, eps, exact, rounded=True)
    assert not r.ok and "outside the Gram basis" in r.reason
    # eps = 0 proves nothing strict
    assert not check_level(data, 2.3, 0, exact, rounded=True).ok


def test_fields_that_cannot_be_recast_are_refused_or_fall_back():
    """exp is not recast: with ``fallback=False`` the SOS validator refuses the system, naming
    the term; by default the branch and bound decides (method ``interval``)."""
    system = roa.System("exp", lambda t, x, xp: (x[1], -(xp.exp(x[0]) - 1) - x[1]), (0.0, 0.0),
                        ("a", "b"))  # fmt: skip
    V = QuadraticLyapunov([[1.5, 0.5], [0.5, 1.0]], [0.0, 0.0])
    strict = roa.SosValidator(fallback=False)
    assert not strict.accepts(system, V)
    res = strict.check(system, V, 0.05)
    assert res.status is roa.Verdict.INCONCLUSIVE and "exp(d0)" in res.message
    with pytest.raises(roa.RoaInputError, match="does not accept"):
        roa.certify(system, V, level=0.05, validator=strict)
    cert = roa.certify(system, V, level=0.05, validator=roa.SosValidator())
    assert cert.method == "interval" and "exp(d0)" in cert.message


@pytest.mark.parametrize("name, function", [("SYSTEM", "tanh("), ("SYSTEM_RELU", "Max(0, ")])
def test_a_network_field_is_refused_naming_its_units_in_decimals(name, function):
    """The pendulum's network controllers (2-16-1; a unit with output weight 0 drops out of the
    field): neither the exact check nor a recast takes them; the refusal names three units as
    written (decimal weights in the offsets d from the equilibrium, not 50-digit rationals) and
    counts the others, and the default validator falls back to the branch and bound."""
    from pathlib import Path

    from roa.proof._recast import recast_exact
    from roa.proof._sos_check import NotPolynomial, exact_data

    path = Path(__file__).resolve().parents[2] / "examples" / "systems" / "pendulum_nn.py"
    system = roa.load_system(f"{path}:{name}")
    V = roa.default_lyapunov(system)
    net = np.load(path.with_name(f"pendulum_nn_{'tanh' if name == 'SYSTEM' else 'relu'}.npz"))
    units = np.count_nonzero(net["W1"])  # the units the field holds
    with pytest.raises(NotPolynomial, match=r"not polynomial in the state") as exact:
        exact_data(system, V)
    with pytest.raises(NotPolynomial, match=rf"cannot recast .* and {units - 3} more") as recast:
        recast_exact(system, V, taylor=1)
    for exc in (exact, recast):
        message = str(exc.value)
        assert function in message and re.search(r"\d\.\d+\*d0", message), message
        assert not re.search(r"\d{10,}/\d{10,}", message), message  # no exact rationals shown
    assert roa.SosValidator.recast_error(system, V) == str(recast.value)
    assert roa.SosValidator().accepts(system, V)  # fallback: the branch and bound decides
    assert not roa.SosValidator(fallback=False).accepts(system, V)


@pytest.mark.parametrize(
    "field",
    [lambda t, x, xp: (-x[0] + 0.0 * xp.tanh(x[0]), -x[1]),  # a gain of 0
     lambda t, x, xp: (-x[0] - x[0] * xp.abs(x[0]) ** 2, -x[1]),  # |x|^2 = x^2
     lambda t, x, xp: (-x[0] * xp.exp(0.0 * x[0]), -x[1]),  # exp(0) = 1
     lambda t, x, xp: (-x[0] + xp.tanh(x[0]) - xp.tanh(x[0]), -x[1])],
    ids=["zero-gain", "abs-squared", "exp-of-zero", "cancelling"],
)  # fmt: skip
def test_functions_that_evaluate_away_are_not_refused(field):
    """A function of the state that evaluates away (the refusal reads the field after
    evaluation) leaves a polynomial field: the exact check and the recast take it."""
    from roa.proof._recast import recast_exact

    system = roa.System("poly", field, (0.0, 0.0), ("a", "b"))
    V = QuadraticLyapunov(np.eye(2), [0.0, 0.0])
    exact_data(system, V)
    recast_exact(system, V, taylor=1)
    box = roa.System("box", lambda t, x, xp, p: (-x[0] * xp.abs(p.a) ** 2, -x[1]), (0.0, 0.0),
                     ("a", "b"), parameters={"a": (1.0, 1.5, 2.0)})  # fmt: skip
    recast_exact(box, V, taylor=1)  # |a|^2 = a^2 of the box's parameter


def test_a_stored_sos_certificate_is_rechecked_exactly_without_a_solver(
    tmp_path, monkeypatch, capsys
):
    """`roa verify` re-checks an exact SOS certificate from its stored Gram matrices alone (the
    solver is not called), and refuses it when the file is edited into a false claim: a level
    raised to 2.31 (above the true optimum 2.3045, where no certificate can exist) or the
    multiplier's Gram matrix made negative definite (it is never projected). An edit that the
    exact projection turns back into a valid certificate (one diagonal entry of Q0 alone on its
    monomial) is accepted: the proof stands on the projected matrices, not on the file."""
    import json

    import roa.search._sos_program as proposer
    from roa.cli import main
    from roa.montecarlo._certified_set import terminal_from_certificate

    cert = roa.certify(vanderpol(), level=2.30, validator=roa.SosValidator())
    assert cert.certified and cert.method == "sos-exact"
    data = json.loads(roa.io.to_json(cert.to_dict()))
    grams = data["certificate"]["parts"][0]["grams"]
    assert data["method"] == "sos-exact" and grams[0]["Q"]

    def no_solver(*a, **k):
        raise AssertionError("the re-check must not solve anything")

    monkeypatch.setattr(proposer.FixedLevel, "solve", no_solver)
    good = tmp_path / "good.json"
    good.write_text(json.dumps(data))
    assert main(["verify", str(good), "--system", "vanderpol", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "certified" and "re-checked exactly" in out["message"]
    term = terminal_from_certificate(data, vanderpol())  # a terminal set from it, no solver
    assert term.quadratic and term.level == 2.30
    raised = {**data, "level": 2.31}
    bad_q = json.loads(json.dumps(data))
    lam = [g for g in bad_q["certificate"]["parts"][0]["grams"] if g["multiplies"] == 1]
    assert lam, "the certificate has a multiplier"
    lam[0]["Q"] = [
        [f"-{v}" if not v.startswith("-") else v[1:] for v in row] for row in lam[0]["Q"]
    ]
    repaired = json.loads(json.dumps(data))
    # one Gram entry edited: the file is what is proved, nothing is projected back onto the
    # identity, so it is refused
    repaired["certificate"]["parts"][0]["grams"][0]["Q"][0][0] = "-1"
    for forged in (raised, bad_q, repaired):
        path = tmp_path / "forged.json"
        path.write_text(json.dumps(forged))
        assert main(["verify", str(path), "--system", "vanderpol", "--json"]) == 1
        out = json.loads(capsys.readouterr().out)
        assert out["status"] == "inconclusive" and "refused" in out["message"]


def test_review_findings_on_the_sos_route():
    """Second review: V centred at another equilibrium is not certified for this system (x' =
    -x (x - 1)(x - 2): {(x - 2)^2 <= 0.5} is no region of attraction of 0); a float constant that
    leaves f(x_eq) != 0 in exact arithmetic is refused (f = -(0.1 x - 0.03), x_eq = 0.3 in
    doubles); stored numbers too large to check are refused before any arithmetic."""
    import json

    from roa.certification import Certificate

    cubic = roa.System("three", lambda t, x, xp: (-x[0] * (x[0] - 1) * (x[0] - 2),), (0.0,), ("x",))
    V2 = roa.QuadraticLyapunov([[1.0]], [2.0])
    v = roa.SosValidator().check(cubic, V2, 0.5)
    assert v.status is roa.Verdict.INCONCLUSIVE and "centred" in v.message
    lin = roa.System("lin", lambda t, x, xp: (-(0.1 * x[0] - 0.03),), (0.3,), ("x",))
    v = roa.SosValidator().check(lin, roa.QuadraticLyapunov([[1.0]], [0.3]), 0.01)
    assert "SOS not applicable (f(x_eq) != 0" in v.message
    # the branch and bound behind it proves convergence to the field's zero x* = 0.03 / 0.1 in
    # exact rationals, 1.67e-17 from x_eq (roa.proof._local, the contraction argument)
    x_star = Fraction(0.03) / Fraction(0.1)
    assert v.status is roa.Verdict.CERTIFIED
    assert v.meta["local_proof"] == "contraction (f(x_eq) enclosed)"
    assert abs(x_star - Fraction(0.3)) <= Fraction(v.meta["equilibrium_radius"]) < 1e-12
    from roa.proof._exact import exact_equilibrium

    assert not exact_equilibrium(lin, lin.x_eq)  # the interval route's local proof sees it too
    assert exact_equilibrium(vanderpol(), vanderpol().x_eq)
    data = json.loads(roa.io.to_json(
        roa.certify(vanderpol(), level=2.30, validator=roa.SosValidator()).to_dict()))  # fmt: skip
    for edit in ({"eps": "1e400"}, {"eps": "0"}):
        assert not Certificate.from_dict({**data, **edit}, vanderpol()).reverify().certified
    huge = json.loads(json.dumps(data))
    huge["certificate"]["parts"][0]["grams"][0]["Q"][0][0] = "1" + "0" * 3000
    assert "at most" in Certificate.from_dict(huge, vanderpol()).reverify().message
