"""Audit of the network jets (roa.proof._jet_net) at the sharpest place for rounding: point boxes
(``lo = hi``), where the enclosures of the value, gradient and Hessian are a few ulps wide, so
every bound is compared exactly (as an mpmath number) with the 50-digit forward-mode derivatives
of ``tests/proof/test_jet_net.py`` at random points of random affine input maps, and of one layer and
its activation ``act(W x + b)`` (no later step's outward rounding to hide a wrong one). On the
latter the same checker is shown to catch the affine layers computed without their
rounding-error bound (round-to-nearest matrix products) and the activations' enclosures replaced
by their float values at the midpoint.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest
from test_jet_net import ACTS, _kink_free, _mp_act, _mp_jet, _net

import roa.proof._jet_net as JN
from roa.nn import MLP, Activation, Affine
from roa.proof._interval import Interval
from roa.proof._jet import Jet


def _shallow(act, seed: int) -> MLP:
    """``act(W x + b)``: one layer and its activation, outputs unmixed, so a wrong rounding of
    either step is not hidden under the next steps' outward rounding."""
    rng = np.random.default_rng(seed)
    name, args = (act, ()) if isinstance(act, str) else (act[0], tuple(act[1:]))
    return MLP.from_ops([Affine(rng.standard_normal((6, 3)), rng.standard_normal(6) * 0.3),
                         Activation(name, args)])  # fmt: skip


def _mp_shallow(net: MLP, act, x: np.ndarray):
    """Value, gradient and Hessian of ``act(W x + b)`` at ``x`` (the inputs), 50 digits."""
    W, b = net.layers[0]
    v, g, h = [], [], []
    for r in range(W.shape[0]):
        w = [mp.mpf(float(a)) for a in W[r]]
        z = mp.fsum(wi * mp.mpf(float(xi)) for wi, xi in zip(w, x, strict=True)) + mp.mpf(b[r])
        f0, f1, f2 = _mp_act(act, z)
        v.append(f0)
        g.append([f1 * w[p] for p in range(3)])
        h.append([[f2 * w[p] * w[q] for q in range(3)] for p in range(3)])
    return v, g, h


def _bounds(e, b):
    if type(e) is float:
        return e, e
    iv = Interval.of(e)
    lo, hi = np.atleast_1d(iv.lo), np.atleast_1d(iv.hi)
    return float(lo[b if lo.size > 1 else 0]), float(hi[b if hi.size > 1 else 0])


def _misses(act, seed: int, centred: bool, shallow: bool = False, points: int = 24
            ) -> tuple[int, int]:  # fmt: skip
    """``(bounds missing the 50-digit value, points checked)`` on point boxes: the 3-5-4-2
    network of a random affine map of the box's variables, or (``shallow``) ``act(W x + b)`` of
    the variables themselves."""
    net = _shallow(act, seed) if shallow else _net(act, seed)
    rng = np.random.default_rng(seed + 10)
    n = 3
    M = np.eye(n) if shallow else rng.standard_normal((3, n))
    c0 = np.zeros(3) if shallow else rng.standard_normal(3) * 0.2
    y = rng.uniform(-0.8, 0.8, (points, n))
    Y = Jet.variables(y, y.copy(), order=2, centred=centred)
    X = Y if shallow else [sum((Y[j] * float(M[i, j]) for j in range(n)), float(c0[i]))
                           for i in range(3)]  # fmt: skip
    out = JN.network_jet(net, X)
    assert out is not None
    name = act if isinstance(act, str) else act[0]
    miss = checked = 0
    for b in range(points):
        if name in ("relu", "leaky_relu", "clip") and not (
            shallow or _kink_free(net, act, c0 + M @ y[b])
        ):
            continue
        checked += 1
        with mp.workdps(50):
            v, g, h = _mp_shallow(net, act, y[b]) if shallow else _mp_jet(net, act, M, c0, y[b])
            for o in range(len(out)):
                pairs = [(out[o].v, v[o])]
                pairs += [(out[o].g[p], g[o][p]) for p in range(n)]
                pairs += [(out[o].h[p][q], h[o][p][q]) for p in range(n) for q in range(p, n)]
                for e, exact in pairs:
                    lo, hi = _bounds(e, b)
                    miss += not (mp.mpf(lo) <= exact <= mp.mpf(hi))
    return miss, checked


@pytest.mark.parametrize("act", ACTS, ids=str)
@pytest.mark.parametrize("centred", [False, True])
@pytest.mark.parametrize("shallow", [False, True], ids=["deep", "shallow"])
def test_point_box_jets_hold_the_50_digit_derivatives(act, centred, shallow):
    total = 0
    for seed in range(3):
        miss, checked = _misses(act, seed, centred, shallow)
        assert miss == 0
        total += checked
    assert total >= 50


def _nearest_affine(W, b, lo, hi):
    """``W x + b`` on the boxes without the dot products' error bound (round-to-nearest)."""
    W = np.asarray(W, dtype=float)
    Wp, Wn = np.maximum(W, 0.0), np.minimum(W, 0.0)
    b = np.asarray(b, dtype=float)[:, None]
    return Interval(Wp @ lo + Wn @ hi + b, Wp @ hi + Wn @ lo + b)


def _midpoint_derivatives(name):
    """``(f, f', f'')`` of the activation as float values at the interval's midpoint."""
    import roa.proof._jet as J
    from roa.proof._interval import INTERVAL

    exact = {"tanh": (INTERVAL.tanh, J._dtanh, J._d2tanh),
             "sigmoid": (INTERVAL.sigmoid, J._dsigmoid, J._d2sigmoid),
             "softplus": (INTERVAL.softplus, INTERVAL.sigmoid, J._dsigmoid)}[name]  # fmt: skip

    def at_mid(f):
        def g(X):
            iv = Interval.of(f(X))
            m = 0.5 * iv.lo + 0.5 * iv.hi
            return Interval(m, m)

        return g

    return tuple(at_mid(f) for f in exact)


@pytest.mark.parametrize("act", ["tanh", "relu", ("leaky_relu", 0.1)], ids=str)
def test_the_audit_catches_affine_layers_without_their_error_bound(monkeypatch, act):
    monkeypatch.setattr(JN, "interval_affine", _nearest_affine)
    assert sum(_misses(act, s, False, shallow=True)[0] for s in range(3)) >= 10


@pytest.mark.parametrize("act", ["tanh", "sigmoid", "softplus"])
def test_the_audit_catches_activation_enclosures_rounded_to_nearest(monkeypatch, act):
    monkeypatch.setattr(JN, "_derivatives", _midpoint_derivatives)
    assert sum(_misses(act, s, False, shallow=True)[0] for s in range(3)) >= 10
