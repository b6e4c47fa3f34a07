"""Neural networks in fields: activations in every namespace, their interval and jet enclosures,
the interval matrix-vector product, :class:`roa.nn.MLP` (arrays, ONNX), and the pendulum under
tanh and ReLU network controllers certified down to the equilibrium.

References are independent: 50-digit mpmath values of the activations and their derivatives,
exact rational (Fraction) ranges of affine maps, onnx's own reference evaluator, and the optimum
of V over ``{V' >= 0}`` by multistart SLSQP (scipy) for the certified levels."""

from __future__ import annotations

import pickle
import sys
from fractions import Fraction
from pathlib import Path

import mpmath as mp
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from roa.errors import RoaInputError
from roa.model._backend import ACTIVATIONS, namespace
from roa.nn import MLP, Activation
from roa.proof._interval import INTERVAL, Interval, interval_affine
from roa.proof._jet import Jet
from roa.proof._jet_net import JET

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "systems" / "pendulum_nn.py"
ALPHA = 0.01


def _exact(name: str, x: mp.mpf, alpha: float = ALPHA) -> mp.mpf:
    """50-digit activation values (the definitions of roa.model._backend)."""
    if name == "tanh":
        return mp.tanh(x)
    if name == "sigmoid":
        return 1 / (1 + mp.exp(-x))
    if name == "softplus":
        return mp.log(1 + mp.exp(x))
    if name == "relu":
        return max(x, mp.mpf(0))
    return max(x, mp.mpf(0)) + mp.mpf(alpha) * min(x, mp.mpf(0))


POINTS = [-800.0, -40.0, -3.0, -0.5, -1e-300, 0.0, 1e-8, 0.3, 2.0, 19.5, 40.0, 700.0]


# -- the namespaces --------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["numpy", "casadi", "sympy", "mpmath"])
def test_activations_in_every_namespace_agree_with_50_digit_values(name):
    import casadi as ca

    ns = namespace(name)
    for f in ACTIVATIONS:
        assert (
            callable(getattr(ns, f))
            and callable(getattr(INTERVAL, f))
            and callable(getattr(JET, f))
        )
        for x in POINTS:
            if name == "sympy" and f in ("sigmoid", "softplus") and abs(x) > 100:
                continue  # sympy Floats overflow as doubles would; numpy/CasADi use stable forms
            got = getattr(ns, f)(x)
            got = float(ca.DM(got)) if name == "casadi" else float(got)
            with mp.workdps(50):
                want = _exact(f, mp.mpf(x))
                # 1e-15 absolute: log(1 + exp(-40)) in doubles (sympy's formula) is 0, not 4e-18
                assert abs(mp.mpf(got) - want) <= 1e-14 * abs(want) + 1e-15, (name, f, x, got)


def test_leaky_relu_slope_is_an_argument_everywhere():
    import casadi as ca

    for name in ("numpy", "casadi", "sympy", "mpmath"):
        ns = namespace(name)
        for alpha in (0.01, 0.25):
            got = ns.leaky_relu(-2.0, alpha)
            got = float(ca.DM(got)) if name == "casadi" else float(got)
            assert got == -2.0 * alpha, (name, alpha)
    enc = INTERVAL.leaky_relu(Interval(-2.0, -1.0), 0.25)  # alpha x rounded outward
    assert -0.5 - 1e-15 <= float(enc.lo) <= -0.5 and -0.25 <= float(enc.hi) <= -0.25 + 1e-15


# -- interval enclosures ---------------------------------------------------------------------------
finite = st.floats(-60.0, 60.0, allow_nan=False, allow_infinity=False)


def _inside(lo: float, hi: float, k: int = 7) -> list[mp.mpf]:
    """``k`` points of ``[lo, hi]`` (its ends exactly), as 60-digit numbers."""
    a, b = Fraction(lo), Fraction(hi)
    with mp.workdps(60):
        return [mp.mpf(q.numerator) / q.denominator for q in
                (a + (b - a) * Fraction(i, k - 1) for i in range(k))]  # fmt: skip


def _check_enclosure(f: str, lo: float, hi: float) -> None:
    enc = getattr(INTERVAL, f)(Interval(lo, hi))
    with mp.workdps(50):
        for p in _inside(lo, hi):
            v = _exact(f, p)
            assert mp.mpf(float(enc.lo)) <= v <= mp.mpf(float(enc.hi)), (f, lo, hi, p, enc)


@settings(max_examples=200, deadline=None)
@given(finite, finite)
def test_interval_activations_enclose_50_digit_values(a, b):
    lo, hi = min(a, b), max(a, b)
    for f in ACTIVATIONS:
        _check_enclosure(f, lo, hi)


def test_interval_activations_at_extreme_and_point_arguments():
    for f in ACTIVATIONS:
        for x in POINTS + [-1e300, 1e300, 5e-324, -5e-324]:
            _check_enclosure(f, x, x)
        _check_enclosure(f, -np.finfo(float).max, np.finfo(float).max)
    # tight: point intervals within 64 ulps (measured 5 to 41: LIBM_ULPS + 1 on each side of each
    # libm call and of each rounded operation, round_down / round_up)
    for f in ("tanh", "sigmoid", "softplus"):
        for x in (-3.0, -0.5, 0.3, 2.0):
            e = getattr(INTERVAL, f)(Interval(x))
            assert 0 < float(e.hi - e.lo) <= 64 * np.spacing(abs(float(e.hi))), (f, x)
    # relu exact; leaky_relu exact on the positive side
    r = INTERVAL.relu(Interval(np.array([-2.0, -1.0, 0.5]), np.array([-1.0, 3.0, 0.75])))
    assert r.lo.tolist() == [0.0, 0.0, 0.5] and r.hi.tolist() == [0.0, 3.0, 0.75]
    r = INTERVAL.leaky_relu(Interval(0.5, 0.75))
    assert float(r.lo) == 0.5 and float(r.hi) == 0.75
    # saturations: tanh in [-1, 1], sigmoid in [0, 1], softplus >= max(x, 0)
    assert float(INTERVAL.tanh(Interval(30.0, 1e300)).hi) == 1.0
    assert float(INTERVAL.sigmoid(Interval(-1e300, -800.0)).lo) == 0.0
    assert float(INTERVAL.softplus(Interval(700.0, 800.0)).lo) >= 700.0


# -- jets ----------------------------------------------------------------------------------------
def _derivatives(f: str, z: mp.mpf) -> tuple[mp.mpf, mp.mpf, mp.mpf]:
    """Value, first and second derivative at 50 digits (closed forms)."""
    if f == "tanh":
        t = mp.tanh(z)
        return t, 1 - t * t, -2 * t * (1 - t * t)
    s = 1 / (1 + mp.exp(-z))
    if f == "sigmoid":
        return s, s * (1 - s), s * (1 - s) * (1 - 2 * s)
    return mp.log(1 + mp.exp(z)), s, s * (1 - s)


@settings(max_examples=60, deadline=None)
@given(finite, finite, st.floats(0.0, 2.0), st.floats(0.0, 2.0))
def test_smooth_activation_jets_enclose_value_gradient_hessian(a, b, ra, rb):
    """z = 2 x0 - x1 + 0.3 on a box; act(z)'s jet holds act, (2, -1) act', (4, -2, 1) act''."""
    lo, hi = np.array([[a / 10, b / 10]]), np.array([[a / 10 + ra, b / 10 + rb]])
    x = Jet.variables(lo, hi, order=2)
    for f in ("tanh", "sigmoid", "softplus"):
        j = getattr(JET, f)(x[0] * 2.0 - x[1] + 0.3)
        h = j.h
        assert h is not None
        for p0 in _inside(lo[0, 0], hi[0, 0], 4):
            for p1 in _inside(lo[0, 1], hi[0, 1], 4):
                with mp.workdps(50):
                    v, d1, d2 = _derivatives(f, 2 * p0 - p1 + mp.mpf(0.3))
                    pairs = [(j.v, v), (j.g[0], 2 * d1), (j.g[1], -d1), (h[0][0], 4 * d2),
                             (h[0][1], -2 * d2), (h[1][1], d2)]  # fmt: skip
                    for enc, want in pairs:
                        e = Interval.of(enc)
                        assert mp.mpf(float(e.lo.item())) <= want <= mp.mpf(float(e.hi.item())), (
                            f,
                            want,
                        )


def _lo(e) -> float:
    return float(np.ravel(Interval.of(e).lo)[0])


def _hi(e) -> float:
    return float(np.ravel(Interval.of(e).hi)[0])


def test_relu_jets_take_a_branch_where_decided_and_the_generalised_gradient_at_the_kink():
    lo = np.array([[0.5, -1.0], [-3.0, -1.0], [-1.0, -1.0]])
    hi = np.array([[1.0, 1.0], [-2.0, 1.0], [1.0, 1.0]])
    for f, slope in (("relu", 0.0), ("leaky_relu", ALPHA)):
        for k in range(3):
            x = Jet.variables(lo[k : k + 1], hi[k : k + 1], order=2)
            z = x[0] * 2.0 + x[1] * 0.25  # > 0 on box 0, < 0 on box 1, across 0 on box 2
            j = getattr(JET, f)(z)
            h = j.h
            assert h is not None
            if k == 0:  # the identity branch: z's jet, Hessian exactly 0
                assert [_lo(e) for e in j.g] == [_hi(e) for e in j.g] == [2.0, 0.25]
                assert all(_lo(e) == _hi(e) == 0.0 for row in h for e in row)
            elif k == 1:  # the slope branch (alpha x rounded outward)
                for e, want in zip(j.g, (2.0 * slope, 0.25 * slope), strict=True):
                    assert _lo(e) <= want <= _hi(e) and _hi(e) - _lo(e) <= 1e-15
                assert all(_lo(e) == _hi(e) == 0.0 for row in h for e in row)
            else:  # across the kink: the hull of both gradients, Hessian unbounded
                assert _lo(j.g[0]) <= 2.0 * slope and _hi(j.g[0]) >= 2.0
                assert _lo(j.g[1]) <= 0.25 * slope and _hi(j.g[1]) >= 0.25
                assert _hi(j.g[0]) <= 2.0 + 1e-15 and _lo(j.g[0]) >= -1e-15
                assert np.isinf(_hi(h[0][0]))


# -- the interval matrix-vector product --------------------------------------------------------------
def _exact_range(W, b, lo, hi):
    """The exact range of W x + b over [lo, hi] (Fractions; attained at corners)."""
    out = []
    for i in range(W.shape[0]):
        a = c = Fraction(float(b[i]))
        for j in range(W.shape[1]):
            p, q = (
                Fraction(float(W[i, j])) * Fraction(float(lo[j])),
                Fraction(float(W[i, j])) * Fraction(float(hi[j])),
            )
            a += min(p, q)
            c += max(p, q)
        out.append((a, c))
    return out


@settings(max_examples=80, deadline=None)
@given(st.integers(1, 6), st.integers(1, 7), st.integers(0, 2**32 - 1))
def test_interval_affine_encloses_the_exact_range_tightly(rows, cols, seed):
    rng = np.random.default_rng(seed)
    W = rng.normal(size=(rows, cols)) * 10.0 ** rng.integers(-8, 9, (rows, cols))
    b = rng.normal(size=rows) * 10.0 ** rng.integers(-3, 4, rows)
    lo = rng.normal(size=(cols, 3)) * 10.0 ** rng.integers(-5, 6, (cols, 3))
    hi = lo + np.abs(rng.normal(size=(cols, 3))) * rng.choice([0.0, 1e-9, 1.0], (cols, 3))
    enc = interval_affine(W, b, lo, hi)
    for m in range(3):
        for i, (a, c) in enumerate(_exact_range(W, b, lo[:, m], hi[:, m])):
            elo, ehi = Fraction(float(enc.lo[i, m])), Fraction(float(enc.hi[i, m]))
            assert elo <= a and c <= ehi
            mag = sum(abs(Fraction(float(W[i, j]))) * max(abs(Fraction(float(lo[j, m]))),
                      abs(Fraction(float(hi[j, m])))) for j in range(cols)) + abs(Fraction(float(b[i])))  # fmt: skip
            assert a - elo <= mag * Fraction(1, 10**13) + Fraction(1, 10**300)


def test_interval_affine_survives_cancellation_that_float_dot_products_get_wrong():
    """1e16 + 1 - 1e16 is 0 or 2 in doubles depending on the order; the enclosure holds 1."""
    W = np.array([[1.0, 1.0, 1.0]])
    x = np.array([[1e16], [1.0], [-1e16]])
    assert float((W @ x)[0, 0]) != 1.0  # the float product is wrong here
    enc = interval_affine(W, np.zeros(1), x, x)
    assert float(enc.lo[0, 0]) <= 1.0 <= float(enc.hi[0, 0])
    unbounded = interval_affine(W, np.zeros(1), np.array([[-np.inf], [0.0], [0.0]]), x * 0)
    assert np.isneginf(unbounded.lo[0, 0]) and np.isposinf(unbounded.hi[0, 0])


# -- the network object --------------------------------------------------------------------------------
def _net(kind: str, seed: int = 1) -> MLP:
    rng = np.random.default_rng(seed)
    W0, b0 = rng.normal(size=(8, 3)), rng.normal(size=8)
    W1, b1 = rng.normal(size=(5, 8)) * 0.5, rng.normal(size=5)
    W2, b2 = rng.normal(size=(2, 5)), rng.normal(size=2)
    second = ("leaky_relu", 0.1) if kind == "relu" else "sigmoid"
    third = ("clip", -1.0, 1.5) if kind == "relu" else "softplus"
    return MLP([(W0, b0), (W1, b1), (W2, b2)], [kind, second, third])


def _mp_net(net: MLP, x: list[mp.mpf]) -> list[mp.mpf]:
    """The network at 50 digits, written out independently of MLP._elementwise."""
    from roa.nn import Affine

    h = list(x)
    for op in net.ops:
        if isinstance(op, Affine):
            h = [sum((mp.mpf(float(w)) * v for w, v in zip(row, h, strict=True)), mp.mpf(0))
                 + mp.mpf(float(bi)) for row, bi in zip(op.W, op.b, strict=True)]  # fmt: skip
        elif op.name == "clip":
            h = [min(max(v, mp.mpf(op.args[0])), mp.mpf(op.args[1])) for v in h]
        else:
            h = [_exact(op.name, v, *op.args) for v in h]
    return h


@pytest.mark.parametrize("kind", ["tanh", "relu"])
def test_mlp_in_every_namespace_agrees_with_a_50_digit_evaluation(kind):
    import casadi as ca

    net = _net(kind)
    rng = np.random.default_rng(7)
    X = rng.uniform(-2, 2, (3, 50))
    batch = net([X[0], X[1], X[2]], namespace("numpy"))
    assert len(batch) == 2 and batch[0].shape == (50,)
    grid = net([X[0].reshape(5, 10), X[1].reshape(5, 10), X[2].reshape(5, 10)], namespace("numpy"))
    assert np.array_equal(grid[1].ravel(), batch[1])  # any common shape
    for k in range(0, 50, 7):
        with mp.workdps(50):
            want = _mp_net(net, [mp.mpf(float(v)) for v in X[:, k]])
            got_mp = net([mp.mpf(float(v)) for v in X[:, k]], namespace("mpmath"))
            for w, g in zip(want, got_mp, strict=True):
                assert abs(w - g) <= mp.mpf(10) ** -40 * (1 + abs(w))
        for name in ("numpy", "casadi", "sympy"):
            got = net([float(v) for v in X[:, k]], namespace(name))
            for w, g in zip(want, got, strict=True):
                g = float(ca.DM(g)) if name == "casadi" else float(g)
                assert abs(g - float(w)) <= 1e-12 * (1 + abs(float(w))), (name, k)


@pytest.mark.parametrize("kind", ["tanh", "relu"])
def test_mlp_interval_and_jet_evaluations_enclose_the_network(kind):
    net = _net(kind)
    rng = np.random.default_rng(3)
    c = rng.uniform(-2, 2, (3, 20))
    r = rng.choice([0.0, 1e-6, 0.05, 0.5], (3, 20))
    lo, hi = c - r, c + r
    enc = net([Interval(lo[i], hi[i]) for i in range(3)], INTERVAL)
    jets = net(Jet.variables(lo.T, hi.T, order=1), JET)
    for m in range(20):
        for p in rng.uniform(lo[:, m], hi[:, m], (5, 3)).tolist() + [lo[:, m].tolist()]:
            with mp.workdps(50):
                want = _mp_net(net, [mp.mpf(v) for v in p])
            for i in range(2):
                for e in (enc[i], Interval.of(jets[i].v)):
                    assert float(e.lo[m]) <= want[i] <= float(e.hi[m]), (kind, m, i)
    tight = net([Interval(c[i]) for i in range(3)], INTERVAL)  # point boxes: a few ulps wide
    assert np.all(tight[0].hi - tight[0].lo <= 1e-12 * (1 + np.abs(tight[0].hi)))


def test_mlp_centred_is_zero_at_the_point_exactly_and_checks_its_input():
    import sympy as sp

    from roa.model._sympy_eval import exact_rationals

    rng = np.random.default_rng(2)
    net = MLP([(rng.normal(size=(4, 3)), rng.normal(size=4)), (rng.normal(size=(2, 4)), rng.normal(size=2))],
              ["tanh", None])  # fmt: skip
    c = net.centred([0.5, -0.25, 0.0])
    assert c([0.5, -0.25, 0.0], namespace("numpy")) == [0.0, 0.0]
    enc = c([Interval(0.5), Interval(-0.25), Interval(0.0)], INTERVAL)
    assert all(float(e.lo) <= 0.0 <= float(e.hi) for e in enc)
    xs = sp.symbols("x0:3", real=True)
    with sp.evaluate(False):
        e = c(list(xs), namespace("sympy"))
    at = {xs[0]: sp.Rational(1, 2), xs[1]: sp.Rational(-1, 4), xs[2]: 0}
    assert all(sp.simplify(exact_rationals(sp.sympify(v)).xreplace(at)) == 0 for v in e)
    uncentred = net(list(xs), namespace("sympy"))  # the raw network is not 0 there
    assert any(abs(float(v.xreplace(at))) > 1e-3 for v in uncentred)
    for bad in ([0.0, 0.0], [0.0, np.nan, 0.0]):
        with pytest.raises(RoaInputError, match="x0 must be 3 finite numbers"):
            net.centred(bad)


def test_mlp_rejects_malformed_networks():
    W, b = np.ones((4, 2)), np.zeros(4)
    cases = [
        (lambda: MLP([]), "layers is empty"),
        (lambda: MLP([(W, np.zeros(3))]), "W has 4 rows but b has shape"),
        (lambda: MLP([(W, b), (np.ones((1, 3)), np.zeros(1))]), "takes 3 inputs"),
        (lambda: MLP([(W, b)], ["gelu"]), "unknown activation 'gelu'"),
        (lambda: MLP([(W, b)], [("leaky_relu", -0.5)]), "slope must be >= 0"),
        (lambda: MLP([(W, b)], [("clip", 1.0, -1.0)]), "clip takes"),
        (lambda: MLP([(W * np.nan, b)]), "non-finite"),
        (lambda: MLP([(W, b), (np.ones((1, 4)), np.zeros(1))], ["tanh", None, "tanh"]), "3 activations"),
        (lambda: MLP([(W, b)])([1.0], namespace("numpy")), "1 inputs given"),
    ]  # fmt: skip
    for make, message in cases:
        with pytest.raises(RoaInputError, match=message):
            make()


def test_mlp_save_load_and_pickle_round_trip(tmp_path):
    net = _net("relu")
    net.save(tmp_path / "net.npz")
    back = MLP.load(tmp_path / "net.npz")
    x = [np.linspace(-2, 2, 9)] * 3
    assert repr(back) == repr(net)
    for a, b in zip(net(x, namespace("numpy")), back(x, namespace("numpy")), strict=True):
        assert np.array_equal(a, b)
    c = pickle.loads(pickle.dumps(net.centred([0.0, 0.0, 0.0])))
    assert c.centre == (0.0, 0.0, 0.0) and c([0.0] * 3, namespace("numpy")) == [0.0, 0.0]


# -- ONNX ------------------------------------------------------------------------------------------------
def _onnx_model(path: Path, nodes, inits, n_in: int, n_out: int) -> None:
    onnx = pytest.importorskip("onnx", reason="ONNX networks need the onnx package (nn extra)")
    from onnx import TensorProto, helper, numpy_helper

    graph = helper.make_graph(
        nodes,
        "net",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [None, n_in])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [None, n_out])],
        [numpy_helper.from_array(v.astype(np.float32), name=k) for k, v in inits.items()],
    )
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)]), str(path))


def _reference(path: Path, X: np.ndarray) -> np.ndarray:
    from onnx.reference import ReferenceEvaluator

    return ReferenceEvaluator(str(path)).run(None, {"x": X.astype(np.float32)})[0]


def test_onnx_networks_are_read_as_the_same_network(tmp_path):
    pytest.importorskip("onnx", reason="ONNX networks need the onnx package (nn extra)")
    from onnx import helper

    rng = np.random.default_rng(11)
    W0, b0 = rng.normal(size=(6, 2)).astype(np.float32), rng.normal(size=6).astype(np.float32)
    W1, b1 = rng.normal(size=(1, 6)).astype(np.float32), rng.normal(size=1).astype(np.float32)
    # Gemm (transB = 1, PyTorch's Linear) - Tanh - Gemm
    gemm = tmp_path / "gemm.onnx"
    _onnx_model(gemm, [helper.make_node("Gemm", ["x", "W0", "b0"], ["h"], transB=1),
                       helper.make_node("Tanh", ["h"], ["a"]),
                       helper.make_node("Gemm", ["a", "W1", "b1"], ["y"], transB=1)],
                {"W0": W0, "b0": b0, "W1": W1, "b1": b1}, 2, 1)  # fmt: skip
    # MatMul + Add - Relu - MatMul + Add - Sigmoid - Clip
    mm = tmp_path / "matmul.onnx"
    _onnx_model(mm, [helper.make_node("MatMul", ["x", "W0t"], ["h0"]),
                     helper.make_node("Add", ["h0", "b0"], ["h"]),
                     helper.make_node("Relu", ["h"], ["a"]),
                     helper.make_node("MatMul", ["a", "W1t"], ["z0"]),
                     helper.make_node("Add", ["b1", "z0"], ["z"]),
                     helper.make_node("Sigmoid", ["z"], ["s"]),
                     helper.make_node("Clip", ["s", "lo", "hi"], ["y"])],
                {"W0t": W0.T.copy(), "b0": b0, "W1t": W1.T.copy(), "b1": b1,
                 "lo": np.array(0.2), "hi": np.array(0.7)}, 2, 1)  # fmt: skip
    sig = MLP([(W0, b0), (W1, b1)], ["relu", "sigmoid"])
    lo32, hi32 = float(np.float32(0.2)), float(np.float32(0.7))  # the file's float32 bounds
    pairs = [
        (gemm, MLP([(W0, b0), (W1, b1)], ["tanh", None])),
        (mm, MLP.from_ops([*sig.ops, Activation("clip", (lo32, hi32))])),
    ]
    X = rng.uniform(-3, 3, (40, 2))
    for path, want in pairs:
        net = MLP.from_onnx(path)
        assert repr(net) == repr(want)
        got = net([X[:, 0], X[:, 1]], namespace("numpy"))[0]
        assert np.array_equal(got, want([X[:, 0], X[:, 1]], namespace("numpy"))[0])
        ref = _reference(path, X)[:, 0]  # onnx's own evaluator, in float32
        assert np.max(np.abs(got - ref)) <= 1e-5 * (1 + np.max(np.abs(ref)))
    assert MLP.from_onnx(mm)([X[:, 0], X[:, 1]], namespace("numpy"))[0].min() >= lo32


def test_onnx_with_an_unsupported_operator_is_refused_by_name(tmp_path, capsys):
    pytest.importorskip("onnx", reason="ONNX networks need the onnx package (nn extra)")
    from onnx import helper

    from roa.cli import main

    path = tmp_path / "softmax.onnx"
    W = np.ones((2, 2), dtype=np.float32)
    _onnx_model(path, [helper.make_node("MatMul", ["x", "W"], ["h"]),
                       helper.make_node("Softmax", ["h"], ["y"], name="probs")], {"W": W}, 2, 2)  # fmt: skip
    with pytest.raises(RoaInputError, match="unsupported operator 'Softmax' \\(node 'probs'\\)"):
        MLP.from_onnx(path)
    system_file = tmp_path / "softmax_system.py"
    system_file.write_text(
        "from roa import System\nfrom roa.nn import MLP\n"
        f"NET = MLP.from_onnx({str(path)!r})\n"
        "SYSTEM = System(name='s', field=lambda t, x, xp: (-x[0], -x[1]), equilibrium=(0.0, 0.0))\n"
    )
    assert main(["certify", "--system", f"{system_file}:SYSTEM", "--level", "0.5"]) == 2
    assert "Softmax" in capsys.readouterr().err
    with pytest.raises(RoaInputError, match="no such file"):
        MLP.from_onnx(tmp_path / "absent.onnx")


# -- the pendulum under network controllers ------------------------------------------------------------
def _example():
    sys.path.insert(0, str(EXAMPLE.parent))
    try:
        import pendulum_nn
    finally:
        sys.path.remove(str(EXAMPLE.parent))
    return pendulum_nn


def independent_optimum(system, P: np.ndarray, starts: int = 40, seed: int = 0) -> float:
    """min V = x'Px subject to V' >= 0 and |x| >= 0.05 (multistart SLSQP from the box
    [-4, 4]^2; V' from the numpy field): the largest level of V whose set has V' < 0."""
    from scipy.optimize import minimize

    def vdot(x):
        return float(2.0 * x @ P @ system.f(x))

    rng = np.random.default_rng(seed)
    best = np.inf
    for _ in range(starts):
        res = minimize(lambda x: float(x @ P @ x), rng.uniform(-4, 4, 2), method="SLSQP",
                       constraints=[{"type": "ineq", "fun": vdot},
                                    {"type": "ineq", "fun": lambda x: float(x @ x) - 0.05**2}],
                       options={"maxiter": 300, "ftol": 1e-12})  # fmt: skip
        if res.success and vdot(res.x) >= -1e-9 and res.x @ res.x >= 0.05**2 - 1e-9:
            best = min(best, float(res.fun))
    return best


@pytest.mark.parametrize("name", ["SYSTEM", "SYSTEM_RELU"])
def test_pendulum_nn_certified_at_099_of_the_optimum_down_to_the_equilibrium(name):
    """The interval branch and bound (default validator) certifies 0.99 x the SLSQP optimum of
    the default quadratic V (15.93 tanh, 18.96 ReLU), with the Hessian proof on a box around
    the equilibrium (no excluded region), and refutes 1.01 x with a 50-digit witness."""
    import roa
    from roa.model._linearisation import lyapunov_matrix

    system = getattr(_example(), name)
    P = lyapunov_matrix(system)
    c = independent_optimum(system, P)
    assert 10.0 < c < 30.0
    cert = roa.certify(system, level=0.99 * c)
    assert cert.certified, cert.message
    meta = cert.to_dict()
    assert meta["local_proof"] == "hessian" and meta["cover"].startswith("global")
    above = roa.certify(system, level=1.01 * c)
    assert above.status.value == "refuted", above.message
    w = np.array(above.witness)
    assert float(w @ P @ w) <= 1.01 * c * (1 + 1e-9)
    assert float(2 * w @ P @ system.f(w)) >= 0.0


def test_relu_network_is_affine_near_the_equilibrium_and_the_local_proof_sees_it():
    """No bias of the ReLU controller is 0: on the box |x_i| <= r with r below
    min |b_i| / max_i |W_i|_1 every unit keeps one phase (proved by the interval product), the
    jets take the linear branches, and the Hessian proof of V' < 0 holds there. With zero
    biases every unit is at its kink at 0, every box around 0 has an unbounded Hessian and the
    local proof (so the certificate) fails: the network must not kink at the equilibrium."""
    from roa.lyapunov import QuadraticLyapunov
    from roa.model._linearisation import lyapunov_matrix
    from roa.proof._local import local_box, local_box_proof

    ex = _example()
    system = ex.SYSTEM_RELU
    net = MLP.load(EXAMPLE.parent / "pendulum_nn_relu.npz")
    (W0, b0), _ = net.layers
    r = 0.9 * float(np.min(np.abs(b0)) / np.max(np.abs(W0).sum(axis=1)))
    assert r > 1e-3
    pre = interval_affine(W0, b0, np.full((2, 1), -r), np.full((2, 1), r))
    assert np.all((pre.lo > 0) | (pre.hi < 0))  # every phase decided on the box
    V = QuadraticLyapunov(lyapunov_matrix(system), np.zeros(2))
    assert local_box_proof(system, V, np.full(2, -r), np.full(2, r))

    kinked = MLP([(W0, np.zeros_like(b0)), net.layers[1]], ["relu", None])

    def field(t, x, xp):
        return (x[1], -xp.sin(x[0]) - 0.1 * x[1] + kinked([x[0], x[1]], xp)[0])

    from roa import System

    s0 = System(name="kinked", field=field, equilibrium=(0.0, 0.0), state_names=("a", "b"))
    assert local_box(s0, V, np.full(2, -1.0), np.full(2, 1.0)) is None


def _system_file(tmp_path: Path, weights: Path) -> str:
    path = tmp_path / f"sys_{weights.stem}.py"
    path.write_text(
        "import importlib.util\n"
        f"spec = importlib.util.spec_from_file_location('pendulum_nn_copy', {str(EXAMPLE)!r})\n"
        "m = importlib.util.module_from_spec(spec)\nspec.loader.exec_module(m)\n"
        f"SYSTEM = m.load('tanh', {str(weights)!r})\n"
    )
    return f"{path}:SYSTEM"


def test_perturbed_weights_make_the_stored_certificate_refuse(tmp_path, capsys):
    """A certificate of the tanh loop (roa certify --json) re-verifies for the committed weights;
    with the hidden weights moved by 1e-3 `roa verify` refuses it (another system: exit 2); with
    the fingerprint removed and the output layer scaled by 0.9, the re-verification refutes the
    stored level (exit 1)."""
    import json

    from roa.cli import main

    committed = EXAMPLE.parent / "pendulum_nn_tanh.npz"
    spec = _system_file(tmp_path, committed)
    net = MLP.load(committed)
    (W0, b0), (W1, b1) = net.layers
    assert main(["certify", "--system", spec, "--level", "15.5", "--json"]) == 0
    cert = json.loads(capsys.readouterr().out)
    assert cert["status"] == "certified"
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(cert))
    assert main(["verify", str(path), "--system", spec]) == 0
    capsys.readouterr()

    moved = tmp_path / "moved.npz"
    MLP([(W0 + 1e-3, b0), (W1, b1)], ["tanh", None]).save(moved)
    assert main(["verify", str(path), "--system", _system_file(tmp_path, moved)]) == 2
    assert "made for another system" in capsys.readouterr().err

    weaker = tmp_path / "weaker.npz"
    MLP([(W0, b0), (W1 * 0.9, b1)], ["tanh", None]).save(weaker)
    del cert["system_fingerprint"]
    path.write_text(json.dumps(cert))
    assert main(["verify", str(path), "--system", _system_file(tmp_path, weaker), "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "refuted" and out["claimed_status"] == "certified"


def test_sympy_fields_with_tanh_and_a_network_controller_compile_for_monte_carlo():
    """tanh is a function of from_sympy fields (every namespace evaluates it), and a traced
    network field (tanh, and relu as Max) compiles to the Monte Carlo kernel's source."""
    import sympy as sp

    from roa import System
    from roa.integration._codegen import kernel_source
    from roa.integration._trace import trace_system

    a, b = sp.symbols("a b", real=True)
    s = System.from_sympy([b, -sp.tanh(a + b) - b], [a, b])
    enc = s.field(0.0, [Interval(0.5, 0.6), Interval(-0.1, 0.1)], INTERVAL)[1]
    for p in ((0.5, -0.1), (0.6, 0.1), (0.55, 0.0)):
        want = -np.tanh(p[0] + p[1]) - p[1]
        assert float(enc.lo) <= want <= float(enc.hi)
    for name in ("SYSTEM", "SYSTEM_RELU"):
        system = getattr(_example(), name)
        text = kernel_source(trace_system(system), system_name=name, stamp="test")
        assert ("np.tanh" in text) == (name == "SYSTEM") and ("np.maximum" in text) == (
            name != "SYSTEM"
        )


def test_exact_equilibrium_of_a_relu_network_field_evaluates_max_on_numbers():
    """f(x_eq) = 0 exactly for the 6-16-16-2 ReLU quadrotor (centred network: 32 nested Max in
    each output), decided on exact rationals in seconds (simplified symbolically first, it took
    minutes); the same field with the network not centred is refused (f(0) != 0 exactly)."""
    from roa import System
    from roa.proof._exact import exact_equilibrium

    path = Path(__file__).resolve().parents[2] / "examples" / "systems" / "quadrotor_nn_relu.npz"
    raw = MLP.load(path)

    def make(net):
        def field(t, x, xp):
            u1, u2 = net(list(x[:6]), xp)
            s, c = xp.sin(x[2]), xp.cos(x[2])
            return (x[3], x[4], x[5], 9.81 * s + u1 * s, -9.81 + 9.81 * c + u1 * c, u2)

        return System(name="q", field=field, equilibrium=(0.0,) * 6, state_names=tuple("abcdef"))

    assert exact_equilibrium(make(raw.centred([0.0] * 6)), np.zeros(6))
    assert not exact_equilibrium(make(raw), np.zeros(6))
