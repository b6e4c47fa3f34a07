"""Adversarial soundness audit of the linear relaxations (roa.proof._relax) and CROWN.

Each case is one an audit found or probed: a bound of :mod:`roa.proof._relax` checked against
the exact value at the box's points, computed independently of the code under test (Python
Fractions for piecewise-linear networks and affine expressions: exact; mpmath at 60 digits for
the smooth functions). The affine bounds themselves are evaluated exactly (Fractions), so a
violation cannot hide in the checker's rounding."""

from __future__ import annotations

from fractions import Fraction

import mpmath as mp
import numpy as np
import pytest

from roa.nn import MLP, Affine
from roa.proof._relax import LINEAR, Lin, variables
from roa.search._rays import ray_box


def _exact_affine(A: np.ndarray, c: float, d: list[Fraction]) -> Fraction | float:
    """``A . d + c`` exactly; an infinite ``c`` (a side without a bound) as it is."""
    assert np.all(np.isfinite(A)) and not np.isnan(c), (A, c)
    if not np.isfinite(c):
        return float(c)
    return Fraction(float(c)) + sum(
        (Fraction(float(a)) * di for a, di in zip(A, d, strict=True)), Fraction(0)
    )


def _le(a: Fraction | float, b: Fraction | float) -> bool:
    """``a <= b`` for Fractions and infinite floats."""
    if isinstance(a, float) or isinstance(b, float):
        return a == -np.inf or b == np.inf
    return a <= b


def _assert_encloses(q: Lin, k: int, x: list[float], mid: np.ndarray, exact: Fraction) -> None:
    """Box ``k`` of ``q``: lower affine <= exact <= upper affine at ``x``, and inside bounds()."""
    d = [Fraction(float(p)) - Fraction(float(m)) for p, m in zip(x, mid[k], strict=True)]
    lo = _exact_affine(q.lA[k], q.lc[k], d)
    hi = _exact_affine(q.uA[k], q.uc[k], d)
    assert _le(lo, exact), (
        f"lower bound {float(lo)!r} above the exact value {float(exact)!r} at {x}"
    )
    assert _le(exact, hi), (
        f"upper bound {float(hi)!r} below the exact value {float(exact)!r} at {x}"
    )
    b_lo, b_hi = q.bounds()
    assert _le(_frac(b_lo[k]), exact) and _le(exact, _frac(b_hi[k])), (b_lo[k], b_hi[k])


def _frac(v: float) -> Fraction | float:
    return Fraction(float(v)) if np.isfinite(v) else float(v)


def _exact_pwl_net(net: MLP, x: list[float]) -> list[Fraction]:
    """A network of affine maps, ReLU, leaky ReLU and clip in exact rational arithmetic."""
    h = [Fraction(float(v)) for v in x]
    for op in net.ops:
        if isinstance(op, Affine):
            h = [
                sum((Fraction(float(w)) * v for w, v in zip(row, h, strict=True)), Fraction(0))
                + Fraction(float(b))
                for row, b in zip(op.W, op.b, strict=True)
            ]
        elif op.name == "relu":
            h = [max(v, Fraction(0)) for v in h]
        elif op.name == "leaky_relu":
            a = Fraction(float(op.args[0]))
            h = [max(v, Fraction(0)) + a * min(v, Fraction(0)) for v in h]
        elif op.name == "clip":
            lo, hi = (Fraction(float(v)) for v in op.args)
            h = [min(max(v, lo), hi) for v in h]
        else:
            raise AssertionError(op.name)
    return h


# -- underflow of coefficients over wide boxes ------------------------------------------------------
# A coefficient that underflows (1e-200 * 1e-200 -> 0) loses its whole term, and over a box of
# radius 1e300 that term is 1e-100, far beyond the old absolute allowance (k 2^-1022). The
# underflow error is now scaled by 1 + sum of the magnitudes it multiplies.
def test_a_product_whose_coefficient_underflows_is_still_enclosed_on_a_wide_box():
    lo, hi = np.array([[-1e300]]), np.array([[1e300]])
    X, mid = variables(lo, hi)
    q = (X[0] * 1e-200) * 1e-200  # exactly x 1e-200 1e-200 (each float product rounded)
    for x in (-1e300, -1.0, 0.0, 3e299, 1e300):
        exact = Fraction(x) * Fraction(1e-200) * Fraction(1e-200)
        _assert_encloses(q, 0, [x], mid, exact)


@pytest.mark.parametrize("act", ["relu", ("leaky_relu", 0.5), None])
def test_crown_back_substitution_whose_coefficient_underflows_is_still_enclosed(act):
    W = np.array([[1e-200]])
    net = MLP([(W, np.zeros(1)), (W, np.zeros(1))], [act, None])
    lo, hi = np.array([[-1e300]]), np.array([[1e300]])
    X, mid = variables(lo, hi)
    q = net(X, LINEAR)[0]
    for x in (-1e300, -2.5e299, 0.0, 1e299, 1e300):
        _assert_encloses(q, 0, [x], mid, _exact_pwl_net(net, [x])[0])


# -- networks at kinks, at extreme scales, on degenerate and unbounded boxes --------------------------
PWL = ["relu", ("leaky_relu", 0.1), ("leaky_relu", 3.0), ("clip", -0.5, 0.25)]


def _corners_and_samples(rng, lo: np.ndarray, hi: np.ndarray, extra: list) -> list[np.ndarray]:
    n = len(lo)
    pts = [lo, hi, 0.5 * lo + 0.5 * hi]
    pts += [np.where(rng.random(n) < 0.5, lo, hi) for _ in range(4)]
    pts += [rng.uniform(lo, hi) for _ in range(4)]
    pts += [np.clip(np.asarray(p, dtype=float), lo, hi) for p in extra]
    return pts


def _check_pwl_net(net: MLP, lo: np.ndarray, hi: np.ndarray, rng, extra=()) -> int:
    X, mid = variables(lo, hi)
    with np.errstate(all="ignore"):
        out = net(X, LINEAR)
    checked = 0
    for k in range(len(lo)):
        for x in _corners_and_samples(rng, lo[k], hi[k], list(extra)):
            exact = _exact_pwl_net(net, list(x))
            for j, q in enumerate(out):
                _assert_encloses(q, k, list(x), mid, exact[j])
                checked += 1
    return checked


@pytest.mark.parametrize("act", PWL)
def test_crown_units_exactly_at_their_kinks(act):
    """Biases chosen so that units sit exactly at 0 (and at the clip ends) at the box centre and
    at corners: the relaxation's kink handling, checked exactly (Fractions) at those points."""
    rng = np.random.default_rng(1)
    W0 = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, -1.0], [0.5, 0.5], [2.0, 0.0]])
    b0 = np.array([0.0, 0.0, 0.0, -0.25, 0.5])  # unit 5 at its lower clip end where x0 = -0.5
    W1 = np.array([[1.0, -1.0, 0.5, 2.0, -1.0], [-0.5, 0.25, 1.0, -1.0, 1.0]])
    net = MLP([(W0, b0), (W1, np.array([0.0, -0.25])), (np.array([[1.0, -1.0]]), np.zeros(1))],
              [act, act, None])  # fmt: skip
    lo = np.array([[-1.0, -1.0], [0.0, 0.0], [-0.5, 0.0], [0.0, -2.0], [-1e-300, -1e-300],
                   [0.5, 0.5]])  # fmt: skip
    hi = np.array([[1.0, 1.0], [0.0, 0.0], [0.5, 0.5], [2.0, 0.0], [1e-300, 1e-300], [0.5, 0.5]])
    kinks = [[0.0, 0.0], [0.25, 0.25], [-0.5, 0.0], [0.0, 0.25]]
    assert _check_pwl_net(net, lo, hi, rng, kinks) == 6 * 15


@pytest.mark.parametrize("scale", [2.0**-1074 * 3, 1e-300, 1e-150, 1e150, 1e300])
def test_crown_with_extreme_weights_encloses_the_exact_network(scale):
    """Weights and biases near the subnormal range and near overflow, boxes from width 0 to
    radius 1e100: exact rational references (piecewise-linear activations)."""
    rng = np.random.default_rng(int(np.log2(scale)) % 1000)
    checked = 0
    for i, act in enumerate(PWL):
        W0, b0 = rng.normal(size=(4, 2)) * scale, rng.normal(size=4) * scale
        W1, b1 = rng.normal(size=(3, 4)), rng.normal(size=3)
        W2, b2 = rng.normal(size=(1, 3)) * scale, rng.normal(size=1)
        net = MLP([(W0, b0), (W1, b1), (W2, b2)], [act, act, None])
        c = rng.normal(size=(4, 2)) * 10.0 ** (2 * i)
        r = np.array([0.0, 1e-8, 1.0, 1e100])[:, None] * rng.uniform(0.1, 1.0, (4, 2))
        checked += _check_pwl_net(net, c - r, c + r, rng)
    assert checked > 100


def test_unbounded_and_overflowing_boxes_give_enclosures_or_nothing():
    """Boxes with infinite sides, or sides at the largest double: the bounds hold (often the
    whole line) at the finite points of the box."""
    big = np.finfo(float).max
    lo = np.array([[-np.inf, 0.0], [0.0, -1.0], [-np.inf, -np.inf], [-big, -big], [big, big]])
    hi = np.array([[np.inf, 1.0], [np.inf, 1.0], [np.inf, np.inf], [big, big], [big, big]])
    pts = {0: [[1e300, 0.5], [-3.0, 0.0]], 1: [[1e308, -1.0], [0.5, 0.5]], 2: [[1.0, -1e200]],
           3: [[-big, big], [0.0, 1e308]], 4: [[big, big]]}  # fmt: skip
    rng = np.random.default_rng(2)
    for act in PWL:
        net = MLP([(rng.normal(size=(3, 2)), rng.normal(size=3)), (rng.normal(size=(1, 3)),
                   rng.normal(size=1))], [act, None])  # fmt: skip
        with np.errstate(all="ignore"):
            X, mid = variables(lo, hi)
            q = net(X, LINEAR)[0]
        b_lo, b_hi = q.bounds()
        for k, xs in pts.items():
            for x in xs:
                v = _exact_pwl_net(net, x)[0]
                assert (b_lo[k] == -np.inf or Fraction(float(b_lo[k])) <= v) and (
                    b_hi[k] == np.inf or v <= Fraction(float(b_hi[k]))
                ), (act, k, x)


# -- elementwise functions on adversarial ranges, against 60-digit values ---------------------------
def _mp_reference(name: str):
    return {
        "recip": lambda z: 1 / z,
        "sin": mp.sin,
        "cos": mp.cos,
        "tan": mp.tan,
        "exp": mp.exp,
        "log": mp.log,
        "sqrt": mp.sqrt,
        "arctanh": mp.atanh,
        "tanh": mp.tanh,
        "sigmoid": lambda z: 1 / (1 + mp.exp(-z)),
        "softplus": lambda z: mp.log1p(mp.exp(z)),
        "relu": lambda z: max(z, 0),
        "abs": abs,
        "leaky": lambda z: max(z, 0) + mp.mpf(0.25) * min(z, 0),
        "clip": lambda z: min(max(z, mp.mpf(-0.5)), mp.mpf(0.75)),
        "cube": lambda z: z**3,
        "pow05": mp.sqrt,
        "powm2": lambda z: 1 / z**2,
        "square": lambda z: z**2,
    }[name]


def _lin_apply(name: str, x: Lin) -> Lin:
    special = {
        "recip": lambda v: 1.0 / v,
        "leaky": lambda v: LINEAR.leaky_relu(v, 0.25),
        "clip": lambda v: LINEAR.clip(v, -0.5, 0.75),
        "cube": lambda v: v**3,
        "pow05": lambda v: v**0.5,
        "powm2": lambda v: v**-2,
        "square": lambda v: v * v,
    }
    return special[name](x) if name in special else getattr(LINEAR, name)(x)


HALF_PI = float(mp.pi / 2)
ADVERSARIAL = [
    ("recip", 1e-300, 1.0), ("recip", -1.0, -1e-300), ("recip", 1e-3, 1e-3 + 1e-12),
    ("recip", 1e300, 1.7e308), ("sin", 0.0, 1e6), ("sin", -1e13, 1e13), ("sin", 1e5, 1e5 + 1),
    ("cos", HALF_PI - 1e-9, HALF_PI + 1e-9), ("cos", -2.0**41, -2.0**41 + 1.0),
    ("tan", -1.5, 1.5), ("tan", HALF_PI - 1e-7, HALF_PI - 1e-9), ("exp", 700.0, 709.7),
    ("exp", 709.0, 720.0), ("exp", -745.0, -700.0), ("exp", -1e-300, 1e-300),
    ("log", 1e-300, 1.0), ("log", 1.0, 1.0 + 2.0**-52), ("sqrt", 0.0, 1e-300), ("sqrt", 0.0, 4.0),
    ("arctanh", -1 + 2.0**-40, 1 - 2.0**-40), ("tanh", -20.0, 20.0), ("tanh", 19.0, 40.0),
    ("tanh", -1e-300, 1e-300), ("tanh", -1e300, 1e300), ("sigmoid", -745.0, -700.0),
    ("sigmoid", 30.0, 40.0), ("sigmoid", -1e-8, 1e-8), ("softplus", -800.0, -700.0),
    ("softplus", 700.0, 800.0), ("softplus", -1e-10, 1e-10), ("relu", -0.0, 0.0),
    ("relu", -1e-300, 1e-300), ("abs", -1e-300, 2e-300), ("leaky", -3.0, 2.0),
    ("clip", -0.5, 0.75), ("clip", -1.0, -0.5), ("cube", -1e100, 1e100), ("cube", -1e-110, 1e-100),
    ("pow05", 0.0, 1e-300), ("pow05", 1.0, 1e300), ("powm2", 1e-100, 1.0),
    ("square", -1e154, 1e154), ("square", 1e-200, 1e-160),
]  # fmt: skip


@pytest.mark.parametrize(("name", "a", "b"), ADVERSARIAL)
def test_elementwise_relaxations_on_adversarial_ranges_enclose_60_digit_values(name, a, b):
    """One quantity ``x`` on ``[a, b]`` (and a point box at each end): the affine bounds of
    ``f(x)`` evaluated exactly hold against ``f`` at 60 digits at the ends, the centre, 20
    random points and the extreme double just inside each end."""
    rng = np.random.default_rng(ADVERSARIAL.index((name, a, b)))
    lo = np.array([[a], [a], [b]])
    hi = np.array([[b], [a], [b]])
    with np.errstate(all="ignore"):
        X, mid = variables(lo, hi)
        q = _lin_apply(name, X[0])
    f = _mp_reference(name)
    with mp.workdps(60):
        for k in range(3):
            pts = [lo[k, 0], hi[k, 0], 0.5 * lo[k, 0] + 0.5 * hi[k, 0]]
            pts += [np.nextafter(lo[k, 0], np.inf), np.nextafter(hi[k, 0], -np.inf)]
            pts += list(rng.uniform(lo[k, 0], hi[k, 0], 20))
            for x in pts:
                x = float(np.clip(x, lo[k, 0], hi[k, 0]))
                v = f(mp.mpf(x))
                d = Fraction(x) - Fraction(float(mid[k, 0]))
                lo_v = _exact_affine(q.lA[k], q.lc[k], [d])
                hi_v = _exact_affine(q.uA[k], q.uc[k], [d])
                lo_m = (
                    lo_v if isinstance(lo_v, float) else mp.mpf(lo_v.numerator) / lo_v.denominator
                )
                hi_m = (
                    hi_v if isinstance(hi_v, float) else mp.mpf(hi_v.numerator) / hi_v.denominator
                )
                assert lo_m <= v <= hi_m, (name, k, x, float(lo_m), float(v), float(hi_m))
                b_lo, b_hi = q.bounds()
                assert b_lo[k] <= v <= b_hi[k], (name, k, x, b_lo[k], float(v), b_hi[k])


# -- the hook into the branch and bound: every claim of relaxation_bounds against samples -----------
def _fitted_pendulum(act, seed: int = 0):
    """A damped pendulum under a 2-8-1 network whose output layer is least squares on a
    stabilising law (random hidden layer), centred so that the origin is an equilibrium."""
    from roa import System
    from roa.model._backend import namespace

    rng = np.random.default_rng(seed)
    W0, b0 = rng.normal(size=(8, 2)) * 1.5, rng.normal(size=8)
    hidden = MLP([(W0, b0), (np.eye(8), np.zeros(8))], [act, None])
    S = rng.uniform(-3, 3, (4000, 2))
    H = np.stack(hidden([S[:, 0], S[:, 1]], namespace("numpy")), 1)
    y = S @ np.array([-3.0, -2.0]) + 0.2 * np.tanh(S[:, 0] * S[:, 1])
    coef = np.linalg.lstsq(np.concatenate([H, np.ones((len(H), 1))], 1), y, rcond=None)[0]
    net = MLP([(W0, b0), (coef[None, :-1], coef[-1:])], [act, None]).centred([0.0, 0.0])

    def field(t, x, xp):
        return (x[1], -xp.sin(x[0]) - 0.1 * x[1] + net([x[0], x[1]], xp)[0])

    return System(name=f"pendulum-{act}", field=field, equilibrium=(0.0, 0.0),
                  state_names=("theta", "omega"))  # fmt: skip


def _vdot_50(system, P: np.ndarray, x: np.ndarray):
    from roa.model._backend import namespace

    with mp.workdps(50):
        xm = [mp.mpf(float(v)) for v in x]
        f = system.field(0.0, xm, namespace("mpmath"))
        return 2 * mp.fsum(
            xm[i] * mp.mpf(float(P[i, j])) * f[j] for i in range(2) for j in range(2)
        )


@pytest.mark.parametrize("act", ["tanh", "relu", "sigmoid", "softplus", ("leaky_relu", 0.2)])
def test_relaxation_bounds_alone_hold_at_sampled_points_and_at_50_digits(act):
    """relaxation_bounds with the interval forms switched off (whole-line inputs), on boxes
    around the level surface of the linearisation's V: its V' bounds contain V' at 300 samples
    per box (the extreme samples re-evaluated at 50 digits), and wherever it claims the
    multiplier bound F < 0, V' < 0 at every sample with V <= level."""
    from roa.lyapunov import QuadraticLyapunov
    from roa.model._backend import namespace
    from roa.model._linearisation import lyapunov_matrix
    from roa.proof._interval import Interval
    from roa.proof._relax_vdot import relaxation_bounds

    system = _fitted_pendulum(act)
    P = lyapunov_matrix(system)
    V = QuadraticLyapunov(P, [0.0, 0.0])
    rng = np.random.default_rng(3)

    def vdot(S: np.ndarray) -> np.ndarray:
        f = np.stack(system.field(0.0, [S[:, 0], S[:, 1]], namespace("numpy")), 1)
        return 2.0 * np.einsum("mi,ij,mj->m", S, P, f)

    G = rng.uniform(-10, 10, (200_000, 2))
    pos = (vdot(G) >= 0) & (np.sum(G * G, 1) > 1e-4)
    # below the sampled optimum (F claims happen); without a sampled V' >= 0, a moderate level
    level = 0.9 * float(V.value(G[pos]).min()) if pos.any() else float(np.quantile(V.value(G), 0.1))
    m = 150
    u = rng.normal(size=(m, 2))
    c = u * np.sqrt(level * rng.uniform(0.6, 1.4, m) / V.value(u))[:, None]
    r = rng.choice([0.0, 0.01, 0.05, 0.2], (m, 1)) * rng.uniform(0.2, 1.0, (m, 2))
    lo, hi = c - r, c + r
    whole = Interval(np.full(m, -np.inf), np.full(m, np.inf))
    vd, F_hi = relaxation_bounds(system, V, lo, hi, level, whole, whole, np.full(m, 1e300))
    assert np.isfinite(vd.hi).all()
    # where V' >= 0 was sampled, the level is near it: boxes across the surface need F
    assert (F_hi < 0).sum() >= 3 or not pos.any()
    for k in range(m):
        S = np.concatenate([rng.uniform(lo[k], hi[k], (300, 2)), [lo[k], hi[k]]])
        v = vdot(S)
        assert _vdot_50(system, P, S[np.argmax(v)]) <= vd.hi[k], (k, lo[k], hi[k])
        assert _vdot_50(system, P, S[np.argmin(v)]) >= vd.lo[k], (k, lo[k], hi[k])
        inside = V.value(S) <= level
        if F_hi[k] < 0 and inside.any():
            j = int(np.argmax(np.where(inside, v, -np.inf)))
            assert _vdot_50(system, P, S[j]) < 0, (k, lo[k], hi[k], S[j])


# -- end to end: no certificate just above an independently found optimum ---------------------------
def _witness_at_50_digits(system, P: np.ndarray) -> np.ndarray:
    """The point of least V = x'Px with V' >= 0 (dense polar grid in V's own coordinates, then
    SLSQP), moved outward along its ray until V' >= 0 holds at 50 digits."""
    from scipy.optimize import minimize

    from roa.model._backend import namespace

    NP = namespace("numpy")

    def vdot(S: np.ndarray) -> np.ndarray:
        f = np.stack(system.field(0.0, [S[:, 0], S[:, 1]], NP), 1)
        return 2.0 * np.einsum("mi,ij,mj->m", S, P, f)

    T = np.linalg.inv(np.linalg.cholesky(P)).T  # x = T y: V = |y|^2
    phi = np.linspace(0.0, 2 * np.pi, 1500, endpoint=False)
    rho = np.linspace(0.02, 10.0, 2000)
    Y = (rho[None, :, None] * np.stack([np.cos(phi), np.sin(phi)], 1)[:, None, :]).reshape(-1, 2)
    X = Y @ T.T
    ok = vdot(X) >= 0
    assert ok.any()
    x0 = X[np.argmin(np.where(ok, np.sum(Y * Y, 1), np.inf))]
    res = minimize(lambda x: float(x @ P @ x), x0, method="SLSQP",
                   constraints=[{"type": "ineq", "fun": lambda x: float(vdot(x[None])[0])}],
                   options={"ftol": 1e-15, "maxiter": 500})  # fmt: skip
    for x in (res.x, x0):
        for t in (1.0, 1 + 1e-12, 1 + 1e-9, 1 + 1e-6):
            if _vdot_50(system, P, x * t) >= 0:
                return x * t
    raise AssertionError("no witness with V' >= 0 at 50 digits")


@pytest.mark.slow
@pytest.mark.parametrize("act", ["tanh", "sigmoid"])
def test_no_certificate_just_above_an_independent_optimum(act, monkeypatch):
    """A fitted network pendulum: a point ``w`` with ``V'(w) >= 0`` at 50 digits found by a dense
    grid and SLSQP (independent of the branch and bound) bounds the optimum by ``V(w)``; the
    branch and bound, with the relaxation bounds deciding boxes, certifies 0.97 V(w) and does
    not certify 1.001 V(w)."""
    import roa.proof._validate as validate
    from roa.lyapunov import QuadraticLyapunov
    from roa.model._linearisation import lyapunov_matrix

    system = _fitted_pendulum(act)
    P = lyapunov_matrix(system)
    V = QuadraticLyapunov(P, [0.0, 0.0])
    w = _witness_at_50_digits(system, P)
    cw = float(Fraction(float(w[0])) ** 2 * Fraction(float(P[0, 0]))
               + 2 * Fraction(float(w[0])) * Fraction(float(w[1])) * Fraction(float(P[0, 1]))
               + Fraction(float(w[1])) ** 2 * Fraction(float(P[1, 1])))  # fmt: skip
    decided = []
    original = validate.relaxation_bounds

    def counting(system, lyap, lo, hi, level, Vb, vdot, F_hi, n_par=0):
        vd, F = original(system, lyap, lo, hi, level, Vb, vdot, F_hi, n_par)
        before = np.broadcast_to(vdot.hi, vd.hi.shape) < 0
        decided.append(int(np.sum(((vd.hi < 0) | (F < 0)) & ~before & ~(F_hi < 0))))
        return vd, F

    monkeypatch.setattr(validate, "relaxation_bounds", counting)
    below = validate.validate_level(system, V, 0.97 * cw, time_limit=300, cover_estimate=ray_box)
    assert below.status.value == "certified", below.message
    assert sum(decided) > 0  # the relaxation decided boxes the interval forms left
    above = validate.validate_level(system, V, 1.001 * cw, time_limit=300, cover_estimate=ray_box)
    assert above.status.value != "certified", above.message


def test_an_identity_step_of_from_ops_is_no_activation_in_every_namespace():
    """``Activation("identity")`` passed to :meth:`MLP.from_ops` was kept as a step that the
    numpy and interval namespaces do not have (AttributeError); it is now dropped."""
    from roa.model._backend import namespace
    from roa.nn import Activation
    from roa.proof._interval import INTERVAL, Interval

    W, b = np.array([[2.0, -1.0]]), np.array([0.5])
    net = MLP.from_ops([Affine(W, b), Activation("identity")])
    assert len(net.ops) == 1
    assert float(net([1.0, 3.0], namespace("numpy"))[0]) == 2.0 - 3.0 + 0.5
    iv = net([Interval(1.0), Interval(3.0)], INTERVAL)[0]
    assert float(iv.lo) <= -0.5 <= float(iv.hi)


def test_a_complex_constant_is_refused_by_intervals_and_relaxations():
    """``Interval * (1 + 2j)`` gave ``Interval`` (the imaginary part dropped with a numpy warning,
    the real part taken as the constant): a wrong enclosure of a complex value. A complex
    constant with an imaginary part is now refused; one with zero imaginary part is its real
    part."""
    from roa.errors import RoaInputError
    from roa.proof._interval import Interval

    x = Interval(np.array([1.0]), np.array([2.0]))
    with pytest.raises(RoaInputError, match="complex constant"):
        _ = x * (1 + 2j)
    with pytest.raises(RoaInputError, match="complex constant"):
        _ = x + np.complex128(3j)
    X, _ = variables(np.array([[1.0]]), np.array([[2.0]]))
    with pytest.raises(RoaInputError, match="complex constant"):
        _ = X[0] * (-2.0) ** 0.5  # Python: a complex number
    y = x * complex(3.0, 0.0)
    assert float(y.lo[0]) <= 3.0 and 6.0 <= float(y.hi[0]) < 6.0 + 1e-14


def _mp_net(net: MLP, x: list[float]) -> list:
    """The network at 100 digits (smooth activations), affine maps summed exactly (fsum)."""
    acts = {
        "tanh": mp.tanh,
        "sigmoid": lambda z: 1 / (1 + mp.exp(-z)),
        "softplus": lambda z: mp.log1p(mp.exp(z)),
    }
    h = [mp.mpf(float(v)) for v in x]
    for op in net.ops:
        if isinstance(op, Affine):
            h = [mp.fsum([mp.mpf(float(w)) * v for w, v in zip(row, h, strict=True)]
                         + [mp.mpf(float(b))]) for row, b in zip(op.W, op.b, strict=True)]  # fmt: skip
        else:
            h = [acts[op.name](v) for v in h]
    return h


@pytest.mark.parametrize("act", ["tanh", "sigmoid", "softplus"])
@pytest.mark.parametrize("scale", [1e-300, 1e-8, 1.0, 1e3, 1e150])
def test_crown_with_smooth_activations_at_extreme_scales_encloses_100_digit_values(act, scale):
    """Three-layer networks with weights of size ``scale`` (units saturated, or all in the
    linear part), boxes of radius 0 to 1e6: the affine bounds at the corners, centre and random
    points hold against the network at 100 digits."""
    rng = np.random.default_rng(int(abs(np.log10(scale))) + len(act))
    W0, b0 = rng.normal(size=(5, 2)) * scale, rng.normal(size=5)
    W1, b1 = rng.normal(size=(4, 5)) * scale, rng.normal(size=4) * scale
    W2, b2 = rng.normal(size=(2, 4)), rng.normal(size=2)
    net = MLP([(W0, b0), (W1, b1), (W2, b2)], [act, act, None])
    c = rng.normal(size=(5, 2))
    r = np.array([0.0, 1e-9, 0.1, 2.0, 1e6])[:, None] * rng.uniform(0.2, 1.0, (5, 2))
    lo, hi = c - r, c + r
    X, mid = variables(lo, hi)
    with np.errstate(all="ignore"):
        out = net(X, LINEAR)
    with mp.workdps(100):
        for k in range(5):
            for x in _corners_and_samples(rng, lo[k], hi[k], []):
                ref = _mp_net(net, list(x))
                d = [
                    Fraction(float(p)) - Fraction(float(q)) for p, q in zip(x, mid[k], strict=True)
                ]
                for j, q in enumerate(out):
                    lo_v = _exact_affine(q.lA[k], q.lc[k], d)
                    hi_v = _exact_affine(q.uA[k], q.uc[k], d)
                    lo_m = (
                        lo_v
                        if isinstance(lo_v, float)
                        else mp.mpf(lo_v.numerator) / lo_v.denominator
                    )
                    hi_m = (
                        hi_v
                        if isinstance(hi_v, float)
                        else mp.mpf(hi_v.numerator) / hi_v.denominator
                    )
                    assert lo_m <= ref[j] <= hi_m, (
                        k,
                        list(x),
                        j,
                        float(lo_m),
                        float(ref[j]),
                        float(hi_m),
                    )


@pytest.mark.parametrize("name", ["SYSTEM", "SYSTEM_RELU"])
def test_relaxation_bounds_on_the_quadrotor_networks_hold_at_samples_and_50_digits(name):
    """The planar quadrotor under its 6-16-16-2 controllers (CROWN through two hidden layers,
    McCormick products with sin/cos of the pitch): relaxation_bounds alone on 120 boxes across
    the level surface near the sampled optimum; every V' bound and every F < 0 claim checked
    against 400 samples per box and the extreme ones at 50 digits."""
    import sys
    from pathlib import Path

    from roa.lyapunov import QuadraticLyapunov
    from roa.model._backend import namespace
    from roa.model._linearisation import lyapunov_matrix
    from roa.proof._interval import Interval
    from roa.proof._relax_vdot import relaxation_bounds

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples" / "systems"))
    try:
        import quadrotor_nn
    finally:
        sys.path.pop(0)
    system = getattr(quadrotor_nn, name)
    P = lyapunov_matrix(system)
    V = QuadraticLyapunov(P, np.zeros(6))
    NP, MPX = namespace("numpy"), namespace("mpmath")

    def vdot(S: np.ndarray) -> np.ndarray:
        f = np.stack(system.field(0.0, [S[:, i] for i in range(6)], NP), 1)
        return 2.0 * np.einsum("mi,ij,mj->m", S, P, f)

    def vdot_50(x: np.ndarray):
        with mp.workdps(50):
            xm = [mp.mpf(float(v)) for v in x]
            f = system.field(0.0, xm, MPX)
            return 2 * mp.fsum(
                xm[i] * mp.mpf(float(P[i, j])) * f[j] for i in range(6) for j in range(6)
            )

    rng = np.random.default_rng(0)
    G = rng.normal(size=(200_000, 6))
    G *= np.sqrt(rng.uniform(0.01, 30, len(G)) / V.value(G))[:, None]
    pos = vdot(G) >= 0
    assert pos.any()
    level = 0.9 * float(V.value(G[pos]).min())
    m = 120
    u = rng.normal(size=(m, 6))
    c = u * np.sqrt(level * rng.uniform(0.6, 1.4, m) / V.value(u))[:, None]
    r = rng.choice([0.0, 0.005, 0.02, 0.1], (m, 1)) * rng.uniform(0.2, 1.0, (m, 6))
    lo, hi = c - r, c + r
    whole = Interval(np.full(m, -np.inf), np.full(m, np.inf))
    vd, F_hi = relaxation_bounds(system, V, lo, hi, level, whole, whole, np.full(m, 1e300))
    assert (F_hi < 0).sum() >= 2 and (vd.hi < 0).sum() >= 20  # the claims checked below
    for k in range(m):
        S = np.concatenate([rng.uniform(lo[k], hi[k], (400, 6)), [lo[k], hi[k]]])
        v = vdot(S)
        assert vdot_50(S[np.argmax(v)]) <= vd.hi[k], k
        assert vdot_50(S[np.argmin(v)]) >= vd.lo[k], k
        inside = V.value(S) <= level
        if F_hi[k] < 0 and inside.any():
            assert vdot_50(S[int(np.argmax(np.where(inside, v, -np.inf)))]) < 0, k
