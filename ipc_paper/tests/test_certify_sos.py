"""SOS level-set program: Van der Pol benchmark (published rho = 2.3045, Drake notes), solver
failure as a status, the IPC recast."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from ipc_paper.system import transformed
from roa.lyapunov import QuadraticLyapunov
from roa.proof._validate import validate_level
from roa.search._rays import ray_box
from roa.search._sos import recast, sos_level
from roa.systems.vanderpol import P_BENCHMARK, RHO_BENCHMARK, vanderpol


def test_vanderpol_sos_level_matches_published_and_validates():
    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    r = sos_level(system, V)
    assert r.status == "solved"
    assert abs(r.level - RHO_BENCHMARK) < 1e-3  # published value has 4 decimals (2.3045)
    assert (
        validate_level(system, V, r.level * (1 - 1e-4), cover_estimate=ray_box).status
        == "certified"
    )


def test_forced_solver_failure_is_a_status_not_a_certificate():
    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    r = sos_level(system, V, solver_options={"max_iter": 2})
    assert r.status in ("failed", "inaccurate")
    assert r.status != "solved"
    assert "no certificate" in r.message or "not a certificate" in r.message


def test_ipc_exact_recast_reproduces_vdot():
    T = np.array([[1.0, 3, 3, 1], [0, 1, 2, 1], [0, 0, 1, 1], [0, 0, 0, 1]])
    e = np.array([0.0, 0, 1, -1])
    system = transformed()
    V = QuadraticLyapunov.for_system(system, T.T @ (0.5 * (np.eye(4) + np.outer(e, e))) @ T)
    rc = recast(system, V, mode="exact")
    assert len(rc.aux) == 1 and len(rc.equalities) == 1
    M = np.linalg.inv(np.linalg.cholesky(V.P).T)
    rng = np.random.default_rng(0)
    for y in rng.normal(size=(5, 4)):
        x = M @ y
        u = np.sqrt(1 + x[2] ** 2) - 1  # the one recast: u = sqrt(b) - sqrt(b(0)), u >= 0
        sub = dict(zip(rc.d + rc.aux, [*y, u], strict=True))
        positive = float(rc.positive.subs(sub))  # Vdot = positive x V', positive > 0
        assert positive >= 1.0 and abs(positive - (1 + u) ** 3) < 1e-9 * positive
        assert abs(float(rc.Vdot.subs(sub)) - positive * V.derivative(system, x)) < 1e-9 * positive
        assert abs(float(rc.equalities[0].subs(sub))) < 1e-12
        assert abs(float(rc.V.subs(sub)) - V.value(x)) < 1e-9
    assert all(isinstance(g, sp.Expr) for g in rc.nonnegative)


def test_symmetry_reduction_keeps_the_vanderpol_optimum():
    """Odd field: the even/odd block program has the same optimum as the full one (published
    2.3045, Drake notes), with smaller Gram blocks."""
    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    full = sos_level(system, V, symmetry=False)
    red = sos_level(system, V, symmetry=True)
    assert full.status == red.status == "solved"
    assert abs(full.level - red.level) < 1e-5 * RHO_BENCHMARK
    assert max(red.sizes["gram_sizes"]) < max(full.sizes["gram_sizes"])
    assert red.sizes["symmetry"] != "none" and full.sizes["symmetry"] == "none"


def test_symmetry_true_on_a_non_odd_field_is_rejected():
    from roa.model._system import System

    sys_ = System(
        name="quadratic_drift",
        field=lambda t, x, xp: (-x[0] + x[1] ** 2, -x[1]),
        equilibrium=(0.0, 0.0),
        state_names=("a", "b"),
    )
    V = QuadraticLyapunov.for_system(sys_, np.eye(2))
    try:
        sos_level(sys_, V, symmetry=True)
    except ValueError as exc:
        assert "even" in str(exc)
    else:  # pragma: no cover
        raise AssertionError("symmetry=True accepted a field that is not odd")
    assert sos_level(sys_, V).sizes["symmetry"] == "none"


@pytest.mark.slow
def test_ipc_exact_sos_solves_with_symmetry_and_matches_sampled_optimum():
    """The exact recast (u = (1 + w^2)^(1/2) - 1) with even/odd blocks solves; its rho is (up to the
    solver tolerance) a lower bound of the true level, compared with the independent IPOPT
    optimum (an upper bound attained at a witness)."""
    from ipc_paper.system.lyapunov import paper_lyapunov
    from roa.search._levelset import level_search

    system, V = transformed(), paper_lyapunov()
    r = sos_level(system, V, recast_mode="exact", aux_degree=2)
    opt = level_search(system, V, shape="level", method="casadi").level
    assert r.status == "solved"
    assert opt * (1 - 1e-3) < r.level < opt * (1 + 1e-5)
