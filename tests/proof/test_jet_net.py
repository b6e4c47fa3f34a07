"""Interval jets through networks as arrays (roa.proof._jet_net): enclosures of the value,
gradient and Hessian against 50-digit forward-mode derivatives at sample points, the exact-zero
structure, and agreement with the neuron-by-neuron jets."""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

from roa.nn import MLP
from roa.proof._interval import Interval
from roa.proof._jet import Jet, nonsmooth
from roa.proof._jet_net import JET, network_jet

ACTS = ["tanh", "sigmoid", "softplus", "relu", ("leaky_relu", 0.1), ("clip", -0.4, 0.7)]


def _net(act, seed: int, n_in: int = 3) -> MLP:
    rng = np.random.default_rng(seed)
    sizes = [n_in, 5, 4, 2]
    layers = [(rng.standard_normal((b, a)), rng.standard_normal(b) * 0.3)
              for a, b in zip(sizes[:-1], sizes[1:], strict=True)]  # fmt: skip
    return MLP(layers, [act, act])


def _mp_act(act, z):
    """(f, f', f'') at z in mpmath (piecewise: the piece of z, which is off every kink)."""
    name, args = (act, ()) if isinstance(act, str) else (act[0], act[1:])
    if name == "tanh":
        t = mp.tanh(z)
        return t, 1 - t * t, -2 * t * (1 - t * t)
    if name == "sigmoid":
        s = 1 / (1 + mp.exp(-z))
        return s, s * (1 - s), s * (1 - s) * (1 - 2 * s)
    if name == "softplus":
        s = 1 / (1 + mp.exp(-z))
        return mp.log(1 + mp.exp(z)), s, s * (1 - s)
    if name == "relu":
        return (z, 1, 0) if z > 0 else (mp.mpf(0), 0, 0)
    if name == "leaky_relu":
        a = mp.mpf(args[0])
        return (z, 1, 0) if z > 0 else (a * z, a, 0)
    lo, hi = mp.mpf(args[0]), mp.mpf(args[1])
    return (lo, 0, 0) if z < lo else ((hi, 0, 0) if z > hi else (z, 1, 0))


def _mp_jet(net: MLP, act, M: np.ndarray, c0: np.ndarray, y: np.ndarray):
    """Value, gradient and Hessian in y of net(c0 + M y), forward mode at 50 digits."""
    n = len(y)
    x = [c0[i] + mp.fsum(mp.mpf(M[i, j]) * mp.mpf(y[j]) for j in range(n)) for i in range(len(c0))]
    v = x
    g = [[mp.mpf(M[i, j]) for j in range(n)] for i in range(len(c0))]
    h = [[[mp.mpf(0)] * n for _ in range(n)] for _ in range(len(c0))]
    layers = net.layers
    for li, (W, b) in enumerate(layers):
        v2, g2, h2 = [], [], []
        for r in range(W.shape[0]):
            w = [mp.mpf(float(a)) for a in W[r]]
            z = mp.fsum(wi * vi for wi, vi in zip(w, v, strict=True)) + mp.mpf(float(b[r]))
            gz = [mp.fsum(w[k] * g[k][p] for k in range(len(v))) for p in range(n)]
            hz = [[mp.fsum(w[k] * h[k][p][q] for k in range(len(v))) for q in range(n)]
                  for p in range(n)]  # fmt: skip
            if li < len(layers) - 1:
                f0, f1, f2 = _mp_act(act, z)
                z = f0
                hz = [[f2 * gz[p] * gz[q] + f1 * hz[p][q] for q in range(n)] for p in range(n)]
                gz = [f1 * e for e in gz]
            v2.append(z)
            g2.append(gz)
            h2.append(hz)
        v, g, h = v2, g2, h2
    return v, g, h


def _kink_free(net: MLP, act, x: np.ndarray) -> bool:
    """Whether no hidden unit of the piecewise-linear net is within 1e-6 of a kink at x."""
    name, args = (act, ()) if isinstance(act, str) else (act[0], act[1:])
    kinks = list(args) if name == "clip" else [0.0]
    h = x
    for W, b in net.layers[:-1]:
        z = W @ h + b
        if any(np.min(np.abs(z - k)) < 1e-6 for k in kinks):
            return False
        if name == "clip":
            h = np.clip(z, *args)
        else:
            h = np.where(z > 0, z, (args[0] if args else 0.0) * z)
    return True


def _contains(e, val, tol: float = 0.0) -> bool:
    if type(e) is float:
        return abs(float(val) - e) <= tol
    iv = Interval.of(e)
    return bool(iv.lo - tol <= float(val) <= iv.hi + tol)


@pytest.mark.parametrize("act", ACTS, ids=str)
@pytest.mark.parametrize("centred", [False, True])
def test_network_jet_encloses_50_digit_derivatives(act, centred):
    net = _net(act, 1)
    rng = np.random.default_rng(2)
    n = 3
    M = rng.standard_normal((3, n))
    c0 = rng.standard_normal(3) * 0.2
    mid = rng.uniform(-0.6, 0.6, (40, n))
    rad = rng.uniform(0.0, 0.15, (40, n))
    rad[1::2] *= 1e-5  # tiny boxes: tight enclosures, so a wrong term shows
    lo, hi = mid - rad, mid + rad
    Y = Jet.variables(lo, hi, order=2, centred=centred)
    X = [sum((Y[j] * float(M[i, j]) for j in range(n)), float(c0[i])) for i in range(3)]
    out = network_jet(net, X)
    assert out is not None and len(out) == 2
    checked = 0
    for b in range(0, 40, 3):
        for _ in range(6):
            y = rng.uniform(lo[b], hi[b])
            x = c0 + M @ y  # float: only used to skip points next to a kink
            name = act if isinstance(act, str) else act[0]
            if name in ("relu", "leaky_relu", "clip") and not _kink_free(net, act, x):
                continue
            with mp.workdps(50):
                v, g, h = _mp_jet(net, act, M, c0, y)
            for o in range(2):
                assert _contains(_row(out[o].v, b), v[o])
                for p in range(n):
                    assert _contains(_row(out[o].g[p], b), g[o][p])
                    for q in range(p, n):
                        assert _contains(_row(out[o].h[p][q], b), h[o][p][q])
            checked += 1
    assert checked >= 30


def _row(e, b):
    if type(e) is float:
        return e
    iv = Interval.of(e)
    if iv.lo.ndim == 0:
        return iv
    return Interval(iv.lo[b], iv.hi[b])


@pytest.mark.parametrize("act", ["tanh", "relu"])
def test_network_jet_agrees_with_neuron_by_neuron_jets(act):
    """Without centring both evaluate the same interval operations up to summation order: the
    enclosures agree to a few ulps relative to their size."""
    net = _net(act, 3)
    rng = np.random.default_rng(4)
    mid = rng.uniform(-0.5, 0.5, (25, 3))
    X = Jet.variables(mid - 0.05, mid + 0.05, order=2)
    a, b = net._elementwise(X, JET), network_jet(net, X)
    assert b is not None
    for ja, jb in zip(a, b, strict=True):
        pairs = [(ja.v, jb.v)] + list(zip(ja.g, jb.g, strict=True))
        pairs += [(ja.h[p][q], jb.h[p][q]) for p in range(3) for q in range(p, 3)]
        for ea, eb in pairs:
            A, B = Interval.of(ea), Interval.of(eb)
            scale = np.maximum(1.0, np.abs(A.lo) + np.abs(A.hi))
            fin = np.isfinite(A.lo) & np.isfinite(B.lo)
            with np.errstate(invalid="ignore"):
                diff = np.abs(A.lo - B.lo)
            assert np.all(diff[fin] <= 1e-12 * np.broadcast_to(scale, fin.shape)[fin])
            assert np.all(np.isinf(A.lo) == np.isinf(B.lo))


def test_exact_zero_structure_and_kink_detection():
    """An input the network ignores keeps symbolic zero derivatives; a ReLU net is seen as
    kinked by nonsmooth (so the branch and bound centres its jets)."""
    rng = np.random.default_rng(5)
    W1 = rng.standard_normal((4, 3))
    W1[:, 2] = 0.0
    net = MLP([(W1, np.zeros(4)), (rng.standard_normal((1, 4)), np.zeros(1))], "relu")
    X = Jet.variables(np.full((5, 3), -0.1), np.full((5, 3), 0.2), order=2)
    out = network_jet(net, X)
    assert out is not None
    assert out[0].g[2] == 0.0 and out[0].h[2][2] == 0.0 and out[0].h[0][2] == 0.0
    assert type(out[0].g[0]) is not float
    assert nonsmooth(lambda: net(X, JET))
    assert not nonsmooth(lambda: _net("tanh", 1)(X, JET))


def _holds(lo: float, hi: float, exact) -> bool:
    """``lo <= exact <= hi`` with infinite ends (``exact`` a Fraction)."""
    from fractions import Fraction

    return (lo == -np.inf or Fraction(float(lo)) <= exact) and (
        hi == np.inf or exact <= Fraction(float(hi))
    )


def test_two_product_multiplication_and_squares_enclose_exact_products():
    """The products of the smooth layers (``_times_nonneg``: a factor ``>= 0``; ``_pair_products``:
    squares on the diagonal) enclose every exact product of points of the factors (Fractions),
    with infinite ends and exact zeros among the factors, and are never wider than the general
    interval product."""
    from fractions import Fraction

    from roa.proof._jet_net import _pair_products, _times_nonneg

    rng = np.random.default_rng(11)
    shape = (4, 50, 3)
    a_lo = np.abs(rng.standard_normal(shape)) * rng.choice([0.0, 1.0], shape)
    a = Interval(a_lo, a_lo + np.abs(rng.standard_normal(shape)) * rng.choice([0.0, 1.0], shape))
    x_lo = rng.standard_normal(shape) * 3
    x_hi = x_lo + np.abs(rng.standard_normal(shape)) * rng.choice([0.0, 1.0], shape)
    x_lo[0, :5], x_hi[1, :5] = -np.inf, np.inf
    X = Interval(x_lo, x_hi)
    fast, general = _times_nonneg(a, X), a * X
    assert np.all(fast.lo >= general.lo) and np.all(fast.hi <= general.hi)
    P = _pair_products(X, *np.triu_indices(3))
    iu, ju = np.triu_indices(3)
    for _ in range(20):
        ta, tx, ty = rng.uniform(size=(3, *shape))
        pa = np.where(a.hi > a.lo, a.lo + ta * (a.hi - a.lo), a.lo)
        px = np.clip(np.where(np.isfinite(x_lo), x_lo, x_hi - 5) + tx * 5, x_lo, x_hi)
        for idx in map(tuple, rng.integers(0, [4, 50, 3], (40, 3))):
            exact = Fraction(float(pa[idx])) * Fraction(float(px[idx]))
            assert _holds(fast.lo[idx], fast.hi[idx], exact)
        py = np.clip(np.where(np.isfinite(x_lo), x_lo, x_hi - 5) + ty * 5, x_lo, x_hi)
        for k, (p, q) in enumerate(zip(iu, ju, strict=True)):
            other = px if p == q else py  # a square is g_p g_p: the same point twice
            i, j = rng.integers(0, 4), rng.integers(0, 50)
            exact = Fraction(float(px[i, j, p])) * Fraction(float(other[i, j, q]))
            if p != q and not (x_lo[i, j, q] <= py[i, j, q] <= x_hi[i, j, q]):
                continue
            assert _holds(P.lo[i, j, k], P.hi[i, j, k], exact)
    assert np.all(P.lo[..., iu == ju] >= 0)


def test_interval_affine_encloses_exact_affine_maps():
    """``W x + b`` at points of the boxes, in exact rationals, lies in the enclosure."""
    from fractions import Fraction

    from roa.proof._interval import interval_affine

    rng = np.random.default_rng(12)
    W, b = rng.standard_normal((5, 7)) * 10.0 ** rng.integers(-3, 3, (5, 7)), rng.standard_normal(5)
    lo = rng.standard_normal((7, 30))
    hi = lo + np.abs(rng.standard_normal((7, 30)))
    out = interval_affine(W, b, lo, hi)
    for _ in range(10):
        x = lo + rng.uniform(size=lo.shape) * (hi - lo)
        for j in range(30):
            for i in range(5):
                exact = sum(Fraction(float(W[i, k])) * Fraction(float(x[k, j])) for k in range(7))
                exact += Fraction(float(b[i]))
                assert Fraction(float(out.lo[i, j])) <= exact <= Fraction(float(out.hi[i, j]))
