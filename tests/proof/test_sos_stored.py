"""The one stored form of an exact SOS certificate and the old forms it replaces.

``tests/data/sos_certificates_old_forms.json`` holds certificate files written by the previous
release (one per old form: ``basis0``/``Q0`` dense, ``blocks``, ``sum``, ``putinar`` for a recast
field and for a parameter box, dense with a ``domain`` part), for the systems below. Each must
still be re-checked exactly (converted on load into the one form, :func:`roa.proof._sos_stored.
parts_of`), and each tampered (a Gram block of the SOS part negated, or the level raised by 1 %
where the level is within 1 % of the optimum) must be refused. Fresh certificates are written
in the one form (``parts``) and convert to themselves.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from sos_systems import poly3d_block as _poly3d, ring as _ring

import roa
import roa.io
from roa.certification._result import Certificate
from roa.proof._sos_stored import parts_of
from roa.status import Verdict
from roa.systems.vanderpol import P_BENCHMARK, vanderpol

OLD = json.loads(
    (Path(__file__).resolve().parents[1] / "data" / "sos_certificates_old_forms.json").read_text()
)


SYSTEMS = {
    "dense": (vanderpol(), roa.SosValidator()),
    "blocks": (
        roa.System(
            "p3x2",
            lambda t, x, xp: _poly3d(x, 0) + _poly3d(x, 3),
            (0.0,) * 6,
            tuple(f"x{i}" for i in range(6)),
        ),
        roa.SosValidator(),
    ),  # fmt: skip
    "sum": (_ring(5), roa.SosValidator(route="sparse")),
    "putinar": (
        roa.System(
            "pendulum",
            lambda t, x, xp: (x[1], -xp.sin(x[0]) - x[1]),
            (0.0, 0.0),
            ("theta", "omega"),
        ),
        roa.SosValidator(fallback=False),
    ),  # fmt: skip
    "box": (vanderpol().with_ranges(mu=(0.9, 1.1)), roa.SosValidator(fallback=False)),
    "domain": (
        roa.System(
            "vdp-strip",
            lambda t, x, xp: (-x[1], x[0] - x[1] + x[0] ** 2 * x[1]),
            (0.0, 0.0),
            ("x1", "x2"),
            margin=lambda x, xp: 0.25 - x[0] * x[0],
            domain_description="|x1| < 0.5",
        ),
        roa.SosValidator(),
    ),  # fmt: skip
}
OLD_KEYS = {"dense": "basis0", "blocks": "blocks", "sum": "sum", "putinar": "putinar",
            "box": "putinar", "domain": "basis0"}  # fmt: skip


def _negate(Q):
    return [[v[1:] if v.startswith("-") else f"-{v}" for v in row] for row in Q]


def _sos_block(cert: dict) -> dict:
    """The first Gram block of the SOS part (factor 0) of an old-form certificate."""
    if "basis0" in cert:
        return cert
    if "sum" in cert:
        return cert["sum"]["sigma"][0]
    if "blocks" in cert:
        return cert["blocks"][0]
    return cert["putinar"]["grams"][0]


@pytest.mark.parametrize("form", sorted(SYSTEMS))
def test_old_forms_are_read_and_tampered_ones_refused(form):
    system, _ = SYSTEMS[form]
    data = OLD[form]
    assert OLD_KEYS[form] in data["certificate"]  # the file is in the old form
    parts = parts_of(data["certificate"], system.n)["parts"]
    assert len(parts) == (2 if form == "blocks" else 1)
    again = Certificate.from_dict(data, system).reverify()
    assert again.certified and again.method == "sos-exact", again.message
    bad = json.loads(json.dumps(data))
    block = _sos_block(bad["certificate"])
    key = "Q0" if "Q0" in block else "Q"
    block[key] = _negate(block[key])
    r = Certificate.from_dict(bad, system).reverify()
    assert r.status is Verdict.INCONCLUSIVE and "refused" in r.message, r.message


def test_fresh_certificates_use_the_one_form_with_the_same_verdicts():
    """Van der Pol at 2.0 (its optimum is 2.3045): written with ``parts`` (one part; the blocks of
    each factor split by the sign symmetry x -> -x), re-checked; the same blocks in the old
    ``sum`` form are read the same; and a raised level (2.31, above the optimum) is refused in
    both."""
    system, validator = SYSTEMS["dense"]
    cert = roa.certify(system, P_BENCHMARK, level=2.0, validator=validator)
    data = json.loads(roa.io.to_json(cert.to_dict()))
    stored = data["certificate"]
    grams = stored["parts"][0]["grams"]
    assert list(stored) == ["parts"] and sorted({g["multiplies"] for g in grams}) == [0, 1]
    assert parts_of(stored, 2)["parts"] == stored["parts"]

    def blocks(k):
        return [{"basis": g["basis"], "Q": g["Q"]} for g in grams if g["multiplies"] == k]

    old = {**data, "certificate": {"sum": {"sigma": blocks(0), "lambda": blocks(1)}}}
    for form in (data, old):
        assert Certificate.from_dict(form, system).reverify().certified
        raised = Certificate.from_dict({**form, "level": 2.31}, system).reverify()
        assert raised.status is Verdict.INCONCLUSIVE
    # an eps of the part that differs from the top level's is refused
    forged = json.loads(json.dumps(data))
    forged["certificate"]["parts"][0]["eps"] = "1/3"
    r = Certificate.from_dict(forged, system).reverify()
    assert r.status is Verdict.INCONCLUSIVE and "eps differs" in r.message


def test_parts_must_partition_the_variables():
    system, _ = SYSTEMS["blocks"]
    data = json.loads(json.dumps(OLD["blocks"]))
    data["certificate"] = parts_of(data["certificate"], 6)  # the one form
    assert Certificate.from_dict(data, system).reverify().certified
    data["certificate"]["parts"][1]["variables"] = [2, 4, 5]
    r = Certificate.from_dict(data, system).reverify()
    assert r.status is Verdict.INCONCLUSIVE and "exactly once" in r.message
