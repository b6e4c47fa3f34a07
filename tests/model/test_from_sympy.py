"""roa.System.from_sympy (#25): a system from sympy expressions runs in every namespace.

Van der Pol written in sympy gives the numbers of the hand-written roa.systems.vanderpol on numpy,
its interval evaluation encloses the numpy values, and certify gives the same verdicts (2.30
certified, 2.31 refuted with the published P). Unsupported functions and stray symbols are refused
when the system is built, naming them.
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
import sympy as sp

import roa
from roa.model._backend import namespace
from roa.proof._interval import INTERVAL, Interval
from roa.proof._jet_net import JET
from roa.systems.vanderpol import P_BENCHMARK, vanderpol

x1, x2, mu = sp.symbols("x1 x2 mu")
VDP = [-x2, x1 + mu * (x1**2 - 1) * x2]


def _vdp(**kw):
    kw.setdefault("params", {mu: 1.0})
    return roa.System.from_sympy(VDP, [x1, x2], name="vdp-sympy", lyapunov=P_BENCHMARK, **kw)


def _states(n=500, seed=0):
    return np.random.default_rng(seed).uniform(-3, 3, size=(n, 2))


def test_numpy_values_are_those_of_the_hand_written_field():
    X = _states()
    np.testing.assert_array_equal(_vdp().f(X), vanderpol().f(X))
    np.testing.assert_array_equal(_vdp().with_params(mu=2.0).f(X), vanderpol(2.0).f(X))


def test_intervals_enclose_the_numpy_values():
    sys_ = _vdp()
    X = _states()
    lo, hi = X - 1e-3, X + 1e-3
    out = sys_.field(0.0, [Interval(lo[:, i], hi[:, i]) for i in range(2)], INTERVAL)
    rng = np.random.default_rng(1)
    for _ in range(5):  # points inside the boxes
        Y = lo + (hi - lo) * rng.uniform(size=X.shape)
        F = sys_.f(Y)
        for i in range(2):
            assert np.all(out[i].lo <= F[:, i]) and np.all(F[:, i] <= out[i].hi)


def test_every_namespace_evaluates_it():
    sys_ = _vdp()
    a, b = sp.symbols("a b")
    f_sym = sys_.field(0.0, [a, b], namespace("sympy"))
    assert sp.simplify(f_sym[1] - (a + (a**2 - 1) * b)) == 0
    import mpmath as mp

    f_mp = sys_.field(0.0, [mp.mpf("0.5"), mp.mpf("0.5")], namespace("mpmath"))
    assert [float(v) for v in f_mp] == [-0.5, 0.125]
    import casadi as ca

    xs = ca.SX.sym("x", 2)
    fn = ca.Function("f", [xs], [ca.vertcat(*sys_.field(0.0, [xs[0], xs[1]], namespace("casadi")))])
    np.testing.assert_allclose(np.asarray(fn([0.5, 0.5])).ravel(), [-0.5, 0.125])
    assert JET is not None  # jets are exercised by certify below (the local analysis)


def test_certify_gives_the_published_levels():
    sys_ = _vdp()
    V = roa.default_lyapunov(sys_)
    assert roa.certify(sys_, V, level=2.30).status is roa.Verdict.CERTIFIED
    above = roa.certify(sys_, V, level=2.31)
    assert above.status is roa.Verdict.REFUTED


def test_functions_rationals_and_constants():
    x, y = sp.symbols("x y")
    exprs = [-sp.sin(x) + sp.Rational(1, 3) * y, -sp.sqrt(1 + x**2) * y + sp.pi * 0 + x / 3 - x / 3]
    sys_ = roa.System.from_sympy(exprs, [x, y])
    X = _states()
    expect = np.stack([-np.sin(X[:, 0]) + X[:, 1] / 3, -np.sqrt(1 + X[:, 0] ** 2) * X[:, 1]], -1)
    np.testing.assert_allclose(sys_.f(X), expect, rtol=1e-14, atol=1e-14)
    # pi and E through the namespace
    s2 = roa.System.from_sympy([sp.pi * x - sp.pi * x - y, sp.E * x - sp.E * x - y + 0 * x], [x, y])
    assert s2.f([1.0, 2.0]).tolist() == [-2.0, -2.0]
    one = roa.System.from_sympy([-x + sp.pi - sp.pi * sp.cos(y), -y], [x, y])
    assert one.f([0.0, 0.0]).tolist() == [0.0, 0.0]
    # a rational coefficient is enclosed by the intervals (1/3 is not a double)
    enc = sys_.field(0.0, [Interval(np.array([0.0])), Interval(np.array([1.0]))], INTERVAL)[0]
    assert enc.lo[0] < 1 / 3 < enc.hi[0] or enc.lo[0] <= 1 / 3 <= enc.hi[0]


def test_uncertain_parameters_as_in_system():
    sys_ = _vdp(params=None, parameters={"mu": (0.8, 1.0, 1.2)})
    assert sys_.uncertain == ("mu",) and sys_.parameters["mu"].nominal == 1.0
    X = _states()
    # sympy orders the product mu * x2 * (x1**2 - 1) its own way: equal to a few ulps
    np.testing.assert_allclose(sys_.at(mu=1.2).f(X), vanderpol(1.2).f(X), rtol=1e-14, atol=1e-13)


@pytest.mark.parametrize(
    ("exprs", "word"),
    [
        ([-x1 + sp.acos(x2), -x2], "acos"),
        ([-x1 + sp.sign(x2), -x2], "sign"),
        ([-x1 + sp.Piecewise((x2, x2 > 0), (0, True)), -x2], "Piecewise"),
        ([-x1 + sp.cbrt(x2), -x2], "power"),
        ([-x1 + mu * x2, -x2], "mu"),
    ],
)
def test_unsupported_expressions_are_refused_naming_them(exprs, word):
    with pytest.raises(roa.RoaInputError, match=word):
        roa.System.from_sympy(exprs, [x1, x2])


def test_wrong_count_and_pickling():
    with pytest.raises(roa.RoaInputError, match="2 expressions for 3 states"):
        roa.System.from_sympy([-x1, -x2], sp.symbols("x1 x2 x3"))
    sys_ = _vdp()
    again = pickle.loads(pickle.dumps(sys_))
    X = _states(10)
    np.testing.assert_array_equal(again.f(X), sys_.f(X))
    assert "sympy" not in repr(sys_.field.func.program)  # no sympy object in the program


def test_a_user_file_with_from_sympy_is_certified_by_the_cli(tmp_path, capsys):
    from roa.cli import main

    path = tmp_path / "vdp_sympy.py"
    path.write_text(
        "import sympy as sp\nfrom roa import System\n\n"
        'x1, x2, mu = sp.symbols("x1 x2 mu")\n'
        "SYSTEM = System.from_sympy([-x2, x1 + mu * (x1**2 - 1) * x2], [x1, x2], params={mu: 1.0},\n"
        '                           name="vdp-sympy", lyapunov=[[1.5, -0.5], [-0.5, 1.0]])\n'
    )
    assert main(["certify", "--system", f"{path}:SYSTEM", "--level", "2.30", "--json"]) == 0
    assert '"status": "certified"' in capsys.readouterr().out
    assert main(["certify", "--system", f"{path}:SYSTEM", "--level", "2.31", "--json"]) == 1
    assert '"status": "refuted"' in capsys.readouterr().out


# --- inputs sympy or numpy cannot take (issue 39, item 5) -------------------------------------


def _nested_atan(depth: int):
    """atan(atan(...atan(x))) with ``depth`` atans, built under a raised recursion limit (sympy's
    own construction recurses per level)."""
    import sys

    x = sp.Symbol("x")
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 20 * depth))
    try:
        e = x
        for _ in range(depth):
            e = sp.atan(e)
        return e - 2 * x  # one more level: the sum
    finally:
        sys.setrecursionlimit(limit)


def test_an_expression_nested_deeper_than_the_limit_is_an_input_error():
    from roa.model._sympy_system import MAX_DEPTH

    x, y = sp.symbols("x y")
    with pytest.raises(roa.RoaInputError, match=rf"expression 0 is nested more than {MAX_DEPTH}"):
        roa.System.from_sympy([_nested_atan(500), -y], [x, y])
    with pytest.raises(roa.RoaInputError, match=rf"nested more than {MAX_DEPTH}"):
        roa.System.from_sympy([_nested_atan(MAX_DEPTH), -y], [x, y])  # the sum is one more level
    deepest = roa.System.from_sympy([_nested_atan(MAX_DEPTH - 1), -y], [x, y])
    v = 0.3
    for _ in range(MAX_DEPTH - 1):
        v = math.atan(v)
    assert deepest.f([0.3, 0.0])[0] == pytest.approx(v - 0.6, rel=1e-14)


@pytest.mark.parametrize(
    ("constant", "match"),
    [
        (
            sp.Rational(10**400, 3),
            r"the constant 1000.*/3 \(\d+ characters\) is outside the double",
        ),
        (sp.Integer(10**400), r"the constant 1000.* is outside the double range"),
        (sp.Float("1e400"), r"the constant .* is outside the double range"),
    ],
)
def test_a_constant_beyond_doubles_is_an_input_error(constant, match):
    x, y = sp.symbols("x y")
    with pytest.raises(roa.RoaInputError, match=match):
        roa.System.from_sympy([-x + constant * y, -y], [x, y])


def test_a_tiny_rational_is_kept_exact_not_refused():
    """1/10**400 underflows to 0.0 in doubles; intervals enclose it (it stays exact)."""
    x, y = sp.symbols("x y")
    s = roa.System.from_sympy([-x + sp.Rational(1, 10**400), -y], [x, y])
    assert s.f([0.5, 0.0]).tolist() == [-0.5, 0.0]


@pytest.mark.parametrize(
    ("value", "match"),
    [
        (object(), r"expression 0 \(object <object object.*\) is not a sympy expression"),
        ("x**", r"expression 0 \(str 'x\*\*'\) is not a sympy expression \(SympifyError\)"),
        (sp.Eq(sp.Symbol("x"), 1), r"expression 0 \(Equality .*\) is not a sympy expression"),
    ],
)
def test_what_is_not_an_expression_is_an_input_error(value, match):
    x, y = sp.symbols("x y")
    with pytest.raises(roa.RoaInputError, match=match):
        roa.System.from_sympy([value, -y], [x, y])
