"""Back-off on the exact SOS route (roa.certification._backoff): a proposal above the optimum is
refused by the exact check, lower levels are tried, the largest certified one is kept (never
above the closed-form optimum) and the level just above the optimum is refuted."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import roa
from roa.certification._backoff import REL_TOL, back_off, exact_route
from roa.proof._validation import Validation
from roa.status import Verdict

ROOT = Path(__file__).resolve().parents[2]
#: poly2d (x1' = -x1 + 2 x1^2 x2, x2' = -x2), V = |x|^2: V' = -2 r^2 + 4 r^4 cos^3 a sin a in
#: polar coordinates vanishes first at r^2 = 1 / (2 max cos^3 a sin a), max at tan^2 a = 1/3:
#: cos^3 a sin a = 3 sqrt(3) / 16, so the largest level is 8 / (3 sqrt(3)).
POLY2D_OPT = 8 / (3 * math.sqrt(3))


def _poly2d() -> roa.System:
    return roa.load_system(f"{ROOT / 'examples/systems/poly2d.py'}:SYSTEM")


def test_poly2d_optimum_closed_form_against_scipy():
    from scipy.optimize import minimize_scalar

    res = minimize_scalar(lambda a: -(math.cos(a) ** 3) * math.sin(a), bounds=(0, 1.5),
                          method="bounded", options={"xatol": 1e-12})  # fmt: skip
    assert 1 / (2 * -res.fun) == pytest.approx(POLY2D_OPT, rel=1e-9)


def test_proposal_above_optimum_backs_off_below_it_and_is_refuted_above():
    system = _poly2d()
    cert = roa.certify(system, level=roa.CandidateLevel(1.05 * POLY2D_OPT, 1.0),
                       validator=roa.SosValidator())  # fmt: skip
    assert cert.status is Verdict.CERTIFIED
    assert cert.level_source == "backoff"
    assert 0.99 * POLY2D_OPT <= cert.level <= POLY2D_OPT
    tries = cert.validation.meta["backoff"]
    assert tries[0]["level"] == pytest.approx(1.05 * POLY2D_OPT)
    assert tries[0]["status"] == "inconclusive"
    assert all(t["seconds"] >= 0 and t["status"] in ("certified", "inconclusive") for t in tries)
    assert max(t["level"] for t in tries if t["status"] == "certified") == cert.level
    assert len(tries) <= roa.SosValidator().backoff + 1
    assert "exact SOS back-off" in cert.message
    stages = [s["stage"] for s in cert.trace]
    assert stages.count("validate below (exact back-off)") == len(tries) - 1
    # every try above the optimum failed: the exact check cannot pass there
    assert all(t["status"] == "inconclusive" for t in tries if t["level"] > POLY2D_OPT)
    above = roa.certify(system, level=1.001 * POLY2D_OPT, validator="interval")
    assert above.status is Verdict.REFUTED


def test_given_level_is_never_backed_off():
    cert = roa.certify(_poly2d(), level=1.05 * POLY2D_OPT, validator=roa.SosValidator())
    assert cert.status is Verdict.INCONCLUSIVE
    assert cert.level == 1.05 * POLY2D_OPT
    assert "backoff" not in (cert.validation.meta if cert.validation else {})


class _Threshold:
    """A validator certifying exactly the levels <= ``top``, its margin ``top - level``."""

    name = "threshold"

    def __init__(self, top: float, margin: bool = True) -> None:
        self.top, self.margin, self.calls = top, margin, []

    def check(self, system, V, level):
        self.calls.append(level)
        ok = level <= self.top
        meta = {"solver_status": "optimal", "margin": (self.top - level) if self.margin else None}
        return Validation(Verdict.CERTIFIED if ok else Verdict.INCONCLUSIVE, level, 0, 0.0,
                          message="ok" if ok else "check failed", meta=meta)  # fmt: skip


@pytest.mark.parametrize("margin", [True, False])
@pytest.mark.parametrize("top", [0.9995, 0.97, 0.8])
def test_back_off_never_above_threshold_and_reports_every_try(top, margin):
    val = _Threshold(top, margin)
    bo = back_off(None, None, val, 1.0, tries=8)  # type: ignore[arg-type]
    assert [t.level for t in bo.tries] == val.calls
    assert val.calls[0] == 1.0 and len(val.calls) <= 9
    assert bo.level is not None and bo.level <= top
    if margin:  # the margins' secant finds the threshold within the bracket tolerance
        assert bo.level >= top - 2 * REL_TOL
    for t in bo.tries:
        assert (t.status == "certified") == (t.level <= top)


def test_back_off_stops_on_a_refused_precondition():
    class Refused(_Threshold):
        def check(self, system, V, level):
            self.calls.append(level)
            return Validation(Verdict.INCONCLUSIVE, level, 0, 0.0, message="domain",
                              meta={"precondition": "domain"})  # fmt: skip

    val = Refused(0.5)
    bo = back_off(None, None, val, 1.0)  # type: ignore[arg-type]
    assert bo.level is None and val.calls == [1.0]


def test_exact_route_only_where_sos_goes_first():
    system = _poly2d()
    V = roa.default_lyapunov(system)
    assert exact_route(roa.AutoValidator(), system, V) is None  # 2 states: B&B first
    assert exact_route(roa.IntervalValidator(), system, V) is None
    sos = exact_route(roa.SosValidator(), system, V)
    assert sos is not None and sos.fallback is False
    ring = roa.load_system(f"{ROOT / 'examples/systems/ring.py'}:SYSTEM_20")
    assert exact_route(roa.AutoValidator(), ring, roa.default_lyapunov(ring)) is not None


def test_backoff_option_refused_out_of_range():
    with pytest.raises(roa.RoaInputError, match="backoff"):
        roa.SosValidator(backoff=-1)


def test_quadrotor3d_gain_is_lqr_of_the_linearisation():
    import importlib.util

    import scipy.linalg as sl

    mod = roa.load_system(f"{ROOT / 'examples/systems/quadrotor3d.py'}:SYSTEM")
    spec = importlib.util.spec_from_file_location(
        "quadrotor3d", ROOT / "examples/systems/quadrotor3d.py"
    )
    q = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(q)

    g, n = q.G, 9
    A, B = np.zeros((n, n)), np.zeros((n, 4))
    A[0, 3] = A[1, 4] = A[2, 5] = 1.0
    A[3, 7], A[4, 6] = g, -g
    B[5, 0] = B[6, 1] = B[7, 2] = B[8, 3] = 1.0
    P = sl.solve_continuous_are(A, B, np.eye(n), np.eye(4))
    assert np.allclose(np.asarray(q.K), B.T @ P, atol=1e-4)
    # the linearisation of the field at hover is A - B K (finite differences)
    x0, h = np.zeros(n), 1e-6
    J = np.stack([(np.asarray(mod.f(x0 + h * e), float) - np.asarray(mod.f(x0 - h * e), float))
                  / (2 * h) for e in np.eye(n)], axis=1)  # fmt: skip
    assert np.allclose(J, A - B @ np.asarray(q.K), atol=1e-6)


@pytest.mark.slow
def test_quadrotor2d_certified_by_the_exact_route_without_branch_and_bound():
    system = roa.load_system(f"{ROOT / 'examples/systems/quadrotor2d.py'}:SYSTEM")
    cert = roa.certify(system)  # auto: 6 states, the SOS route first, then its back-off
    assert cert.status is Verdict.CERTIFIED
    assert cert.method == "sos-exact"
    assert not any(s.get("by") == "interval" for s in cert.trace)
    search = cert.search
    assert search is not None and search.witness is not None
    # below the level search's confirmed witness (V' >= 0 there): never above the optimum
    assert cert.level < float(search.level)


# -- the solver and its memory estimate (roa.search._sdp) -------------------------------------------
def test_solver_settings_in_each_solvers_keywords():
    from roa.search._sdp import settings

    assert settings("scs", 1e-9, 100) == {"solver": "scs", "eps_abs": 1e-9, "eps_rel": 1e-9,
                                          "max_iters": 100}  # fmt: skip
    assert settings("clarabel", 1e-10) == {"solver": "clarabel", "tol_gap_abs": 1e-10,
                                           "tol_gap_rel": 1e-10, "tol_feas": 1e-10}  # fmt: skip
    for bad in ({"solver": "mosek"}, {"tolerance": 0.0}, {"tolerance": 2.0}, {"max_iter": 0}):
        with pytest.raises(roa.RoaInputError):
            settings(**bad)  # type: ignore[arg-type]


def test_memory_estimate_chooses_the_first_order_solver_for_a_231_block():
    from roa.search._sdp import choose_solver

    # one Gram block of 231 monomials: s = 231 * 232 / 2 = 26796 svec entries, the interior
    # point's dense scaling block 24 s^2 bytes = 16.06 GiB, over the 4 GiB budget
    c = choose_solver([231], rows=10626, nonzeros=231 * 231)
    assert c.ipm_bytes == 24 * 26796**2
    assert c.solver == "scs" and c.scs_bytes < 2**30
    assert choose_solver([50], 1000, 2500).solver == "clarabel"
    assert choose_solver([231], 10626, 231 * 231, "clarabel").solver is None  # refused
    assert choose_solver([231], 10626, 231 * 231, budget=2**20).solver is None


def test_auto_solver_takes_scs_for_blocks_above_the_interior_points_range():
    import cvxpy as cp

    from roa.search._sdp import AUTO_SCS_BLOCK, solve

    for m, expected in ((3, "clarabel"), (AUTO_SCS_BLOCK + 1, "scs")):
        Q = cp.Variable((m, m), symmetric=True)
        prob = cp.Problem(cp.Minimize(cp.trace(Q)), [Q >> 0, Q[0, 0] == 1])
        res = solve(prob, options={"solver": "auto"})
        assert res.solver == expected and res.usable
        assert float(prob.value) == pytest.approx(1.0, abs=1e-4)  # Q = e1 e1'


@pytest.mark.parametrize("solver", ["scs", "clarabel"])
def test_the_solver_is_an_option_and_the_exact_check_still_decides(solver):
    from roa.search._sdp import settings

    system = _poly2d()
    V = roa.default_lyapunov(system)
    opts = settings(solver, 1e-9, 200_000 if solver == "scs" else None)
    v = roa.SosValidator(solver_options=opts).check(system, V, 0.99 * POLY2D_OPT)
    assert v.status is Verdict.CERTIFIED
    above = roa.SosValidator(solver_options=opts).check(system, V, 1.01 * POLY2D_OPT)
    assert above.status is Verdict.INCONCLUSIVE  # the exact check never passes above


@pytest.mark.slow
def test_quadrotor3d_at_099_of_its_optimum_on_the_auto_route():
    """The 9-state quadrotor's recast splits into independent lateral chains; where the clique
    program of those components fails the exact check, the dense program (it fits) is tried too:
    0.99 x the optimum 0.0899728373 (``benchmarks/bench_scale.py``: multistart SLSQP on its own
    copy of the field, its point refuting 1.0002 x at 50 digits) is certified by the auto route,
    and 1.001 x it is not."""
    system = roa.load_system(f"{ROOT / 'examples/systems/quadrotor3d.py'}:SYSTEM")
    opt = 0.0899728373
    cert = roa.certify(system, level=0.99 * opt, validator=roa.SosValidator(fallback=False))
    assert cert.certified, cert.message
    above = roa.certify(system, level=1.001 * opt, validator=roa.SosValidator(fallback=False))
    assert not above.certified
