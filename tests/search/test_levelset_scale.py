"""Level search where it used to fail: a 10-state system and an equilibrium whose V' starts at degree 4.

Reference levels are closed forms derived in each test's docstring; tolerances are relative.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import roa
from roa.lyapunov import QuadraticLyapunov
from roa.model._system import System
from roa.search._levelset import casadi_level, level_search
from roa.search._levelset_core import finish, problem, vdot_order
from roa.status import LevelStatus

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "systems"


def _quartic(a2: float = 4.0) -> System:
    """x1' = x2 - x1^3 + x1^5 / a2, x2' = -x1 - x2^3. With V = |x|^2 the rotation cancels:
    V' = -2 x1^4 + 2 x1^6 / a2 - 2 x2^4, which starts at degree 4 (A'P + PA = 0). V' >= 0 needs
    x1^2 >= a2 (1 + x2^4 / x1^4) >= a2, so min |x|^2 over {V' >= 0} is a2, at (+-sqrt(a2), 0)."""

    def field(t: Any, x: Any, xp: Any) -> tuple:
        return (x[1] - x[0] ** 3 + x[0] ** 5 / a2, -x[0] - x[1] ** 3)

    return System("quartic", field, (0.0, 0.0), ("x1", "x2"))


def test_degree_four_vdot_both_methods_agree_on_the_closed_form():
    """CasADi used to stop next to the equilibrium (V'/s -> 0 there; V' = -1e-46 passed as a
    witness) and the result was 'disagree' at 1e-24; the constraint is now V'/s^2 and such a point
    is refused."""
    system = _quartic(4.0)
    V = QuadraticLyapunov.for_system(system, np.eye(2))
    res = level_search(system, V, method="both")
    assert res.status is LevelStatus.AGREE, res.message
    assert res.level == pytest.approx(4.0, rel=1e-8)
    cas = res.per_method["casadi"]
    assert cas.details["vdot_order"] == 4 and cas.details["n_run"] >= 1
    assert np.abs(cas.witness) @ np.array([1.0, 0.0]) == pytest.approx(2.0, rel=1e-6)


def test_vdot_order_is_two_for_a_definite_linearisation_and_four_when_degenerate():
    quartic = _quartic(4.0)
    V = QuadraticLyapunov.for_system(quartic, np.eye(2))
    assert vdot_order(problem(quartic, V, np.eye(2), "ball")) == 4
    vdp = roa.load_system("vanderpol")
    Vv = roa.default_lyapunov(vdp)
    assert vdot_order(problem(vdp, Vv, Vv.P, "level")) == 2


def test_a_point_next_to_the_equilibrium_is_not_a_witness():
    """V' = -2 (x1^4 + x2^4) + ... is -4e-52 at |x| = 1e-13: below the absolute tolerance, but no
    root of V' is there (V' < 0 on the whole ray up to |x| = 2)."""
    system = _quartic(4.0)
    V = QuadraticLyapunov.for_system(system, np.eye(2))
    prob = problem(system, V, np.eye(2), "ball")
    near = finish(prob, np.array([1e-13, 1e-13]), "casadi", {})
    assert near.status == "failed" and near.witness_kind is None
    on = finish(prob, np.array([2.0 + 1e-9, 0.0]), "casadi", {})  # next to the true root (2, 0)
    assert on.status == "found" and on.value == pytest.approx(4.0, rel=1e-12)


def test_casadi_without_a_violating_ray_runs_nothing_and_claims_no_bound():
    """x' = -x (V' = -2|x|^2 < 0 everywhere): no ray violates, IPOPT is not run, and the status
    says what was searched (rays up to s = 10^4), not that the level is at least that."""
    system = System("decay", lambda t, x, xp: (-x[0], -x[1]), (0.0, 0.0), ("a", "b"))
    V = QuadraticLyapunov.for_system(system, np.eye(2))
    res = casadi_level(system, V, np.eye(2), n_candidates=200)
    assert res.status == "unbounded"
    assert res.details["n_run"] == 0 and res.details["n_rays_violating"] == 0
    assert res.details["searched_up_to"] == pytest.approx(1e4)
    msg = level_search(system, V, method="casadi").message
    assert "not a bound" in msg and "at least" not in msg


@pytest.mark.slow
def test_lyznet_10d_both_methods_agree_on_the_closed_form():
    """LyZNet HSCC'24 example 4 (10 states), V from A'P + PA = -I, which is P = I/2. The skew linear
    parts cancel in V' = -|x|^2 + C(x), C(x) = -0.1 x1 x9^2 - 0.1 x3 x1^2 + 0.1 x5 x7^2
    + 0.1 x10 x2^2 (cubic). Along a ray x = t u (|u| = 1), V' = 0 at t = 1 / C(u), where
    V = 1 / (2 C(u)^2): the level is 1 / (2 m^2) with m the largest C on the unit sphere. The
    first two terms share x1 and give m = 2/45 at u = (-2/3, -1/3, 2/3) on (x1, x3, x9) (larger than
    the single terms' 0.1 x 2 / (3 sqrt 3)), so the level is 2025/8 = 253.125 at (-15, 0, -7.5, 0,
    0, 0, 0, 0, 15, 0). CasADi used to find no start (n_run 0) and claim the level was at least
    900; the sampled level was 0.3 % high."""
    system = roa.load_system(f"{EXAMPLES / 'lyznet_10d.py'}:SYSTEM")
    V = roa.default_lyapunov(system)
    assert np.allclose(V.P, 0.5 * np.eye(10), atol=1e-12)
    res = level_search(system, V, method="both")
    assert res.status is LevelStatus.AGREE, res.message
    for r in res.per_method.values():
        assert r.level == pytest.approx(2025 / 8, rel=1e-6)
    assert res.per_method["casadi"].details["n_run"] >= 1
    u = np.array([-2.0, -1.0, 2.0]) / 3  # the maximiser of C on (x1, x3, x9)
    C = -0.1 * u[0] * u[2] ** 2 - 0.1 * u[1] * u[0] ** 2
    assert C == pytest.approx(2 / 45, rel=1e-14)


@pytest.mark.slow
def test_lyznet_three_copies_30_states_both_methods_agree():
    """Three decoupled copies (30 states) have the same level 2025/8: V and V' are sums over the
    copies, so a copy's witness with the others at 0 is one, and no copy has V' >= 0 below it.
    At the former default (rays up to s = 900) CasADi found no violating ray here."""
    system = roa.load_system(f"{EXAMPLES / 'lyznet_10d.py'}:SYSTEM_30")
    res = level_search(system, method="both")
    assert res.status is LevelStatus.AGREE, res.message
    for r in res.per_method.values():
        assert r.level == pytest.approx(2025 / 8, rel=1e-6)
