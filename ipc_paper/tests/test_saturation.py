"""Nonsmooth functions (minimum, maximum, clip, abs) in every namespace, their interval and jet
enclosures (value, generalised gradient, Taylor forms), and the saturated IPC field."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from ipc_paper import system as ipc
from roa.model._backend import FUNCTIONS, PIECEWISE, namespace
from roa.proof._interval import INTERVAL, Interval, box_offsets, iabs, iclip, imaximum, iminimum
from roa.proof._jet import Jet
from roa.proof._jet_net import JET
from roa.search._rays import ray_box

finite = st.floats(-50.0, 50.0, allow_nan=False, allow_infinity=False)


def _interval(draw: st.DrawFn) -> tuple[float, float]:
    a, b = draw(finite), draw(finite)
    return (min(a, b), max(a, b))


@st.composite
def intervals(draw: st.DrawFn) -> tuple[float, float]:
    return _interval(draw)


def _points(lo: float, hi: float, k: int = 9) -> list[Fraction]:
    """Exact points of [lo, hi]: its ends and interior points (rationals)."""
    a, b = Fraction(lo), Fraction(hi)
    return [a + (b - a) * Fraction(i, k - 1) for i in range(k)]


# -- the namespaces --------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["numpy", "casadi", "sympy", "mpmath"])
def test_every_namespace_has_every_function(name):
    ns = namespace(name)
    for f in FUNCTIONS + PIECEWISE:
        assert callable(getattr(ns, f)), f"{name} lacks {f}"
    for ns2 in (INTERVAL, JET):
        for f in FUNCTIONS + PIECEWISE:
            assert callable(getattr(ns2, f)), f"{ns2.name} lacks {f}"


@pytest.mark.parametrize("name", ["casadi", "sympy", "mpmath"])
def test_piecewise_functions_agree_with_numpy(name):
    import casadi as ca

    ns, NP = namespace(name), namespace("numpy")
    for a, b in [(-2.5, 0.5), (0.5, -2.5), (1.0, 1.0), (3.0, -0.25)]:
        for f, args in [("minimum", (a, b)), ("maximum", (a, b)), ("clip", (a, -1.0, 1.0)),
                        ("clip", (b, -0.5, 2.0)), ("abs", (a,))]:  # fmt: skip
            want = float(getattr(NP, f)(*args))
            got = getattr(ns, f)(*args)
            got = float(ca.DM(got)) if name == "casadi" else float(got)
            assert got == want, (name, f, args)


# -- interval enclosures ---------------------------------------------------------------------------
@settings(max_examples=300, deadline=None)
@given(intervals(), intervals(), intervals())
def test_interval_min_max_clip_abs_enclose_every_value(x, y, bounds):
    X, Y = Interval(*x), Interval(*y)
    lo, hi = bounds
    encl = {
        "min": iminimum(X, Y),
        "max": imaximum(X, Y),
        "clip": iclip(X, lo, hi),
        "abs": iabs(X),
    }
    for p in _points(*x):
        for q in _points(*y):
            exact = {"min": min(p, q), "max": max(p, q), "clip": min(max(p, Fraction(lo)), Fraction(hi)),
                     "abs": abs(p)}  # fmt: skip
            for k, v in exact.items():
                e = encl[k]
                assert Fraction(float(e.lo)) <= v <= Fraction(float(e.hi)), (k, x, y, bounds)
    # tight: the enclosure of min/max is the exact range (attained at the corners)
    assert float(encl["min"].lo) == min(x[0], y[0]) and float(encl["min"].hi) == min(x[1], y[1])
    assert float(encl["max"].lo) == max(x[0], y[0]) and float(encl["max"].hi) == max(x[1], y[1])


def test_interval_namespace_vectorised_and_constants():
    X = Interval(np.array([-3.0, -0.5, 0.2, 2.0]), np.array([-2.0, 0.5, 0.8, 5.0]))
    c = INTERVAL.clip(X, -1.0, 1.0)
    assert c.lo.tolist() == [-1.0, -0.5, 0.2, 1.0]
    assert c.hi.tolist() == [-1.0, 0.5, 0.8, 1.0]
    a = INTERVAL.abs(X)
    assert a.lo.tolist() == [2.0, 0.0, 0.2, 2.0] and a.hi.tolist() == [3.0, 0.5, 0.8, 5.0]
    m = INTERVAL.minimum(0.0, X)  # a constant first
    assert m.lo.tolist() == [-3.0, -0.5, 0.0, 0.0] and m.hi.tolist() == [-2.0, 0.0, 0.0, 0.0]


# -- jets: generalised gradients and the centred / Taylor forms -------------------------------------
class _Exact:
    """mpmath numbers at 1200 digits: exact for the few sums and products of doubles used here."""

    name = "exact"
    minimum = staticmethod(min)
    maximum = staticmethod(max)
    abs = staticmethod(abs)

    @staticmethod
    def clip(x, lo, hi):
        return min(max(x, lo), hi)


def _f(x, xp, k):
    """Nonsmooth test functions of two variables (products, sums and compositions of kinks)."""
    a, b = x
    if k == 0:
        return xp.clip(a * 2.0 + b, -1.0, 1.0)
    if k == 1:
        return xp.minimum(a * a, b + 0.5) * b
    if k == 2:
        return xp.abs(a - b) * a + xp.maximum(b, 0.25)
    if k == 3:
        return xp.clip(a * b - 0.5, -0.75, 0.5) * (a + 1.0) + xp.abs(b)
    return xp.maximum(xp.clip(a, -0.5, 0.5), b * b * 0.5 - a)


def _exact_f(p, k):
    import mpmath as mp

    with mp.workdps(1200):
        return _f([mp.mpf(float(p[0])), mp.mpf(float(p[1]))], _Exact, k)


def _inside(v, e: Interval, i: int = 0) -> bool:
    """The mpmath number ``v`` lies in entry ``i`` of ``e`` (compared exactly)."""
    import mpmath as mp

    lo, hi = float(np.atleast_1d(e.lo)[i]), float(np.atleast_1d(e.hi)[i])
    with mp.workdps(1200):
        return (lo == -np.inf or mp.mpf(lo) <= v) and (hi == np.inf or v <= mp.mpf(hi))


@st.composite
def boxes(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    small = st.floats(-2.0, 2.0, allow_nan=False)
    a, b, c, d = draw(small), draw(small), draw(small), draw(small)
    return np.array([min(a, b), min(c, d)]), np.array([max(a, b), max(c, d)])


def _jet_encloses(box, k, centred):
    """Over a box: the value enclosure holds f; the gradient enclosure holds every slope
    (f(p) - f(p')) / (p_i - p'_i) along each axis, hence every one-sided partial derivative and
    Clarke's generalised gradient; the centred form f(m) + G (p - m) and the second-order Taylor
    form (as the validations build them) hold f(p) at every test point p of the box."""
    import mpmath as mp

    lo, hi = box
    J = _f(Jet.variables(lo[None], hi[None], order=2, centred=centred), JET, k)
    mid = 0.5 * (lo + hi)
    at = _f(Jet.variables(mid[None], mid[None], order=1), JET, k)
    delta_of = lambda p: box_offsets(p[None], p[None], mid[None])  # noqa: E731 - exact p - mid
    G = [Interval.of(g) for g in J.g]
    fm = _exact_f(mid, k)
    assert _inside(fm, Interval.of(at.v))
    grid = [
        np.clip(np.array([s, t]), lo, hi)
        for s in np.linspace(lo[0], hi[0], 4)
        for t in np.linspace(lo[1], hi[1], 4)
    ]
    for p in grid:
        fp = _exact_f(p, k)
        assert _inside(fp, J.v), ("value", p)
        d = delta_of(p)
        cen, tay = Interval.of(at.v), Interval.of(at.v)
        for i in range(2):
            cen = cen + G[i] * d[i]
            tay = tay + Interval.of(at.g[i]) * d[i]
            for j in range(i, 2):
                h = Interval.of(J.h[i][j])
                tay = tay + (h * 0.5 * d[i].square() if i == j else h * (d[i] * d[j]))
        assert _inside(fp, cen), ("centred form", p)
        assert _inside(fp, tay), ("Taylor form", p)
        for i in range(2):  # slopes along each axis, exact
            for q in grid:
                if q[1 - i] == p[1 - i] and q[i] != p[i]:
                    with mp.workdps(1200):
                        s = (_exact_f(q, k) - fp) / (mp.mpf(float(q[i])) - mp.mpf(float(p[i])))
                    assert _inside(s, G[i]), ("slope", i, p, q)


@settings(max_examples=40, deadline=None)
@given(boxes(), st.integers(0, 4), st.booleans())
def test_jet_value_gradient_and_forms_enclose_nonsmooth_functions(box, k, centred):
    """40 boxes (the slow suite draws 400): see :func:`_jet_encloses`."""
    _jet_encloses(box, k, centred)


@pytest.mark.slow
@settings(max_examples=400, deadline=None)
@given(boxes(), st.integers(0, 4), st.booleans())
def test_jet_encloses_nonsmooth_functions_on_many_boxes(box, k, centred):
    _jet_encloses(box, k, centred)


def test_clip_derivative_is_zero_one_or_the_hull():
    x = Jet.variables(np.array([[-3.0], [-0.5], [0.5], [2.0]]), np.array([[-2.0], [0.5], [1.5], [3.0]]), order=2)[0]  # fmt: skip
    c = JET.clip(x, -1.0, 1.0)
    g = Interval.of(c.g[0])
    assert g.lo.tolist() == [0.0, 1.0, 0.0, 0.0] and g.hi.tolist() == [0.0, 1.0, 1.0, 0.0]
    h = Interval.of(c.h[0][0])  # a kink inside the box: no second-order information
    assert h.lo.tolist() == [0.0, 0.0, -np.inf, 0.0] and h.hi.tolist() == [0.0, 0.0, np.inf, 0.0]
    a = JET.abs(x)
    ga = Interval.of(a.g[0])
    assert ga.lo.tolist() == [-1.0, -1.0, 1.0, 1.0] and ga.hi.tolist() == [-1.0, 1.0, 1.0, 1.0]


def test_kink_box_fails_the_hessian_test():
    """A box across the saturation gives an interval Hessian with infinite entries: the
    negative-definiteness test (local proof) refuses it instead of trusting a kinked V'."""
    from roa.proof._local import hessian_negative_definite

    x, y = Jet.variables(np.array([[0.5, -0.1]]), np.array([[1.5, 0.1]]), order=2)
    vd = -(x * x) - y * y + JET.clip(x + y, -1.0, 1.0) * x * 0.1  # x + y crosses 1
    assert not hessian_negative_definite(vd, 2)
    x, y = Jet.variables(np.array([[-0.1, -0.1]]), np.array([[0.1, 0.1]]), order=2)
    vd = -(x * x) - y * y + JET.clip(x + y, -1.0, 1.0) * x * 0.1  # no kink in this box
    assert hessian_negative_definite(vd, 2)


# -- the saturated IPC field -----------------------------------------------------------------------
def _reference_field(x: np.ndarray, sat: float) -> np.ndarray:
    """The saturated closed loop as before xp.clip: np.clip of the unsaturated force."""
    from ipc_paper.system.model import accelerations

    u = np.clip(ipc.control_force(0.0, x.T), -sat, sat)
    qdd, thdd = accelerations(x[:, 1], x[:, 2], x[:, 3], u, 1.0)
    return np.stack([x[:, 1], qdd, x[:, 3], thdd], axis=-1)


def test_saturated_field_is_the_same_in_every_namespace():
    import casadi as ca
    import mpmath as mp
    import sympy as sp

    rng = np.random.default_rng(3)
    X = rng.uniform([-2, -2, -1.2, -2], [2, 2, 1.2, 2], size=(16, 4))
    X[:6] *= 0.05  # unsaturated states
    s = ipc.closed_loop(saturation=1.0)
    ref = _reference_field(X, 1.0)
    u = ipc.control_force(0.0, X.T)
    assert np.any(u > 1) and np.any(u < -1) and np.any(np.abs(u) < 1)  # all three pieces
    assert np.array_equal(s.f(X), ref)
    sym = ca.SX.sym("x", 4)
    F = ca.Function(
        "f", [sym], [ca.vertcat(*s.field(0.0, [sym[i] for i in range(4)], namespace("casadi")))]
    )
    I_f = s.field(0.0, [Interval(X[:, i]) for i in range(4)], INTERVAL)
    J_f = s.field(0.0, Jet.variables(X, X, order=2), JET)
    for k, x in enumerate(X):
        np.testing.assert_allclose(np.asarray(F(x)).ravel(), ref[k], rtol=1e-12, atol=1e-12)
        xs = [sp.Rational(float(v)) for v in x]
        f_sym = [float(e) for e in s.field(0.0, xs, namespace("sympy"))]
        np.testing.assert_allclose(f_sym, ref[k], rtol=1e-12, atol=1e-12)
        with mp.workdps(30):
            f_mp = [
                float(e) for e in s.field(0.0, [mp.mpf(float(v)) for v in x], namespace("mpmath"))
            ]
        np.testing.assert_allclose(f_mp, ref[k], rtol=1e-12, atol=1e-12)
        for i in range(4):
            for e in (I_f[i], J_f[i].v):
                assert Interval.of(e).lo[k] <= f_mp[i] <= Interval.of(e).hi[k]


def test_saturated_linearisation_is_the_unsaturated_one():
    from roa.model._linearisation import jacobian

    np.testing.assert_allclose(
        jacobian(ipc.closed_loop(saturation=1.0)), jacobian(ipc.closed_loop()), atol=1e-14
    )


def test_centred_jets_decide_the_branch_where_the_natural_range_cannot():
    def f(x):
        return JET.clip(x * 3.0 - x * 2.0, -1.0, 0.7)  # = x on [0.4, 0.6]: no kink reached

    loose = f(Jet.variables(np.array([[0.4]]), np.array([[0.6]]), order=2, centred=False)[0])
    tight = f(Jet.variables(np.array([[0.4]]), np.array([[0.6]]), order=2, centred=True)[0])
    assert Interval.of(loose.g[0]).lo[0] == 0.0 and np.isinf(Interval.of(loose.h[0][0]).hi[0])
    assert tight.g[0] == 1.0 and tight.h[0][0] == 0.0  # exact: the identity branch
    assert 0.4 - 1e-12 < tight.v.lo[0] <= 0.4 and 0.6 <= tight.v.hi[0] < 0.6 + 1e-12


def test_centring_changes_nothing_for_smooth_expressions():
    lo, hi = np.array([[0.1, -0.3], [1.0, 2.0]]), np.array([[0.2, 0.1], [1.5, 2.5]])
    out = []
    for centred in (False, True):
        x, y = Jet.variables(lo, hi, order=2, centred=centred)
        e = JET.sin(x * y) / (1.0 + y * y) + JET.sqrt(x + 2.0) * JET.arctan(y)
        out.append([e.v, *e.g, *(h for row in e.h for h in row)])
    for a, b in zip(*out, strict=True):
        a, b = Interval.of(a), Interval.of(b)
        assert np.array_equal(a.lo, b.lo) and np.array_equal(a.hi, b.hi)


def test_flat_saturated_loop_is_the_physical_one_in_flat_coordinates():
    """d/dt xi(x(t)) = J(x) f(x) of the saturated physical loop equals the saturated flat field
    at xi(x) (sympy Jacobian of (2.2), evaluated at 30 digits; saturated and unsaturated states;
    the float gains limit the agreement to ~1e-16)."""
    import mpmath as mp
    import sympy as sp

    from ipc_paper.system.coordinates import to_flat_components

    S, M = namespace("sympy"), namespace("mpmath")
    q = sp.symbols("q qd th thd", real=True)
    xi = sp.Matrix(to_flat_components(*q, xp=S))
    J = xi.jacobian(sp.Matrix(q))
    for delta in (1.0, 2.5):
        phys = ipc.closed_loop(saturation=0.8, delta=delta)
        flat = ipc.transformed(saturation=0.8, delta=delta)
        push = sp.lambdify(q, list(J * sp.Matrix(phys.field(0.0, list(q), S))), "mpmath")
        rng = np.random.default_rng(5)
        X = rng.uniform([-2, -2, -1.2, -2], [2, 2, 1.2, 2], size=(8, 4))
        X[:3] *= 0.05
        seen = set()
        for x in X:
            with mp.workdps(30):
                xs = [mp.mpf(float(v)) for v in x]
                want = push(*xs)
                got = flat.field(0.0, list(to_flat_components(*xs, xp=M)), M)
                for a, b in zip(want, got, strict=True):
                    assert abs(a - b) < 1e-13 * (1 + abs(b))
            seen.add(abs(float(ipc.control_force(0.0, x, delta=delta))) > 0.8)
        assert seen == {True, False}
    assert ipc.transformed(saturation=1.0).name == "ipc_flat_saturated"
    assert "numba" not in ipc.transformed(saturation=1.0).meta  # its kernels are unsaturated


# -- certificates of saturated loops ----------------------------------------------------------------
def _saturated_pendulum():
    from roa.model._system import System

    def field(t, x, xp):
        u = xp.clip(-2.0 * x[0] - 2.0 * x[1], -1.0, 1.0)  # PD law, |u| <= 1
        return (x[1], xp.sin(x[0]) + u)

    return System(name="saturated pendulum", field=field, equilibrium=(0.0, 0.0),
                  state_names=("a", "b"))  # fmt: skip


def _level_set_points(V, level, n=4000, seed=0):
    """Points of {V <= level}: random rays scaled to random radii (a quadratic V)."""
    rng = np.random.default_rng(seed)
    U = rng.normal(size=(n, V.n))
    U *= np.sqrt(level / V.value(U))[:, None] * rng.random((n, 1))
    return U


def test_saturated_toy_certified_at_0999_and_refuted_just_above():
    """A pendulum under a saturated PD law: the level of the sampled search is certified at 0.999
    (the set reaches into saturation: V' < 0 is proved for the clipped field) and refuted at
    1.001 with a saturated 50-digit witness."""
    from roa.certification import certify
    from roa.lyapunov import PolynomialLyapunov
    from roa.model._linearisation import lyapunov_matrix
    from roa.options import IntervalOptions
    from roa.search._levelset import level_search

    s = _saturated_pendulum()
    V = PolynomialLyapunov.from_gram(np.eye(2, dtype=int), lyapunov_matrix(s), np.zeros(2))
    found = level_search(s, V, method="sampled")
    cert = certify(s, V, candidate=found, interval=IntervalOptions(sampled_safety=0.999),
                   check_above=1.001)  # fmt: skip
    assert cert.certified, cert.message
    assert cert.above is not None and cert.above.status.value == "refuted"
    w = np.array(cert.above.witness)
    assert cert.above.witness_check["confirmed"] and abs(-2 * w[0] - 2 * w[1]) > 1  # saturated
    X = _level_set_points(V, cert.level)
    assert np.max(np.abs(-2 * X[:, 0] - 2 * X[:, 1])) > 1.2  # the certified set saturates


def test_quadratic_fast_path_rechecks_a_clip_field_witness():
    from roa.lyapunov import QuadraticLyapunov
    from roa.model._linearisation import lyapunov_matrix
    from roa.proof._validate import validate_level

    s = _saturated_pendulum()
    V = QuadraticLyapunov(lyapunov_matrix(s), np.zeros(2))
    assert validate_level(s, V, 0.2934 * 1.01, cover_estimate=ray_box).status.value == "refuted"


def _ipc_saturated_certificate(fraction: float):
    from ipc_paper.system.lyapunov import paper_lyapunov
    from roa.certification import certify
    from roa.options import IntervalOptions
    from roa.search._levelset import level_search

    s = ipc.transformed(saturation=1.0)  # the physical loop |u| <= 1 in flat coordinates
    V = paper_lyapunov()
    found = level_search(s, V, method="sampled")
    cert = certify(s, V, candidate=found, interval=IntervalOptions(sampled_safety=fraction),
                   check_above=1.001)  # fmt: skip
    return s, V, cert


def _assert_saturated_ipc(V, cert):
    from ipc_paper.system.coordinates import from_flat

    assert cert.certified, cert.message
    assert cert.above is not None and cert.above.status.value == "refuted"
    assert cert.above.witness_check["confirmed"]
    assert abs(ipc.control_force(0.0, from_flat(np.array(cert.above.witness)))) > 1  # saturated
    u = ipc.control_force(0.0, from_flat(_level_set_points(V, cert.level)).T)
    assert np.max(np.abs(u)) > 1.1  # the certified set reaches into saturation


@pytest.mark.slow  # the default suite runs C11 in the quick certify experiment (test_report.py)
def test_saturated_ipc_certified_below_and_refuted_just_above():
    """The IPC with |u| <= 1 and the paper's V: 0.9 of the sampled level certified (cheap), 1.001
    refuted by a saturated 50-digit witness."""
    _, V, cert = _ipc_saturated_certificate(0.9)
    _assert_saturated_ipc(V, cert)


@pytest.mark.slow
def test_saturated_ipc_certified_at_0999():
    _, V, cert = _ipc_saturated_certificate(0.999)
    _assert_saturated_ipc(V, cert)


def test_saturated_certificates_are_kept_apart_and_drawn_on_the_saturated_map(tmp_path):
    """certified.json keeps the saturated loop's sets under "saturated": the maps and terminal sets
    of the loop without saturation never see them; the saturated map draws and counts them."""
    import json

    from ipc_paper.basins import _basin_title, slice_panels
    from ipc_paper.certified import ipc_certified_regions, ipc_saturated_regions
    from ipc_paper.system.lyapunov import paper_lyapunov
    from roa.integration import _integrator as I  # noqa: N812
    from roa.montecarlo._sampling import grid_slice

    entry = {"name": "saturated loop |u| <= 1, optimised quadratic V: V <= 0.1 (certified)",
             "P": paper_lyapunov().P.tolist(), "level": 0.1, "status": "certified",
             "coords": "flat", "saturation": 1.0}  # fmt: skip
    path = tmp_path / "certified.json"
    path.write_text(json.dumps({"regions": [], "saturated": [entry]}))
    assert ipc_certified_regions(path) == []
    assert ipc_saturated_regions(path, saturation=2.0) == []
    (r,) = ipc_saturated_regions(path, saturation=1.0)
    assert r.meta["label"] == "our certified level set of V for the saturated loop: V <= 0.1"
    ((words, drawn),) = slice_panels([r], saturated=True)
    assert drawn == [r] and "certified set" in words
    s = ipc.closed_loop(saturation=1.0)
    g = grid_slice(s, ["q", "theta"], [(-1.0, 1.0), (-0.3, 0.3)], (9, 7),
                   fixed={"q_dot": 0.0, "theta_dot": 0.0})  # fmt: skip
    code = np.full(g.n, I.CONVERGED)
    k = int(r.contains(g.points(0, g.n)).sum())
    assert 0 < k < g.n
    title = _basin_title("t", code, 1.0, g, [r])
    assert f"holds {k} of them" in title and "do not converge" not in title
    assert "no certificate of the saturated loop" in _basin_title("t", code, 1.0, g, [])
