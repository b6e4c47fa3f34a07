"""Quadratic V search: the ray level is an upper bound of the true level (IPOPT / SLSQP optimum of
the time-reversed Van der Pol benchmark, published 2.3045), extra rays can only lower it, and the
search's inputs are validated."""

from __future__ import annotations

import numpy as np
import pytest

from roa.lyapunov import QuadraticLyapunov
from roa.search._quadratic import optimise_quadratic, ray_level
from roa.systems.vanderpol import P_BENCHMARK, RHO_BENCHMARK, vanderpol


def _unit(n_dir: int, seed: int = 0) -> np.ndarray:
    U = np.random.default_rng(seed).normal(size=(n_dir, 2))
    return U / np.linalg.norm(U, axis=1, keepdims=True)


def test_ray_level_is_an_upper_bound_and_extra_rays_lower_it():
    system = vanderpol()
    coarse = ray_level(system, P_BENCHMARK, _unit(6))
    fine = ray_level(system, P_BENCHMARK, _unit(4000))
    assert coarse >= fine >= RHO_BENCHMARK * (1 - 1e-4)
    assert abs(fine - RHO_BENCHMARK) < 2e-3 * RHO_BENCHMARK  # dense rays in 2D: near the optimum
    # a witness direction of the published level (found by dense rays) as an extra ray
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    U = _unit(4000)
    M = np.linalg.inv(np.linalg.cholesky(P_BENCHMARK).T)
    X = (U @ M.T) * np.sqrt(fine)
    with np.errstate(all="ignore"):
        best = X[np.argmax(V.derivative(system, X))]
    assert ray_level(system, P_BENCHMARK, _unit(6), extra=best[None]) <= coarse


def test_search_rejects_bad_options():
    system = vanderpol()
    ident = lambda X: X  # noqa: E731
    with pytest.raises(ValueError, match="objective"):
        optimise_quadratic(system, P_BENCHMARK, ident, objective="volume")
    with pytest.raises(ValueError, match="rounds"):
        optimise_quadratic(system, P_BENCHMARK, ident, box=((-1, 1), (-1, 1)), rounds=0)
    with pytest.raises(ValueError, match="curve"):
        optimise_quadratic(system, P_BENCHMARK, ident, objective="sector")
