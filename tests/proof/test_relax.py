"""Linear relaxations and CROWN (roa.proof._relax): soundness against dense sampling and 50-digit
mpmath evaluations on random networks and boxes, tightness against plain intervals, outward
rounding where float products cancel, and the hook into the branch and bound (fewer boxes, the
same verdicts).

References are independent of the code under test: the network and the fields evaluated at
50 digits by mpmath (written out here), numpy on dense samples."""

from __future__ import annotations

import sys
from pathlib import Path

import mpmath as mp
import numpy as np
import pytest

from roa.model._backend import namespace
from roa.nn import MLP, Affine
from roa.proof._interval import INTERVAL, Interval
from roa.proof._relax import LINEAR, Lin, variables
from roa.search._rays import ray_box

NP = namespace("numpy")
ROOT = Path(__file__).resolve().parents[2]
KINDS = ["tanh", "relu", "sigmoid", "softplus", ("leaky_relu", 0.1)]


def _net(kind, seed: int, n_in: int = 3) -> MLP:
    rng = np.random.default_rng(seed)
    W0, b0 = rng.normal(size=(12, n_in)), rng.normal(size=12)
    W1, b1 = rng.normal(size=(10, 12)) * 0.4, rng.normal(size=10)
    W2, b2 = rng.normal(size=(2, 10)), rng.normal(size=2)
    last = ("clip", -0.5, 0.8) if seed % 2 else None
    return MLP([(W0, b0), (W1, b1), (W2, b2)], [kind, kind, last])


def _mp_act(name: str, args: tuple, z: mp.mpf) -> mp.mpf:
    if name == "tanh":
        return mp.tanh(z)
    if name == "sigmoid":
        return 1 / (1 + mp.exp(-z))
    if name == "softplus":
        return mp.log(1 + mp.exp(z))
    if name == "relu":
        return max(z, mp.mpf(0))
    if name == "leaky_relu":
        return max(z, mp.mpf(0)) + mp.mpf(args[0]) * min(z, mp.mpf(0))
    if name == "clip":
        return min(max(z, mp.mpf(args[0])), mp.mpf(args[1]))
    raise AssertionError(name)


def _mp_net(net: MLP, x: list) -> list:
    h = [mp.mpf(float(v)) for v in x]
    for op in net.ops:
        if isinstance(op, Affine):
            h = [mp.fsum(mp.mpf(float(w)) * v for w, v in zip(row, h, strict=True)) + mp.mpf(float(bi))
                 for row, bi in zip(op.W, op.b, strict=True)]  # fmt: skip
        else:
            h = [_mp_act(op.name, op.args, v) for v in h]
    return h


def _affine_at(q: Lin, k: int, d: list) -> tuple[mp.mpf, mp.mpf]:
    """The lower and upper affine bounds of box ``k`` at the offset ``d``, at 50 digits."""
    lo = mp.mpf(float(q.lc[k])) + mp.fsum(
        mp.mpf(float(a)) * v for a, v in zip(q.lA[k], d, strict=True)
    )
    hi = mp.mpf(float(q.uc[k])) + mp.fsum(mp.mpf(float(a)) * v for a, v in zip(q.uA[k], d, strict=True))  # fmt: skip
    return lo, hi


def _boxes(rng, m: int, n: int):
    c = rng.uniform(-2, 2, (m, n))
    r = rng.choice([1e-6, 0.01, 0.1, 0.5, 1.5], (m, 1)) * rng.uniform(0.5, 1.0, (m, n))
    return c - r, c + r


@pytest.mark.parametrize("kind", KINDS)
def test_crown_bounds_enclose_the_network_at_50_digits_and_on_dense_samples(kind):
    """For random 3-12-10-2 networks and boxes (radii 1e-6 to 1.5): the affine lower/upper
    functions and the concrete bounds hold at every corner and random point (50-digit network
    value, 50-digit affine functions), and on 4000 float samples per box."""
    rng = np.random.default_rng(5)
    with mp.workdps(50):
        for seed in range(2):
            net = _net(kind, seed)
            lo, hi = _boxes(rng, 12, 3)
            X, mid = variables(lo, hi)
            out = net(X, LINEAR)
            for k in range(12):
                pts = [lo[k] + (hi[k] - lo[k]) * np.array(b) for b in np.ndindex(2, 2, 2)]
                pts += list(rng.uniform(lo[k], hi[k], (6, 3)))
                for p in pts:
                    want = _mp_net(net, list(p))
                    d = [
                        mp.mpf(float(v)) - mp.mpf(float(c)) for v, c in zip(p, mid[k], strict=True)
                    ]
                    for o in range(2):
                        lo_f, hi_f = _affine_at(out[o], k, d)
                        a, b = out[o].bounds()
                        assert lo_f <= want[o] <= hi_f, (kind, seed, k, o)
                        assert mp.mpf(float(a[k])) <= want[o] <= mp.mpf(float(b[k]))
            S = rng.uniform(lo[:, None, :], hi[:, None, :], (12, 4000, 3))
            v = net([S[..., 0], S[..., 1], S[..., 2]], NP)
            for o in range(2):
                a, b = out[o].bounds()
                assert np.all(a[:, None] <= v[o]) and np.all(v[o] <= b[:, None])


def test_crown_is_tighter_than_interval_propagation():
    """The median width of the interval enclosure over the CROWN enclosure of the outputs (random
    networks, boxes of radius 0.1 to 1): measured 1.25 (tanh, saturating on these wide boxes) to 3.1 (leaky ReLU); asserted >= 1.15.
    And CROWN is never wider than the interval product (it is intersected with it)."""
    rng = np.random.default_rng(9)
    for kind in KINDS:
        net = _net(kind, 4)
        c = rng.uniform(-2, 2, (200, 3))
        r = rng.uniform(0.1, 1.0, (200, 1))
        lo, hi = c - r, c + r
        X, _ = variables(lo, hi)
        out = net(X, LINEAR)
        ivs = net([Interval(lo[:, i], hi[:, i]) for i in range(3)], INTERVAL)
        for o in range(2):
            a, b = out[o].bounds()
            assert np.all(b - a <= ivs[o].hi - ivs[o].lo)
            ratio = float(np.median((ivs[o].hi - ivs[o].lo) / (b - a)))
            assert ratio >= 1.15, (kind, o, ratio)


@pytest.mark.parametrize("name", ["sin", "cos", "tanh", "sigmoid", "softplus", "exp", "arctan",
                                  "relu", "abs", "sqrt", "log"])  # fmt: skip
def test_elementwise_relaxations_enclose_50_digit_values(name):
    """``f(a x0 + b x1 + c)`` in the namespace: the affine bounds hold at 50 digits."""
    rng = np.random.default_rng(2)
    fns = {"sin": mp.sin, "cos": mp.cos, "tanh": mp.tanh, "exp": mp.exp, "arctan": mp.atan,
           "sigmoid": lambda z: 1 / (1 + mp.exp(-z)), "softplus": lambda z: mp.log(1 + mp.exp(z)),
           "relu": lambda z: max(z, 0), "abs": abs, "sqrt": mp.sqrt, "log": mp.log}  # fmt: skip
    positive = name in ("sqrt", "log")
    lo, hi = _boxes(rng, 30, 2)
    if positive:
        lo, hi = np.abs(lo) + 0.1, np.abs(lo) + 0.1 + (hi - lo)
    X, mid = variables(lo, hi)
    c1 = 0.25 if positive else -0.25  # sqrt and log: a positive argument
    q = getattr(LINEAR, name)(X[0] * 1.5 + X[1] * c1 + (0.0 if positive else 0.3))
    with mp.workdps(50):
        for k in range(30):
            for p in list(rng.uniform(lo[k], hi[k], (8, 2))) + [lo[k], hi[k]]:
                z = mp.mpf(float(p[0])) * mp.mpf(1.5) + mp.mpf(float(p[1])) * mp.mpf(c1)
                want = fns[name](z + (0 if positive else mp.mpf(0.3)))
                d = [mp.mpf(float(v)) - mp.mpf(float(c)) for v, c in zip(p, mid[k], strict=True)]
                a, b = _affine_at(q, k, d)
                assert a <= want <= b, (name, k)


def test_products_and_a_closed_loop_derivative_are_enclosed():
    """V' of the pendulum under its ReLU and tanh networks (McCormick products of grad V and the
    field, CROWN through the network) holds the float V' on dense samples of random boxes."""
    sys.path.insert(0, str(ROOT / "examples" / "systems"))
    try:
        import pendulum_nn
    finally:
        sys.path.pop(0)
    import roa

    rng = np.random.default_rng(4)
    for system in (pendulum_nn.SYSTEM, pendulum_nn.SYSTEM_RELU):
        V = roa.default_lyapunov(system)
        lo, hi = _boxes(rng, 40, 2)
        X, _ = variables(lo, hi)
        q = V.vdot_expr(system, X, LINEAR)
        a, b = q.bounds()
        S = rng.uniform(lo[:, None, :], hi[:, None, :], (40, 3000, 2))
        vd = V.derivative(system, S)
        slack = 1e-12 * (1 + np.abs(vd))  # the float V' itself is off by a few ulps
        assert np.all(a[:, None] <= vd + slack) and np.all(vd - slack <= b[:, None])


def test_outward_rounding_survives_cancellation_that_floats_get_wrong():
    """``relu(1e16 x + 1 - 1e16)`` at ``x = 1``: the float products give 0 or 2, the exact value
    is 1; the CROWN bounds on the point box enclose 1, and so do those of a network whose hidden
    layer cancels (W = [1e16, 1, -1e16] on inputs (1, 1, 1))."""
    net = MLP([(np.array([[1e16, 1.0, -1e16]]), np.zeros(1)), (np.array([[1.0]]), np.zeros(1))],
              ["relu", None])  # fmt: skip
    x = np.ones((1, 3))
    assert float(np.array([1e16, 1.0, -1e16]) @ x[0]) != 1.0
    X, _ = variables(x, x)
    a, b = net(X, LINEAR)[0].bounds()
    # the a priori error bound of the products: 2 gamma_7 (2e16 + 1) ~ 31 (interval_affine)
    assert a[0] <= 1.0 <= b[0] and b[0] - a[0] <= 64.0
    wide = x + np.array([[0.0, 1e-3, 0.0]])  # a box: still an enclosure of the exact range
    X, _ = variables(x, wide)
    a, b = net(X, LINEAR)[0].bounds()
    assert a[0] <= 1.0 and 1.001 <= b[0]


@pytest.mark.slow
def test_the_hook_decides_boxes_the_interval_forms_leave_and_keeps_the_verdicts():
    """The pendulum's ReLU loop at 0.999 of its optimum (18.96209): certified with and without
    the relaxation bounds; with them the branch and bound evaluates fewer boxes (measured 403
    against 851). Just above the optimum both refute."""
    sys.path.insert(0, str(ROOT / "examples" / "systems"))
    try:
        import pendulum_nn
    finally:
        sys.path.pop(0)
    import roa
    import roa.proof._relax_vdot as rv
    from roa.proof._validate import validate_level

    system = pendulum_nn.SYSTEM_RELU
    V = roa.default_lyapunov(system)
    runs = {}
    try:
        for enabled in (False, True):
            rv.ENABLED = enabled
            runs[enabled] = validate_level(system, V, 0.999 * 18.96209, cover_estimate=ray_box)
            above = validate_level(system, V, 1.01 * 18.96209, cover_estimate=ray_box)
            assert above.status.value == "refuted", (enabled, above.message)
    finally:
        rv.ENABLED = True
    assert all(r.status.value == "certified" for r in runs.values())
    assert runs[True].boxes < 0.8 * runs[False].boxes, (runs[True].boxes, runs[False].boxes)


@pytest.mark.slow
def test_quadrotor_networks_have_a_local_proof_down_to_the_equilibrium():
    """No hole at the origin: for both quadrotor controllers the Hessian proof of V' < 0 holds on
    a box around hover (f(x_eq) = 0 and grad V(x_eq) = 0 exactly, the interval Hessian of V'
    negative definite in exact rationals). For the ReLU network every hidden unit's phase is
    decided on that box (interval products layer by layer, computed here): the network is affine
    there, which is why its jets have finite Hessians."""
    sys.path.insert(0, str(ROOT / "examples" / "systems"))
    try:
        import quadrotor_nn
    finally:
        sys.path.pop(0)
    import roa
    from roa.proof._interval import interval_affine
    from roa.proof._local import local_box

    for system, kind in ((quadrotor_nn.SYSTEM, "tanh"), (quadrotor_nn.SYSTEM_RELU, "relu")):
        V = roa.default_lyapunov(system)
        half = np.sqrt(0.07 * np.diag(np.linalg.inv(V.P)))  # the box of {V <= 0.07}
        found = local_box(system, V, -half, half)
        assert found is not None and found[2]["local_proof"] == "hessian", kind
        lo, hi, _ = found
        assert np.all(lo < 0) and np.all(hi > 0)
        if kind == "relu":
            net = MLP.load(ROOT / "examples" / "systems" / "quadrotor_nn_relu.npz")
            h = Interval(lo[:, None], hi[:, None])
            for (W, b), last in zip(net.layers, (False, False, True), strict=True):
                z = interval_affine(W, b, h.lo, h.hi)
                if last:
                    break
                assert np.all((z.lo > 0) | (z.hi < 0))  # every phase decided
                h = INTERVAL.relu(z)
