"""Correlative sparsity in the exact SOS check (:func:`roa.search._sos_program.clique_pattern`, :mod:`roa.proof._putinar`).

The system is a ring of 6 cells, ``x_i' = -x_i + x_{i+1} / 2 + x_i^3`` (indices mod 6), with
``V = |x|^2``: ``V' = 2 sum(-x_i^2 + x_i x_{i+1} / 2 + x_i^4)`` couples every cell to its
neighbours (one connected interaction graph: a 6-cycle, whose chordal extension has 4 triangles).
At ``x = e_1``, ``V' = 2 (-1 + 1) = 0`` exactly with ``V = 1``, so no level >= 1 is certifiable.
The largest level of this V is ``0.932313...``: one SLSQP run (scipy) on ``min V s.t. V' = 0``
from ``e_1`` in the test, independent of roa (the benchmark's multistart gives the same to 1e-12).
"""

from __future__ import annotations

import json
from fractions import Fraction

import numpy as np
import pytest

import roa
import roa.io
from roa.certification import Certificate
from roa.proof._putinar import Certificate as PutinarCertificate, check_level
from roa.proof._sos_check import exact_data
from roa.search._sos_program import (
    SosRoute,
    choose_route,
    clique_pattern,
    cliques,
    default_eps,
    interaction_graph,
)

N, A = 6, 0.5


def _field(x):
    return [-x[i] + A * x[(i + 1) % N] + x[i] ** 3 for i in range(N)]


def _ring() -> roa.System:
    return roa.System("ring-6", lambda t, x, xp: tuple(_field(x)), (0.0,) * N,
                      tuple(f"x{i}" for i in range(N)), lyapunov=np.eye(N))  # fmt: skip


def _optimum() -> float:
    from scipy import optimize

    def vdot(x):
        return 2 * sum(x[i] * v for i, v in enumerate(_field(list(x))))

    x0 = np.eye(N)[0]
    res = optimize.minimize(lambda x: x @ x, x0, jac=lambda x: 2 * x, method="SLSQP",
                            constraints=[{"type": "eq", "fun": lambda x: vdot(x) / (x @ x)}],
                            options={"ftol": 1e-14, "maxiter": 500})  # fmt: skip
    assert res.success and abs(vdot(res.x)) < 1e-12
    return float(res.x @ res.x)


@pytest.fixture(scope="module")
def ring():
    system = _ring()
    data = exact_data(system, roa.default_lyapunov(system))
    return system, data, _optimum()


def test_the_ring_structure_is_found():
    """The interaction graph is the 6-cycle; its chordal extension has 6 - 2 = 4 triangles that
    cover every edge; the plan has a 9-monomial block per clique (degree 1..2 in 3 variables), a
    3-monomial multiplier per clique and one cross block per clique and outside variable."""
    import networkx as nx

    system = _ring()
    data = exact_data(system, roa.default_lyapunov(system))
    G = interaction_graph(data)
    assert sorted(map(sorted, G.edges())) == sorted(sorted((i, (i + 1) % N)) for i in range(N))
    cl = cliques(data)
    assert len(cl) == 4 and all(len(c) == 3 for c in cl)
    assert all(any({i, j} <= set(c) for c in cl) for i, j in G.edges())
    H = nx.Graph([e for c in cl for e in zip(c, c[1:] + c[:1], strict=True)])
    assert nx.is_chordal(H)
    p, why = clique_pattern(data, symmetry=False)
    assert p is not None and why == ""
    assert p.sizes == {"cliques": [3, 3, 3, 3], "sigma_clique_blocks": [9, 9, 9, 9],
                       "sigma_cross_blocks": 4 * 3, "lambda_blocks": [3, 3, 3, 3]}  # fmt: skip
    assert choose_route(data)[0] == "dense"  # 27 monomials fit the budget
    assert choose_route(data, route="sparse")[0] == "sparse"
    # a non-diagonal V (one group: every variable): every monomial of lambda_j V is a product
    # of two monomials of one cross block of clique j (lambda_j V is a Gram form over it)
    P = np.eye(N) + 0.1 * (np.eye(N, k=1) + np.eye(N, k=-1))
    dense_V = exact_data(system, roa.QuadraticLyapunov(P, np.zeros(N)))
    p2, why2 = clique_pattern(dense_V, symmetry=False)
    assert p2 is not None and why2 == ""
    K = len(p2.cliques)
    cross = p2.sigma[K:]
    assert len(cross) == K  # one group, outside every clique
    for lam, block in zip(p2.lam, cross, strict=True):
        products = {tuple(a + b for a, b in zip(u, w, strict=True)) for u in block for w in block}
        for m1 in lam:
            for m2 in lam:
                for v in dense_V.V:
                    assert tuple(a + b + c for a, b, c in zip(m1, m2, v, strict=True)) in products
    with pytest.raises(roa.RoaInputError, match="route"):
        roa.SosValidator(route="chordal")


def test_sparse_and_dense_routes_both_certify_099_of_the_optimum(ring):
    """Both routes prove 0.99 x the independent optimum exactly; neither proves 1 (the witness
    e_1 has V' = 0 at V = 1), nor 1.001 x the optimum."""
    system, _, opt = ring
    assert 0.93 < opt < 0.935
    for route in ("dense", "sparse"):
        val = roa.SosValidator(route=route)
        cert = roa.certify(system, level=0.99 * opt, validator=val)
        assert cert.certified, (route, cert.message)
        meta = cert.validation.meta
        if route == "sparse":
            sigma = [g for g in meta["certificate"]["parts"][0]["grams"] if g["multiplies"] == 0]
            assert meta["route"] == "sparse" and len(sigma) > 1
            assert meta["blocks"]["cliques"] == [3, 3, 3, 3] and meta["peak_mib"] > 0
        else:
            grams = meta["certificate"]["parts"][0]["grams"]
            # dense: one part, the factors' blocks split by the sign symmetry x -> -x only
            assert sorted({g["multiplies"] for g in grams}) == [0, 1] and len(grams) <= 4
        for level in (1.001 * opt, 1.0):
            assert not roa.certify(system, level=level, validator=val).certified


def test_the_library_default_validator_is_the_command_lines(ring):
    """``roa.certify`` without ``validator`` routes as ``roa certify`` does (auto): at 6 states
    the exact SOS certificate decides, with no branch and bound over the 6-dimensional set."""
    system, _, opt = ring
    cert = roa.certify(system, level=0.99 * opt)
    assert cert.certified, cert.message
    assert cert.validation.meta["method"] != "interval" and "certificate" in cert.validation.meta
    assert not roa.certify(system, level=1.001 * opt).certified


@pytest.mark.slow
def test_above_the_branch_and_bounds_dimension_a_level_search_witness_refutes_just_above(ring):
    """At 6 states the check above the certified level is refuted by a witness from the CasADi
    level search (V' >= 0 at 50 digits, V(x) at the independent optimum), without running the
    branch and bound over 6 dimensions; the search never refutes a level below the optimum."""
    from roa.certification._pipeline import witness_by_search

    system, _, opt = ring
    cert = roa.certify(system, check_above=1.001)
    assert cert.certified and 0.99 * opt <= cert.level <= opt, cert.message
    above = cert.above
    assert above is not None and above.status is roa.Verdict.REFUTED, above
    assert 1.001 * cert.level <= above.level <= 1.002 * opt  # 1.001 x the proposed level
    x = np.asarray(above.witness)
    assert x @ x == pytest.approx(opt, rel=1e-9) and above.witness_check["confirmed"]
    stages = [(t["stage"], t["by"]) for t in cert.trace if t["stage"] == "refute above"]
    assert stages == [("refute above", "witness (level search)")]
    V = roa.default_lyapunov(system)
    below, note = witness_by_search(system, V, 0.999 * opt, [])
    assert below is None and "no level at or above it can be certified" in note


def test_the_sparse_bisection_level_agrees_with_the_dense_one(ring, monkeypatch):
    """The level proposer's bisection with the sparse program (forced by a small memory budget)
    is within 1 % below the dense program's and the optimum, never above the optimum; the
    pipeline then certifies 0.9999 x it with the sparse certificate."""
    import roa.search._sos_program as sparse
    from roa.search._sos_bisection import bisect_level

    system, data, opt = ring
    dense_level, _ = bisect_level(data, rel_tol=1e-5)
    monkeypatch.setattr(sparse, "MAX_SDP_BYTES", 2**20)  # the dense block (27) does not fit
    assert choose_route(data)[0] == "sparse"
    sparse_level, _ = bisect_level(data)
    assert dense_level is not None and sparse_level is not None
    assert dense_level <= opt * (1 + 1e-6)
    assert 0.99 * opt <= sparse_level <= dense_level * (1 + 1e-4), (sparse_level, dense_level)
    cert = roa.certify(system, validator=roa.SosValidator())
    assert cert.certified and cert.validation.meta["route"] == "sparse"
    assert cert.level == pytest.approx(sparse_level * (1 - 1e-4), rel=1e-4)


def _sparse_certificate(data, level):
    p, _ = clique_pattern(data)
    eps = default_eps(data)
    cand = SosRoute(data, "sparse", p, "").propose(level, eps)
    res = check_level(data, level, eps, cand.certificate)
    assert res.ok, res.reason
    return p, eps, res


def check_sum(data, level, eps, S, L, rounded=False):
    """The sparse certificate (``S`` sigma's blocks, ``L`` the level multiplier's) by the one
    check."""
    grams = tuple((0, b, Q) for b, Q in S) + tuple((1, b, Q) for b, Q in L)
    return check_level(data, level, eps, PutinarCertificate(grams), rounded=rounded)


def test_tampered_sparse_certificates_are_refused(ring):
    system, data, opt = ring
    level = 0.98 * opt
    p, eps, res = _sparse_certificate(data, level)
    S, L = res.certificate.blocks(0), res.certificate.blocks(1)
    again = check_sum(data, level, eps, S, L, rounded=True)
    assert again.ok and again.residual == 0  # the exact certificate passes as it is
    # an indefinite clique block with every coefficient unchanged: +a on the (d_i^2, d_j^2)
    # pair and -2a on (d_i d_j, d_i d_j), which the projection does not move
    i, j = p.cliques[0][:2]
    unit = [tuple(int(k == v) for k in range(N)) for v in (i, j)]
    two = [tuple(2 * e for e in u) for u in unit]
    mixed = tuple(a + b for a, b in zip(*unit, strict=True))
    b0 = next(b for b, (basis, _) in enumerate(S) if {*two, mixed} <= set(basis))
    basis, Q = S[b0]
    ii, jj, m = (basis.index(two[0]), basis.index(two[1]), basis.index(mixed))
    bad = [row[:] for row in Q]
    a = abs(Q[m][m]) + 1
    bad[ii][jj] += a
    bad[jj][ii] += a
    bad[m][m] -= 2 * a
    r = check_sum(data, level, eps, S[:b0] + [(basis, bad)] + S[b0 + 1 :], L, rounded=True)
    assert not r.ok and r.residual == 0 and f"sigma block {b0} is not positive definite" in r.reason
    # an indefinite multiplier block
    lb, LQ = L[2]
    badL = [row[:] for row in LQ]
    badL[0][0] = Fraction(-1, 10**6)
    r = check_sum(data, level, eps, S, L[:2] + [(lb, badL)] + L[3:], rounded=True)
    assert not r.ok and "multiplier's block 2 is not positive definite" in r.reason
    # an identity off by one coefficient: V' with its d_0^2 coefficient -2 raised by 2 (V' no
    # longer negative definite along d_0): the projection moves by 2 and no certificate remains
    Vdot = dict(data.Vdot)
    Vdot[tuple(2 * (k == 0) for k in range(N))] += 2
    wrong = type(data)(data.n, data.center, data.V, Vdot, data.low)
    r = check_sum(wrong, level, eps, S, L, rounded=True)
    assert r.residual == 2 and not r.ok and "does not hold exactly as stored" in r.reason
    # a monomial that no block holds (x0^3 x3: x0 and x3 share no clique)
    assert not any({0, 3} <= set(c) for c in p.cliques)
    Vdot = dict(data.Vdot)
    Vdot[(3, 0, 0, 1, 0, 0)] = Fraction(1)
    wrong = type(data)(data.n, data.center, data.V, Vdot, data.low)
    r = check_sum(wrong, level, eps, S, L, rounded=True)
    assert not r.ok and "outside the Gram basis" in r.reason
    assert not check_sum(data, level, 0, S, L, rounded=True).ok  # eps = 0 proves nothing


def test_a_stored_sparse_certificate_is_rechecked_without_a_solver(ring, monkeypatch):
    """The file's blocks are re-checked exactly with no solver; a block made indefinite, an
    identity off by one coefficient (a stored basis monomial changed) or a level raised to the
    witness's 1 is refused."""
    import roa.search._sos_program as sparse

    system, _, opt = ring
    cert = roa.certify(system, level=0.99 * opt, validator=roa.SosValidator(route="sparse"))
    assert cert.certified
    data = json.loads(roa.io.to_json(cert.to_dict()))
    assert data["certificate"]["parts"][0]["cliques"]

    def no_solver(*a, **k):
        raise AssertionError("the re-check must not solve anything")

    monkeypatch.setattr(sparse.SosRoute, "propose", no_solver)
    monkeypatch.setattr(sparse.FixedLevel, "solve", no_solver)
    again = Certificate.from_dict(data, system).reverify()
    assert again.certified and "sparse SOS certificate re-checked exactly" in again.message
    negated = json.loads(json.dumps(data))
    for block in negated["certificate"]["parts"][0]["grams"][:1]:
        block["Q"] = [[v[1:] if v.startswith("-") else f"-{v}" for v in row]
                      for row in block["Q"]]  # fmt: skip
    shifted = json.loads(json.dumps(data))
    basis = shifted["certificate"]["parts"][0]["grams"][0]["basis"]
    basis[-1] = [e + (k == 0) for k, e in enumerate(basis[-1])]  # one monomial of degree 3
    raised = {**data, "level": 1.0}
    malformed = json.loads(json.dumps(data))
    lam = [g for g in malformed["certificate"]["parts"][0]["grams"] if g["multiplies"] == 1]
    lam[0]["Q"] = [["1/0"]]
    for forged in (negated, shifted, raised, malformed):
        v = Certificate.from_dict(forged, system).reverify()
        assert v.status is roa.Verdict.INCONCLUSIVE, v.message


def test_decoupled_rings_get_one_sparse_certificate_per_block(ring):
    """Two decoupled copies of the ring (12 states): V and V' split into the two copies
    (:mod:`roa.proof._reductions`), each proved by its own sparse certificate at the same level
    (the optimum is one copy's: the other copy at 0 gives the witness); the file is re-checked
    block by block and a copy's clique block negated is refused (one entry changed is not enough:
    the re-check projects the stored blocks again, which may well restore a valid certificate)."""
    _, _, opt = ring

    def field(t, x, xp):
        return tuple(_field(list(x[:N]))) + tuple(_field(list(x[N:])))

    system = roa.System("ring-6-x2", field, (0.0,) * (2 * N),
                        tuple(f"x{i}" for i in range(2 * N)), lyapunov=np.eye(2 * N))  # fmt: skip
    cert = roa.certify(system, level=0.99 * opt, validator=roa.SosValidator(route="sparse"))
    assert cert.certified, cert.message
    stored = cert.validation.meta["certificate"]["parts"]
    assert [b["variables"] for b in stored] == [list(range(N)), list(range(N, 2 * N))]
    assert all(sum(g["multiplies"] == 0 for g in b["grams"]) > 1 for b in stored)  # cliques
    data = json.loads(roa.io.to_json(cert.to_dict()))
    assert Certificate.from_dict(data, system).reverify().certified
    bad = json.loads(json.dumps(data))
    block = bad["certificate"]["parts"][1]["grams"][0]
    block["Q"] = [[v[1:] if v.startswith("-") else f"-{v}" for v in row] for row in block["Q"]]
    again = Certificate.from_dict(bad, system).reverify()
    assert again.status is roa.Verdict.INCONCLUSIVE and "block [6," in again.message
