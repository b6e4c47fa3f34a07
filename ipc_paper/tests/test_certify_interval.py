"""Interval arithmetic soundness and the interval validation of levels (certify/refute pairs).

Reference levels: Van der Pol benchmark rho = 2.3045 (Tedrake, Underactuated Robotics notes;
LyZNet's dReal bisection 2.3042); IPC paper's V: the sampled optimum is recomputed here by an
independent SLSQP minimisation of V subject to V' = 0 (not by the code under test).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.optimize import minimize

from ipc_paper.system import phi0, transformed
from roa.lyapunov import QuadraticLyapunov
from roa.proof._interval import INTERVAL, Interval, box_offsets
from roa.proof._jet import Jet
from roa.proof._jet_net import JET
from roa.proof._local import local_box, local_box_proof
from roa.proof._validate import validate_level
from roa.search._rays import ray_box
from roa.systems.vanderpol import P_BENCHMARK, RHO_BENCHMARK, vanderpol

finite = st.floats(-5, 5, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(finite, finite, finite, finite, st.floats(0, 1), st.floats(0, 1))
def test_interval_ops_enclose_point_values(a, b, c, d, ta, tb):
    lo1, hi1 = min(a, b), max(a, b)
    lo2, hi2 = min(c, d), max(c, d)
    x = min(max(lo1 + ta * (hi1 - lo1), lo1), hi1)  # a point of [lo1, hi1] despite rounding
    y = min(max(lo2 + tb * (hi2 - lo2), lo2), hi2)
    X, Y = Interval(lo1, hi1), Interval(lo2, hi2)
    for iv, val in (
        (X + Y, x + y),
        (X - Y, x - y),
        (X * Y, x * y),
        (X * X, x * x),
        (INTERVAL.sqrt(X * X + 1.0), np.sqrt(x * x + 1)),
        (X**3, x**3),
        (INTERVAL.arctan(X), np.arctan(x)),
        (INTERVAL.sin(X), np.sin(x)),
        (INTERVAL.cos(X), np.cos(x)),
    ):
        assert iv.lo <= val <= iv.hi
    if lo2 > 0:
        assert (X / Y).lo <= x / y <= (X / Y).hi


@settings(max_examples=200, deadline=None)
@given(finite, finite, st.floats(0, 1))
def test_phi0_interval_encloses_and_is_tight_at_extremes(a, b, t):
    lo, hi = min(a, b), max(a, b)
    w = min(max(lo + t * (hi - lo), lo), hi)
    P = phi0(Interval(lo, hi), INTERVAL)
    assert P.lo <= phi0(w) <= P.hi
    # the jet (value + derivative) encloses phi0 and phi0' = (1 - 2 w^2) (1 + w^2)^(-5/2)
    J = phi0(Jet.variables(np.array([[lo]]), np.array([[hi]]))[0], JET)
    v, g = Interval.of(J.v), Interval.of(J.g[0])
    assert v.lo[0] <= phi0(w) <= v.hi[0]
    assert g.lo[0] <= (1 - 2 * w * w) * (1 + w * w) ** -2.5 <= g.hi[0]
    # the non-monotone phi0 peaks at w = 1/sqrt(2) with 2/(3 sqrt 3): narrow boxes stay tight
    K = phi0(Interval(0.70, 0.71), INTERVAL)
    assert K.hi <= 2 / (3 * np.sqrt(3)) + 0.01


def test_square_of_straddling_interval_is_nonnegative():
    X = Interval(-1.0, 2.0)
    assert (X * X).lo == 0.0 and (X * X).hi >= 4.0
    assert (X * Interval(-1.0, 2.0)).lo < 0  # a different factor: no dependency assumed


def test_vanderpol_certify_and_refute_around_published_level():
    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    below = validate_level(system, V, 0.999 * RHO_BENCHMARK, cover_estimate=ray_box)
    above = validate_level(system, V, 1.001 * RHO_BENCHMARK, cover_estimate=ray_box)
    assert below.status == "certified" and below.boxes > 0
    assert above.status == "refuted"
    assert above.witness_check["confirmed"]
    w = np.asarray(above.witness)
    assert V.value(w) <= 1.001 * RHO_BENCHMARK and V.derivative(system, w) >= 0


def _paper_V():
    T = np.array([[1.0, 3, 3, 1], [0, 1, 2, 1], [0, 0, 1, 1], [0, 0, 0, 1]])
    e = np.array([0.0, 0, 1, -1])
    return T.T @ (0.5 * (np.eye(4) + np.outer(e, e))) @ T


def _slsqp_optimum(system, V) -> float:
    rng = np.random.default_rng(3)
    U = rng.normal(size=(4000, 4))
    U /= np.sqrt(V.value(U))[:, None]  # V(U) = 1
    r = np.linspace(0.05, 4.0, 200)
    bad = V.derivative(system, r[None, :, None] * U[:, None, :]) >= 0
    hit = bad.any(axis=1)
    first = r[np.argmax(bad, axis=1)][hit]
    starts = U[hit][np.argsort(first)[:12]] * np.sort(first)[:12, None]
    best = np.inf
    for x0 in starts:
        r = minimize(
            V.value,
            x0,
            method="SLSQP",
            options={"ftol": 1e-14, "maxiter": 400},
            constraints=[{"type": "eq", "fun": lambda x: V.derivative(system, x)}],
        )
        if r.success and np.linalg.norm(r.x) > 1e-3 and abs(V.derivative(system, r.x)) < 1e-9:
            best = min(best, float(r.fun))
    return best


@pytest.mark.slow
def test_ipc_paper_V_certify_below_refute_above_the_optimum():
    system = transformed()
    V = QuadraticLyapunov.for_system(system, _paper_V())
    opt = _slsqp_optimum(system, V)
    assert 2.0 < opt < 2.5
    below = validate_level(system, V, 0.999 * opt, cover_estimate=ray_box)
    assert below.status == "certified", below.message
    above = validate_level(system, V, 1.001 * opt, cover_estimate=ray_box)
    assert above.status == "refuted" and above.witness_check["confirmed"]


def test_budget_exhaustion_is_inconclusive_not_certified():
    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    v = validate_level(system, V, 0.9999 * RHO_BENCHMARK, max_boxes=50, cover_estimate=ray_box)
    assert v.status == "inconclusive"


def test_local_proof_fails_for_an_unstable_candidate():
    system = vanderpol()
    # V = x1^2 + x2^2 is not a Lyapunov function of the linearisation (V' = 2 mu (x1^2 - 1) x2^2
    # is only <= 0, never negative definite): the local proof must not succeed
    V = QuadraticLyapunov.for_system(system, np.eye(2))
    r = np.full(2, np.sqrt(1e-3))  # the box of {V <= 1e-3}
    assert not local_box_proof(system, V, -r, r)
    # nor on any box of the one loop's search (2^-k of the cover), nor by the lowest-order part
    # (-2 mu x2^2 vanishes on the x1 axis)
    assert local_box(system, V, np.full(2, -1.0), np.full(2, 1.0)) is None
    # (a budget of 2e5 boxes: the branch and bound ends inconclusive, never certified)
    assert (
        validate_level(system, V, 0.5, max_boxes=200_000, cover_estimate=ray_box).status
        != "certified"
    )


def test_not_positive_definite_candidate_rejected():
    system = vanderpol()
    with pytest.raises(ValueError, match="not positive definite"):
        QuadraticLyapunov.for_system(system, np.array([[1.0, 0.0], [0.0, -1.0]]))


def test_bad_level_rejected():
    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    with pytest.raises(ValueError, match="level"):
        validate_level(system, V, -1.0, cover_estimate=ray_box)


@settings(max_examples=300, deadline=None)
@given(
    st.floats(-10, 0, allow_nan=False, allow_subnormal=False),
    st.floats(0, 10, allow_nan=False, allow_subnormal=False),
    st.floats(0, 1),
)
def test_box_offsets_enclose_exact_differences(a, b, t):
    """x - mid over the box, computed exactly with Fractions, lies in the offset interval (boxes
    straddling 0 with unequal sides make lo - mid and hi - mid inexact in floating point)."""
    lo, hi = np.array([[a, -b]]), np.array([[b, -a]])
    mid = np.array([[a + t * (b - a), -(a + t * (b - a))]])
    mid = np.clip(mid, lo, hi)
    for i, d in enumerate(box_offsets(lo, hi, mid)):
        m = Fraction(float(mid[0, i]))
        assert Fraction(float(d.lo[0])) <= Fraction(float(lo[0, i])) - m
        assert Fraction(float(hi[0, i])) - m <= Fraction(float(d.hi[0]))


def test_box_offsets_round_outward_on_a_known_inexact_case():
    # found by random search: lo - mid, hi - mid rounded to nearest lie strictly inside the exact
    # offsets for this box (the naive delta was not an enclosure)
    lo, hi = np.array([[-6.369616873214543]]), np.array([[2.697867137638703]])
    mid = 0.5 * (lo + hi)
    exact = [Fraction(float(v)) - Fraction(float(mid[0, 0])) for v in (lo[0, 0], hi[0, 0])]
    naive = [Fraction(float(lo[0, 0] - mid[0, 0])), Fraction(float(hi[0, 0] - mid[0, 0]))]
    assert naive[0] > exact[0] or naive[1] < exact[1]  # the case really is inexact
    d = box_offsets(lo, hi, mid)[0]
    assert Fraction(float(d.lo[0])) <= exact[0] and exact[1] <= Fraction(float(d.hi[0]))


def _mp_in(iv, value, tol: float = 0.0) -> bool:
    """``value`` (an mpmath number, exact to 40 digits) lies in the float interval (+- ``tol``)."""
    import mpmath as mp

    lo, hi = mp.mpf(float(np.ravel(iv.lo)[0])), mp.mpf(float(np.ravel(iv.hi)[0]))
    return lo - tol <= value <= hi + tol


def test_itan_at_the_pole_is_the_whole_line_not_inverted():
    # [float(pi/2), next float] contains the pole pi/2 (float(pi/2) < pi/2 < its successor)
    a = np.pi / 2
    T = INTERVAL.tan(Interval(a, np.nextafter(a, 4.0)))
    assert T.lo == -np.inf and T.hi == np.inf
    T = INTERVAL.tan(Interval(np.nextafter(a, 0.0), a))  # just below the pole: finite, huge
    assert 1e15 < T.lo <= T.hi < np.inf
    T = INTERVAL.tan(Interval(2.0, 4.0))  # one branch between the poles pi/2 and 3 pi/2
    assert T.lo <= np.tan(2.0) and np.tan(4.0) <= T.hi and np.isfinite(T.hi)


def test_inverted_interval_rejected():
    with pytest.raises(ValueError, match="lower bound > upper bound"):
        Interval(1.0, 0.0)
    assert Interval(np.nan, 0.0).lo == -np.inf  # NaN stays "no information"


@settings(max_examples=300, deadline=None)
@given(st.floats(-20, 20), st.floats(-20, 20), st.floats(0, 1))
def test_tan_log_powers_reciprocal_enclose_mpmath_values(a, b, t):
    """Enclosures checked against 40-digit mpmath values at a point of the box."""
    import mpmath as mp

    lo, hi = min(a, b), max(a, b)
    x = min(max(lo + t * (hi - lo), lo), hi)
    X = Interval(lo, hi)
    with mp.workdps(40):
        _check_enclosures(X, x, lo, hi)


def _check_enclosures(X, x, lo, hi):
    import mpmath as mp

    xm = mp.mpf(x)
    if mp.cos(xm) != 0:
        assert _mp_in(INTERVAL.tan(X), mp.tan(xm))
    if x > 0:
        assert _mp_in(INTERVAL.log(X), mp.log(xm))
        assert _mp_in(X**0.5, mp.sqrt(xm))
        assert _mp_in(X**-1.5, xm**-1.5)
        assert _mp_in(X**2.5, xm**2.5)
    if x != 0:
        assert _mp_in(X.reciprocal(), 1 / xm)  # across zero too: the whole line
        assert _mp_in(X**-3, xm**-3)
    if lo < 0 < hi:
        R = X.reciprocal()
        assert R.lo == -np.inf and R.hi == np.inf


_ops = [
    lambda X, Y: X + Y,
    lambda X, Y: X - Y,
    lambda X, Y: X * Y,
    lambda X, Y: X / Y,
    lambda X, Y: X * X,
    lambda X, Y: X.reciprocal(),
    lambda X, Y: X**3,
    lambda X, Y: X**-2,
    lambda X, Y: X**0.5,
    lambda X, Y: X**-0.5,
    lambda X, Y: INTERVAL.tan(X),
    lambda X, Y: INTERVAL.log(X),
    lambda X, Y: INTERVAL.sqrt(X),
    lambda X, Y: INTERVAL.abs(X),
    lambda X, Y: INTERVAL.sin(X),
    lambda X, Y: INTERVAL.cos(X),
    lambda X, Y: INTERVAL.exp(X),
    lambda X, Y: INTERVAL.arctan(X),
    lambda X, Y: INTERVAL.arcsinh(X),
    lambda X, Y: INTERVAL.arctanh(X),
]
wide = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(wide, wide, wide, wide, st.lists(st.integers(0, len(_ops) - 1), min_size=1, max_size=6))
def test_compositions_never_produce_inverted_intervals(a, b, c, d, chain):
    X, Y = Interval(min(a, b), max(a, b)), Interval(min(c, d), max(c, d))
    with np.errstate(all="ignore"):
        for k in chain:
            X = _ops[k](X, Y)  # Interval() raises on lo > hi
            assert X.lo <= X.hi


def _half_plane_system():
    """Toy system x' = -x (V = |x|^2, V' = -2 |x|^2 < 0 everywhere) on the domain x1 < 1."""
    from roa.model._system import System

    return System(
        name="decay_half_plane",
        field=lambda t, x, xp: (-x[0], -x[1]),
        equilibrium=(0.0, 0.0),
        state_names=("x1", "x2"),
        margin=lambda x, xp: 1.0 - x[0],
        domain_description="x1 < 1",
    )


def test_level_set_cut_by_the_domain_is_not_certified():
    # {|x|^2 <= 4} contains x = (1.5, 0), outside the domain x1 < 1: V' < 0 everywhere is not
    # enough, the sublevel set must lie inside the domain (it does for level 0.81 < 1)
    system = _half_plane_system()
    V = QuadraticLyapunov.for_system(system, np.eye(2))
    cut = validate_level(system, V, 4.0, cover_estimate=ray_box)
    assert cut.status == "refuted"  # a point of the set outside the domain refutes the level
    assert "leaves the domain" in cut.message and cut.meta["precondition"] == "domain"
    w = np.asarray(cut.meta["domain_witness"])
    assert V.value(w) <= 4.0 and w[0] >= 1.0
    assert validate_level(system, V, 0.81, cover_estimate=ray_box).status == "certified"
    # the bounding cube of {V <= 0.999} has x1 <= 0.9995 < 1: provably inside the domain
    assert (
        validate_level(system, V, 0.999, max_boxes=20_000, cover_estimate=ray_box).status
        == "certified"
    )
    assert validate_level(system, V, 1.0001, cover_estimate=ray_box).status != "certified"


def _composite(x, xp):
    """Uses every function of the JET namespace (and /, **) in one expression of two variables."""
    a, b = x[0], x[1]
    return (
        xp.tan(0.3 * a) * xp.arcsinh(b)
        + xp.sqrt(1.0 + a * a) * xp.log(2.0 + b * b)
        + xp.arctan(a * b) / (1.5 + xp.cos(b))
        + xp.exp(-0.5 * a) * xp.sin(a)
        + (1.0 + b * b) ** -1.5 * a
    )


def _jet_and_mp_derivatives(fn, x, lo, hi):
    """Interval jet (order 2) of ``fn`` on the box [lo, hi] and 40-digit mpmath derivatives at x."""
    import mpmath as mp

    from roa.model._backend import namespace

    n = len(x)
    J = fn(Jet.variables(lo[None, :], hi[None, :], order=2), JET)
    with mp.workdps(40):
        xs = [mp.mpf(float(v)) for v in x]

        def f(*args):
            return fn(list(args), namespace("mpmath"))

        g = [mp.diff(f, xs, tuple(int(k == i) for k in range(n))) for i in range(n)]
        H = [
            [mp.diff(f, xs, tuple(int(k == i) + int(k == j) for k in range(n))) for j in range(n)]
            for i in range(n)
        ]
    return J, g, H


def _assert_jet_encloses(J, g, H, tol=1e-30):
    """Enclosure up to ``tol``: 40-digit finite differences of O(1) functions resolve derivatives
    only to an absolute ~1e-35 (a derivative of 1e-91 at a tiny coordinate reads as 0)."""
    n = len(g)
    for i in range(n):
        assert _mp_in(Interval.of(J.g[i]), g[i], tol), (i, J.g[i], g[i])
        for j in range(i, n):
            e = J.h[i][j]
            assert _mp_in(Interval.of(e), H[i][j], tol), (i, j, e, H[i][j])


coord = st.floats(-1.2, 1.2, allow_nan=False)
offset = st.floats(0, 0.05)


@settings(max_examples=80, deadline=None)
@given(coord, coord, offset, offset)
def test_jet_gradient_and_hessian_enclose_mpmath_derivatives(a, b, r1, r2):
    """The local proof and the Taylor forms rely on jet enclosures of the gradient and Hessian: the
    enclosure on a box around x must contain the derivatives at x (mpmath.diff: finite
    differences at 40 digits)."""
    x = np.array([a, b])
    J, g, H = _jet_and_mp_derivatives(_composite, x, x - r1, x + r2)
    _assert_jet_encloses(J, g, H)
    Jp, _, _ = _jet_and_mp_derivatives(_composite, x, x, x)  # point box: only rounding
    _assert_jet_encloses(Jp, g, H)


@settings(max_examples=40, deadline=None)
@given(coord, coord, coord, coord, offset)
def test_jet_of_ipc_vdot_encloses_mpmath_derivatives(a, b, c, d, r):
    """The same for V' of the IPC closed loop (3.8) with the paper's V, as the validation uses it:
    in x (jets of ``grad V . f``), and in the whitened y of the one loop (jets from the exact
    expansions in y; mpmath through the composition with ``x = M y``)."""
    from roa.proof._whiten import Whitened, whitened_system, whitening_for

    system = transformed()
    V = QuadraticLyapunov.for_system(system, _paper_V())
    x = np.array([a, b, c, d])
    J, g, H = _jet_and_mp_derivatives(lambda y, xp: V.vdot_expr(system, y, xp), x, x - r, x + r)
    _assert_jet_encloses(J, g, H)
    W = Whitened(V, system, whitening_for(V))
    Sw = whitened_system(system, W)
    J, g, H = _jet_and_mp_derivatives(lambda y, xp: W.vdot_expr(Sw, y, xp), x, x - r, x + r)
    _assert_jet_encloses(J, g, H)


def test_public_interval_functions_have_docstrings():
    import inspect

    import roa.proof._interval as mod
    import roa.proof._jet as jet_mod

    missing = [
        name
        for m in (mod, jet_mod)
        for name, obj in vars(m).items()
        if not name.startswith("_")
        and inspect.isfunction(obj)
        and obj.__module__ == m.__name__
        and not inspect.getdoc(obj)
    ]
    for cls in (mod.Interval, jet_mod.Jet):
        for name in vars(cls):
            if (
                not name.startswith("_")
                and callable(getattr(cls, name))
                and not inspect.getdoc(getattr(cls, name))
            ):
                missing.append(f"{cls.__name__}.{name}")
    assert not missing, missing
