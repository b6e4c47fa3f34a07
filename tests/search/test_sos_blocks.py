"""Independent blocks of variables in the exact SOS check (:mod:`roa.proof._reductions`).

Two decoupled copies of poly3d (x' = -x + (x2 x3, x1 x3, x1 x2) per copy, V = |x|^2) have the
largest level 3 exactly, as one copy (examples/systems/poly3d.py: AM-GM on the sphere; V' is the
sum of the copies' V', so a point of one copy with V' = 0 and the other copy at 0 is a witness).
The split certificate proves 0.99 x 3 with one 3-variable certificate per copy.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from sos_systems import poly3d_block as _poly3d

import roa
import roa.io
from roa.certification import Certificate
from roa.proof._reductions import blocks, check_partition, restrict
from roa.proof._sos_check import exact_data
from roa.search._sdp import monomials


def _copies(k: int) -> roa.System:
    return roa.System(f"poly3d-x{k}", lambda t, x, xp: sum((_poly3d(x, 3 * c) for c in range(k)),
                                                             ()),  # fmt: skip
                      (0.0,) * (3 * k), tuple(f"x{i}" for i in range(3 * k)))  # fmt: skip


def _rotated() -> roa.System:
    """The two copies in coordinates y = Q x (Q orthogonal): the same level 3, every variable coupled."""
    Q = np.linalg.qr(np.random.default_rng(3).standard_normal((6, 6)))[0]

    def field(t, y, xp):
        x = [sum(Q[j, i] * y[j] for j in range(6)) for i in range(6)]
        g = _poly3d(x, 0) + _poly3d(x, 3)
        return tuple(sum(Q[i, j] * g[j] for j in range(6)) for i in range(6))

    return roa.System("poly3d-rot", field, (0.0,) * 6, tuple(f"y{i}" for i in range(6)))


def test_blocks_are_the_decoupled_copies_and_nothing_else():
    V = roa.QuadraticLyapunov(np.eye(6), np.zeros(6))
    assert blocks(exact_data(_copies(2), V)) == [(0, 1, 2), (3, 4, 5)]
    assert blocks(exact_data(_rotated(), V)) == [tuple(range(6))]
    data = exact_data(_copies(2), V)
    sub = restrict(data, (3, 4, 5))
    assert sub.n == 3 and sub.low == 2 and sub.V == exact_data(_copies(1), roa.QuadraticLyapunov(
        np.eye(3), np.zeros(3))).V  # fmt: skip
    with pytest.raises(ValueError, match="couples"):
        restrict(exact_data(_rotated(), V), (0, 1, 2))
    with pytest.raises(ValueError, match="exactly once"):
        check_partition([[0, 1, 2], [2, 3, 4, 5]], 6)


@pytest.fixture(scope="module")
def split_certificate():
    system = _copies(2)
    cert = roa.certify(system, np.eye(6), level=0.99 * 3, validator=roa.SosValidator())
    return system, cert


def test_decoupled_copies_are_certified_block_by_block(split_certificate):
    system, cert = split_certificate
    assert cert.status is roa.Verdict.CERTIFIED, cert.message
    stored = cert.validation.meta["certificate"]["parts"]
    assert [b["variables"] for b in stored] == [[0, 1, 2], [3, 4, 5]]
    for part in stored:  # the SOS part: the 9 monomials of degree 1..2 in 3 variables, split
        sos = [g["basis"] for g in part["grams"] if g["multiplies"] == 0]  # by sign symmetry
        assert sorted(tuple(m) for b in sos for m in b) == sorted(
            tuple(m) for m in monomials(3, 2, 1)
        )
    assert cert.validation.meta["gram_sizes"] == [max(len(b) for b in sos)] * 2
    assert "2 independent blocks" in cert.message
    # the level 3 is the optimum (a witness of one copy); nothing above it can be certified
    assert not roa.certify(system, np.eye(6), level=1.01 * 3,
                           validator=roa.SosValidator()).certified  # fmt: skip


def test_a_split_certificate_is_rechecked_and_tampering_is_refused(split_certificate, monkeypatch):
    """Re-checked without a solver; refused when the level is raised above the optimum 3, when a
    block's multiplier Gram matrix is negated (never projected, so no longer positive definite),
    or when the stored blocks are not independent (a monomial couples them)."""
    import roa.search._sos_program as proposer

    system, cert = split_certificate
    data = json.loads(roa.io.to_json(cert.to_dict()))

    def no_solver(*a, **k):
        raise AssertionError("the re-check must not solve anything")

    monkeypatch.setattr(proposer.FixedLevel, "solve", no_solver)
    again = Certificate.from_dict(data, system).reverify()
    assert again.certified and "2 independent blocks" in again.message
    raised = {**data, "level": 3.03}
    negated = json.loads(json.dumps(data))
    lam = [g for g in negated["certificate"]["parts"][1]["grams"] if g["multiplies"] == 1]
    assert lam, "the block has a multiplier"
    lam[0]["Q"] = [[v[1:] if v.startswith("-") else f"-{v}" for v in row] for row in lam[0]["Q"]]
    merged = json.loads(json.dumps(data))
    merged["certificate"]["parts"][0]["variables"] = [0, 1, 3]
    merged["certificate"]["parts"][1]["variables"] = [2, 4, 5]
    for forged in (raised, negated, merged):
        v = Certificate.from_dict(forged, system).reverify()
        assert v.status is roa.Verdict.INCONCLUSIVE, v.message


def test_the_sos_level_of_independent_blocks_is_the_least_block_level():
    """Two copies of poly3d plus x7' = -x7 (V' = -2 x7^2 < 0 everywhere: no limit): the blocks'
    levels are 3 (both copies, solved once) and unlimited, so the proposal is 3 (closed form), to
    the bisection's and the solver's tolerance; roa.certify (SosLevel, the default proposer for a
    quadratic V) then has the exact check prove 0.9999 x it."""
    from roa.search._sos_bisection import block_levels

    def field(t, x, xp):
        return _poly3d(x, 0) + _poly3d(x, 3) + (-x[6],)

    system = roa.System("poly3d-x2-plus", field, (0.0,) * 7, tuple(f"x{i}" for i in range(7)))
    V = roa.QuadraticLyapunov(np.eye(7), np.zeros(7))
    res = block_levels(exact_data(system, V))
    assert res.sizes == {"blocks": [3, 3, 1], "distinct_blocks": 2, "routes": ["dense", "dense"]}
    assert res.level == pytest.approx(3.0, rel=1e-4) and res.level <= 3.0 * (1 + 1e-9)
    assert [b for b, _ in res.per_block] == [(0, 1, 2), (3, 4, 5), (6,)]
    assert res.per_block[2][1] > 1e6  # unlimited, up to the solver's scaling at huge levels
    proved = roa.certify(system, V, validator=roa.SosValidator())
    assert proved.level_source == "sos" and proved.sos.solver_status == "bisection"
    assert proved.certified and proved.level == pytest.approx(3.0, rel=2e-4)
