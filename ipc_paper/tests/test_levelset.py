"""Generic level-set search: closed-form problems, the Van der Pol benchmark, method agreement."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from roa.lyapunov import QuadraticLyapunov
from roa.model._system import System
from roa.options import SampledOptions
from roa.search._levelset import (
    AGREEMENT_RTOL,
    WITNESS_ATOL,
    casadi_level,
    inner_level,
    level_search,
    lyapunov_matrix,
    sampled_level,
)
from roa.status import LevelStatus
from roa.systems.vanderpol import P_BENCHMARK, RHO_BENCHMARK, vanderpol


def _cubic() -> System:
    # x1' = -x1 + x1^3, x2' = -x2: with V = ||x||^2, V' = -2 x1^2 (1 - x1^2) - 2 x2^2,
    # so V' < 0 on 0 < ||x||^2 <= c exactly for c < 1; c* = 1 (closed form), witness (+-1, 0).
    def field(t: Any, x: Any, xp: Any) -> tuple:
        return (-x[0] + x[0] ** 3, -x[1])

    return System("cubic", field, (0.0, 0.0), ("x1", "x2"))


@pytest.mark.parametrize("method", ["sampled", "casadi"])
def test_closed_form_cubic(method):
    system = _cubic()
    V = QuadraticLyapunov.for_system(system, np.eye(2))
    res = level_search(system, V, shape="ball", method=method)
    assert res.status is LevelStatus.FOUND
    assert res.level == pytest.approx(1.0, rel=1e-9)
    assert np.allclose(np.abs(res.witness), [1.0, 0.0], atol=1e-6)


@pytest.mark.parametrize("method", ["sampled", "casadi"])
def test_vanderpol_benchmark(method):
    """Drake course notes: rho = 2.3045 for V = x'Px, P = [[1.5, -0.5], [-0.5, 1]]."""
    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    res = level_search(
        system, V, shape="level", method=method, sampled=SampledOptions(n_directions=4000)
    )
    assert res.level == pytest.approx(RHO_BENCHMARK, abs=1e-3)
    assert abs(res.vdot_witness) < WITNESS_ATOL
    assert V.value(res.witness) == pytest.approx(res.level, rel=1e-12)


@pytest.mark.parametrize("shape", ["ball", "level"])
def test_ipc_methods_agree_and_witness_verifies(shape):
    from ipc_paper.estimates import khalil
    from ipc_paper.system import lyapunov as ly

    res = khalil(shape)
    assert res["status"] == "agree"
    assert res["relative_difference"] <= AGREEMENT_RTOL
    for r in res["per_method"].values():
        assert r["status"] == "found"
        assert abs(r["vdot_witness"]) < WITNESS_ATOL
    assert abs(res["Phi_witness"]) < WITNESS_ATOL
    # the witness is on the boundary of the shape set: s(witness) = value
    xi = np.asarray(res["witness"])
    assert xi @ ly.shape_matrix(shape) @ xi == pytest.approx(res["value"], rel=1e-12)
    # no sampled point strictly inside the set has Phi >= 0 (independent brute-force check)
    rng = np.random.default_rng(11)
    U = rng.standard_normal((200000, 4))
    L = np.linalg.cholesky(ly.shape_matrix(shape))
    X = np.linalg.solve(L.T, (U / np.linalg.norm(U, axis=1, keepdims=True)).T).T
    X *= np.sqrt(res["value"] * 0.999) * rng.uniform(0.05, 1.0, (len(X), 1))
    assert np.max(ly.Phi(ly.to_q(X))) < 0


def test_sampled_estimate_decreases_with_samples():
    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    res = sampled_level(system, V, P_BENCHMARK, shape="level", n_directions=1024)
    vals = [c["value"] for c in res.details["convergence"]]
    assert all(a >= b for a, b in zip(vals, vals[1:], strict=False))
    assert vals[-1] >= res.value - 1e-12  # raw minima are upper bounds of the refined value


def test_linear_system_is_unbounded_and_lyapunov_equation():
    def field(t: Any, x: Any, xp: Any) -> tuple:
        return (-x[0] + 2 * x[1], -3 * x[1])

    system = System("linear", field, (0.0, 0.0), ("x1", "x2"))
    P = lyapunov_matrix(system)
    A = np.array([[-1.0, 2], [0, -3]])
    assert np.allclose(A.T @ P + P @ A, -np.eye(2), atol=1e-12)
    V = QuadraticLyapunov.for_system(system, P)
    assert sampled_level(system, V, np.eye(2), n_directions=64).status == "unbounded"
    assert casadi_level(system, V, np.eye(2), n_starts=2).status == "unbounded"


def test_not_locally_negative():
    def field(t: Any, x: Any, xp: Any) -> tuple:  # V' = 2 x'(A) x with A = [[-1, 3], [0, -1]]
        return (-x[0] + 3 * x[1], -x[1])

    system = System("skew", field, (0.0, 0.0), ("x1", "x2"))
    V = QuadraticLyapunov.for_system(system, np.eye(2))
    res = level_search(system, V, shape="ball", method="both")
    assert res.status is LevelStatus.NOT_LOCALLY_NEGATIVE and res.level is None
    assert "not negative definite" in res.message


def test_inner_level_closed_form():
    P = np.diag([1.0, 4.0])
    assert inner_level(P, 2.0, np.eye(2)) == pytest.approx(0.5)


def test_bad_options():
    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    with pytest.raises(ValueError, match="n_directions"):
        sampled_level(system, V, P_BENCHMARK, n_directions=3)
    with pytest.raises(ValueError, match="method"):
        level_search(system, V, method="grid")
    with pytest.raises(ValueError, match="positive definite"):
        level_search(system, V, shape=-np.eye(2))
    with pytest.raises(ValueError, match="SampledOptions.n_directions must be in"):
        SampledOptions(n_directions=10**9)


def test_both_takes_only_successful_results():
    """Van der Pol, V-level shape: c* = 2.3045 (published, Drake notes). A sampled search with
    r_max = 1 (s <= 1 < c*) ends 'unbounded' with value 1.0, which is not an upper bound of c*:
    the combined result must be the CasADi level, with status 'partial', not min(1.0, 2.3045)."""
    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    res = level_search(system, V, shape="level", method="both", sampled=SampledOptions(r_max=1.0))
    assert res.per_method["sampled"].status is LevelStatus.UNBOUNDED
    assert res.per_method["sampled"].level is None
    assert res.per_method["sampled"].lower_bound == 1.0
    assert res.per_method["casadi"].status is LevelStatus.FOUND
    assert res.status is LevelStatus.PARTIAL
    assert res.level == pytest.approx(2.3045, abs=1e-3)
    assert res.witness is not None
