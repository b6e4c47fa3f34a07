"""Exact ellipsoid containment, the search cache, and regions in hybrid coordinates.

Reference values: max of x'Px over {x'Qx <= a} is a lambda_max(Q^-1 P) (Rayleigh quotient), here
computed independently by numpy's symmetric eigensolver or in closed form for diagonal matrices.
"""

from __future__ import annotations

import json
from fractions import Fraction

import numpy as np
import pytest

from roa.proof._containment import ellipsoid_contains
from roa.search._cache import SearchCache


def test_diagonal_containment_decided_on_both_sides_of_the_exact_bound():
    P, Q = np.diag([1.0, 2.0, 0.5]), np.eye(3)
    # max of P over the unit ball is 2: containment in {x'Px <= b} iff b >= 2
    assert ellipsoid_contains(P, 2.0 * (1 + 1e-12), Q, 1.0)["status"] == "proved"
    assert ellipsoid_contains(P, 2.0 * (1 - 1e-12), Q, 1.0)["status"] == "not proved"
    # b = 2 exactly: b Q - a P is singular, not positive definite; never claimed
    assert ellipsoid_contains(P, 2.0, Q, 1.0)["status"] == "not proved"


def test_random_containment_agrees_with_the_rayleigh_bound():
    rng = np.random.default_rng(5)
    for _ in range(20):
        A, B = rng.normal(size=(2, 4, 4))
        P, Q = A @ A.T + 0.1 * np.eye(4), B @ B.T + 0.1 * np.eye(4)
        a = Fraction(489, 100)
        lam = np.max(np.linalg.eigvals(np.linalg.solve(Q, P)).real)
        bound = float(a) * lam
        assert ellipsoid_contains(P, bound * (1 + 1e-6), Q, a)["status"] == "proved"
        res = ellipsoid_contains(P, bound * (1 - 1e-6), Q, a)
        assert res["status"] == "not proved"
        assert res["max_inner"] == pytest.approx(bound, rel=1e-9)


def test_bad_inputs_rejected():
    with pytest.raises(ValueError, match="positive definite"):
        ellipsoid_contains(np.eye(2), 1.0, np.diag([1.0, -1.0]), 1.0)
    with pytest.raises(ValueError, match="levels must be > 0"):
        ellipsoid_contains(np.eye(2), 0.0, np.eye(2), 1.0)
    with pytest.raises(ValueError, match="symmetric"):
        ellipsoid_contains(np.array([[1.0, 0.1], [0.0, 1.0]]), 1.0, np.eye(2), 1.0)


def test_search_cache_hits_recomputes_on_new_keys_and_prunes(tmp_path):
    path = tmp_path / "cache.json"
    calls = []

    def compute(v):
        def f():
            calls.append(v)
            return {"P": np.eye(2) * v, "level": 0.1 * v}

        return f

    c = SearchCache(path)
    r1, hit1 = c.get({"case": "a", "P0": np.eye(2)}, compute(1.0))
    c.get({"case": "b"}, compute(2.0))
    c.save()
    assert not hit1 and calls == [1.0, 2.0]
    c2 = SearchCache(path)
    r2, hit2 = c2.get({"case": "a", "P0": np.eye(2)}, compute(3.0))
    assert hit2 and r2 == r1 and calls == [1.0, 2.0]  # floats round-trip exactly
    c2.save()
    assert len(json.loads(path.read_text())) == 1  # unused entry "b" pruned
    c3 = SearchCache(path, enabled=False)
    assert c3.get({"case": "a", "P0": np.eye(2)}, compute(4.0))[1] is False


def test_certified_regions_use_their_stored_coordinates(tmp_path):
    from ipc_paper.certified import coords_map, ipc_certified_regions

    P = np.diag(
        [1.0, 1.0, 1.0 / 3.0, 1.0]
    )  # in hybrid coords the sector point is (0, 0, tan th, 0)
    entry = {"P": P.tolist(), "level": 1.0, "status": "certified"}
    data = {"regions": [{"name": "h", "coords": "hybrid", **entry}, {"name": "f", **entry}]}
    path = tmp_path / "certified.json"
    path.write_text(json.dumps(data))
    h, f = ipc_certified_regions(path)
    x = np.array([[0.0, 0.0, np.radians(59.9), 0.0], [0.0, 0.0, np.radians(60.1), 0.0]])
    assert h.contains(x).tolist() == [True, False]  # tan^2(theta) / 3 <= 1 iff |theta| <= 60 deg
    # flat: z1 = arsinh(tan th) adds to the form, so the 59.9 deg point is outside
    assert f.contains(x).tolist() == [False, False]
    with pytest.raises(ValueError, match="allowed flat, hybrid"):
        coords_map("physical")


def test_exact_positive_definite_is_sylvester_on_symmetric_matrices_only():
    """Leading minors decide definiteness only for a symmetric matrix: [[1, 3], [-3, 1]] has
    positive minors (1 and 10) but is no symmetric positive-definite matrix, so it is refused."""
    from fractions import Fraction

    from roa.proof._exact import exact_positive_definite

    assert exact_positive_definite([[2, 1], [1, 2]]) == (True, [Fraction(2), Fraction(3, 2)])
    assert exact_positive_definite([[1, 3], [-3, 1]])[0] is False
    assert exact_positive_definite([[1, 2], [2, 1]]) == (False, [Fraction(1), Fraction(-3)])


def test_exact_positive_definite_pivots_are_ratios_of_leading_minors():
    """One elimination gives the pivots Sylvester's minors do (each minor an exact determinant),
    definite, semidefinite and indefinite alike (issue 39, item 4: I_800 took 180 s)."""
    import random
    import time
    from fractions import Fraction

    import flint

    from roa.proof._exact import exact_positive_definite

    rng = random.Random(1)
    for _ in range(200):
        n = rng.randint(1, 6)
        B = [[Fraction(rng.randint(-9, 9), rng.randint(1, 5)) for _ in range(n)] for _ in range(n)]
        A = [[sum(B[k][i] * B[k][j] for k in range(n)) + (Fraction(rng.randint(-3, 3), 2)
              if i == j else 0) for j in range(n)] for i in range(n)]  # fmt: skip
        if rng.random() < 0.2:
            A[0][0] = Fraction(0)  # a zero first minor: the elimination exchanges rows
        minors = [Fraction(1)]
        for k in range(1, n + 1):
            d = flint.fmpq_mat(k, k, [flint.fmpq(A[i][j].numerator, A[i][j].denominator)
                                      for i in range(k) for j in range(k)]).det()  # fmt: skip
            minors.append(Fraction(int(d.p), int(d.q)))
        stop = next((k for k in range(1, n + 1) if minors[k] <= 0), n)
        want = [minors[k] / minors[k - 1] for k in range(1, stop + 1)]
        assert exact_positive_definite(A) == (stop == n and minors[n] > 0, want)
    t0 = time.perf_counter()
    ok, pivots = exact_positive_definite(np.eye(800))
    assert ok and pivots == [1] * 800 and time.perf_counter() - t0 < 30
