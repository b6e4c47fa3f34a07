"""The sampled cutting-plane search of a polynomial V (roa.search._cutting_planes) and its
certification (roa.certify with roa.CuttingPlanes, roa.certify(..., vs=VsOptions(method=
"sampled"))), on Van der Pol (reversed, mu = 1), whose true region is bounded by its limit cycle."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import roa
from roa.errors import RoaInputError
from roa.options import SampleSearchOptions, VsOptions
from roa.proof._cover import gram_cover
from roa.search._cutting_planes import monomials, sample_search

FAST = SampleSearchOptions(rounds=6, directions=1500, radial=12, soft_points=600,
                           initial_cuts=600, outer_points=400, horizon=20.0)  # fmt: skip


@pytest.fixture(scope="module")
def vdp():
    return roa.load_system("vanderpol")


@pytest.fixture(scope="module")
def cycle(vdp):
    """The limit cycle, by forward integration of the negated (reversed) field."""
    from scipy.integrate import solve_ivp

    sol = solve_ivp(lambda t, x: -vdp.f(x[None])[0], (0, 40), [2.0, 0.0], rtol=1e-10,
                    atol=1e-12, dense_output=True)  # fmt: skip
    X = sol.sol(np.linspace(25, 40, 30001)).T
    i = np.where((X[:-1, 1] < 0) & (X[1:, 1] >= 0))[0]
    return X[i[0] : i[1] + 1]


def _inside(poly: np.ndarray, P: np.ndarray) -> np.ndarray:
    from matplotlib.path import Path

    return np.asarray(Path(poly).contains_points(P))


def test_options_validation_names_the_field():
    with pytest.raises(RoaInputError, match="SampleSearchOptions.degree"):
        SampleSearchOptions(degree=3)
    with pytest.raises(RoaInputError, match=r"SampleSearchOptions.margin must be in \(0, 10\)"):
        SampleSearchOptions(margin=0.0)
    with pytest.raises(RoaInputError, match="SampleSearchOptions.outer"):
        SampleSearchOptions(grow=2.0, outer=1.5)
    with pytest.raises(RoaInputError, match="VsOptions.method"):
        VsOptions(method="neural")
    assert VsOptions(method="sampled", sampled={"rounds": 3}).sampled.rounds == 3


def test_monomials_count():
    # C(n + d - 1, d) monomials of degree d in n variables
    assert len(monomials(4, [4])) == 35
    assert len(monomials(4, [2, 4])) == 45
    assert len(monomials(2, range(1, 4))) == 2 + 3 + 4


def test_search_candidate_is_a_gram_form_with_a_global_cover(vdp):
    seed = roa.default_lyapunov(vdp)
    hard = np.array([[0.8, 0.0], [0.0, 0.8], [-0.8, 0.0], [0.0, -0.8]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = sample_search(vdp, seed, hard=hard, options=FAST.replace(rounds=2))
    V = res.V
    assert V is not None and V.degree == 4
    # even V for the odd field: no odd-degree terms
    assert all(sum(m) % 2 == 0 for m in V.terms)
    # the hard targets are in {V <= 1} (up to the solver's tolerance)
    assert np.all(V.value(hard) <= 1 + 1e-6)
    # V = m' Q m with Q positive definite: the validation's global cover applies
    basis, Q = V.gram
    assert np.linalg.eigvalsh(Q)[0] > 0
    assert gram_cover(V, 1.0) is not None
    assert res.sizes["gram_blocks"] == [2, 3]  # odd block (x1, x2), even block (quadratics)
    assert {"round", "status", "cuts", "violators"} <= set(res.rounds[0].to_dict())


@pytest.mark.slow
def test_sampled_certificate_is_inside_the_limit_cycle(vdp, cycle):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cert = roa.certify(vdp, degree=4, vs=VsOptions(method="sampled", sampled=FAST),
                           check_above=1.001)  # fmt: skip
    assert cert.certified, cert.message
    assert cert.level is not None and cert.candidate is not None
    assert cert.level <= cert.candidate  # validated at most at the sampled optimum
    assert cert.vs is not None and cert.vs.to_dict()["degree"] == 4
    # the certified set lies in the true region (inside the limit cycle)
    g = np.linspace(-3, 3, 301)
    G = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    inside_V = cert.V.value(G) <= cert.level
    assert inside_V.sum() > 100
    assert np.all(_inside(cycle, G[inside_V]))
    # and every trajectory from it converges (reversed VdP: forward in the negated cycle)
    from scipy.integrate import solve_ivp

    for x0 in G[inside_V][:: max(1, int(inside_V.sum()) // 8)]:
        sol = solve_ivp(lambda t, x: vdp.f(x[None])[0], (0, 30), x0, rtol=1e-8, atol=1e-10)
        assert np.linalg.norm(sol.y[:, -1]) < 1e-2
    # no certified level above the true optimum: just above V's optimum it is refuted
    assert cert.above is not None and cert.above.status.value == "refuted"


def test_certify_sampled_needs_a_quadratic_seed(vdp):
    from roa.lyapunov import PolynomialLyapunov

    def certify_sampled(system, V0, **kw):
        return roa.certify(system, roa.CuttingPlanes(seed=V0), **kw)

    V = PolynomialLyapunov([[2, 0], [0, 2], [4, 0]], [1.0, 1.0, 1.0], [0.0, 0.0])
    with pytest.raises(RoaInputError, match="quadratic seed"):
        certify_sampled(vdp, V)
    with pytest.raises(RoaInputError, match="check_above"):
        certify_sampled(vdp, None, check_above=0.5)


@pytest.mark.slow
def test_certify_sampled_retries_below_a_confirmed_witness(vdp):
    """A level above V's true optimum (here 1.3 x the sampled one, given on purpose) is refuted
    with a 50-digit witness w; V(w) bounds the optimum, so the level is chosen again below it and
    certified, with the refutation just above V(w) (no certified level above the optimum)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        first = {}

        def level(V, c):  # above the optimum the first time, then just below the bound
            if "c" not in first:
                first["c"] = c
                return 1.3 * c
            return 0.999 * c

        cert = roa.certify(vdp, roa.CuttingPlanes(FAST, level=level), check_above=1.001)
    assert cert.certified, cert.message
    assert "retried below confirmed witnesses" in cert.message and "50 digits" in cert.message
    assert cert.level_source == "witness"  # not the caller's level function's first answer
    assert cert.candidate is not None and cert.candidate <= first["c"]
    # at most level_safety (0.98 here) x the corrected optimum, below the refuted level
    assert cert.level <= FAST.level_safety * cert.candidate * (1 + 1e-12)
    assert cert.level < 1.3 * first["c"]
    assert cert.above is not None and cert.above.status.value == "refuted"
    assert cert.above.level == pytest.approx(1.001 * cert.candidate, rel=1e-12)
    # the refutation's witness: V <= its level and V' >= 0, re-checked here at 50 digits
    from roa.proof._witness import recheck_witness

    w = np.asarray(cert.above.witness)
    assert recheck_witness(vdp, cert.V, w, cert.above.level)["confirmed"]
    with pytest.raises(RoaInputError, match="retries"):
        roa.certify(vdp, roa.CuttingPlanes(FAST), retries=-1)
