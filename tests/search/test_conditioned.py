"""The best-conditioned quadratic candidate (roa.search.conditioned_lyapunov)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import optimize

import roa
from roa.errors import RoaInputError
from roa.search import conditioned_lyapunov
from roa.search._conditioned import best_conditioned, condition_number


def test_real_spectrum_closed_form():
    """For an eigenvector ``v`` of ``A`` (eigenvalue ``-a``), ``v'Qv = 2a v'Pv`` whatever ``P``:
    the Rayleigh quotients of ``H`` reach ``2 a_min`` and ``2 a_max``, so ``kappa >= a_max /
    a_min``, attained by ``P = I`` for a symmetric ``A``. Found within 0.5 %."""
    A = -np.diag([1.0, 3.0, 2.0])
    P, kappa = best_conditioned(A)
    assert kappa >= 3.0 - 1e-6 and kappa == pytest.approx(3.0, rel=5e-3)
    assert condition_number(A, P) == pytest.approx(kappa)


def test_a_complex_pair_closed_form():
    """``A`` with eigenvalues ``-s +- i w`` is ``T (-s I + w J) T^-1``; with ``P = T^-T T^-1``,
    ``H = 2 s I``: ``kappa = 1`` (``A'P + PA = -I`` gives 2.06 here)."""
    from scipy.linalg import solve_continuous_lyapunov

    A = np.array([[0.0, 1.0], [-2.0, -0.3]])
    P, kappa = best_conditioned(A)
    assert kappa == pytest.approx(1.0, abs=5e-3)
    assert condition_number(A, solve_continuous_lyapunov(A.T, -np.eye(2))) > 2


def test_against_a_direct_minimisation():
    """A non-normal 3 x 3 ``A`` (a complex pair and a real mode): the least ``kappa`` over
    ``P = L L'`` by Nelder-Mead from 4 perturbations of ``A'P + PA = -I``'s factor (scipy,
    independent of the LMIs) is not beaten by more than 1 %."""
    from scipy.linalg import solve_continuous_lyapunov

    A = np.array([[0.0, 1.0, 0.0], [-2.0, -0.3, 1.0], [0.5, 0.0, -1.0]])
    P, kappa = best_conditioned(A)
    L0 = np.linalg.cholesky(solve_continuous_lyapunov(A.T, -np.eye(3)))
    idx = np.tril_indices(3)

    def k(theta):
        L = np.zeros((3, 3))
        L[idx] = theta
        try:
            return condition_number(A, L @ L.T + 1e-12 * np.eye(3))
        except np.linalg.LinAlgError:
            return np.inf

    rng = np.random.default_rng(0)
    starts = [L0[idx] * (1 + 0.3 * rng.normal(size=6)) for _ in range(4)]
    direct = min(optimize.minimize(k, s0, method="Nelder-Mead",
                                   options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 2500}).fun
                 for s0 in starts)  # fmt: skip
    assert np.isfinite(direct) and kappa <= 1.01 * direct
    assert condition_number(A, L0 @ L0.T) >= kappa


def test_the_candidate_is_centred_and_refuses_bad_systems():
    from roa.systems.vanderpol import vanderpol

    V = conditioned_lyapunov(vanderpol())
    assert np.allclose(V.center, 0) and np.all(np.linalg.eigvalsh(V.P) > 0)
    with pytest.raises(RoaInputError, match="not exponentially stable"):
        best_conditioned(np.array([[0.0, 1.0], [-1.0, 0.0]]))
    with pytest.raises(RoaInputError, match="square"):
        best_conditioned(np.ones((2, 3)))
    cubic = roa.load_system("cubic-map")
    with pytest.raises(RoaInputError, match="map"):
        conditioned_lyapunov(cubic)
