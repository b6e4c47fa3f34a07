"""Rigour of the interval layer (issue 15): jets enclose exact values and derivatives; sectors.

Random programs of jet operations with float constants are run three ways: on interval jets
(:class:`roa.proof.Jet`, second order, on a box), on exact rational jets
(:class:`fractions.Fraction`, for the rational operations) and on 50-digit mpmath jets (with the
transcendental functions); the interval jet must contain the exact value, gradient and Hessian at
a point of the box. The exact derivatives come from the chain rule in exact / 50-digit arithmetic,
not from finite differences.
"""

from __future__ import annotations

from fractions import Fraction

import mpmath as mp
import numpy as np
import pytest
from hypothesis import assume, example, given, settings, strategies as st

from roa.errors import RoaInputError
from roa.proof._interval import INTERVAL, Interval
from roa.proof._jet import Jet
from roa.proof._jet_net import JET
from roa.search._rays import ray_box


# -- reference jets: exact (Fraction) or 50-digit (mpmath) ------------------------------------------
class _Reject(Exception):
    """The reference value leaves the domain (or grows unmanageably): skip the example."""


class RefJet:
    """Value, gradient and full Hessian in exact (Fraction) or mpmath arithmetic."""

    def __init__(self, v, g, h):
        self.v, self.g, self.h = v, g, h

    @classmethod
    def variables(cls, x, zero, one):
        n = len(x)
        return [
            cls(x[i], [one if j == i else zero for j in range(n)], [[zero] * n for _ in range(n)])
            for i in range(n)
        ]

    def _lift(self, c):
        if isinstance(c, RefJet):
            return c
        z = self.v * 0
        n = len(self.g)
        return RefJet(c, [z] * n, [[z] * n for _ in range(n)])

    def __add__(self, o):
        o = self._lift(o)
        n = len(self.g)
        return RefJet(
            self.v + o.v,
            [self.g[i] + o.g[i] for i in range(n)],
            [[self.h[i][j] + o.h[i][j] for j in range(n)] for i in range(n)],
        )

    __radd__ = __add__

    def __neg__(self):
        return self * -1

    def __sub__(self, o):
        return self + (-self._lift(o))

    def __rsub__(self, o):
        return self._lift(o) - self

    def __mul__(self, o):
        o = self._lift(o)
        n = len(self.g)
        return RefJet(
            self.v * o.v,
            [self.g[i] * o.v + self.v * o.g[i] for i in range(n)],
            [
                [
                    self.h[i][j] * o.v
                    + self.v * o.h[i][j]
                    + self.g[i] * o.g[j]
                    + self.g[j] * o.g[i]
                    for j in range(n)
                ]
                for i in range(n)
            ],
        )

    __rmul__ = __mul__

    def apply(self, f0, f1, f2):
        n = len(self.g)
        d1, d2 = f1, f2
        return RefJet(
            f0,
            [d1 * self.g[i] for i in range(n)],
            [[d2 * self.g[i] * self.g[j] + d1 * self.h[i][j] for j in range(n)] for i in range(n)],
        )

    def reciprocal(self):
        if self.v == 0:
            raise _Reject
        v = self.v
        return self.apply(1 / v, -1 / (v * v), 2 / (v * v * v))

    def __truediv__(self, o):
        return self * (o.reciprocal() if isinstance(o, RefJet) else self._lift(o).reciprocal())

    def __rtruediv__(self, o):
        return self.reciprocal() * o

    def __pow__(self, p):
        v = self.v
        if isinstance(p, int):
            if v == 0 and p < 2:
                raise _Reject
            return self.apply(v**p, p * v ** (p - 1), p * (p - 1) * v ** (p - 2))
        if v <= 0:
            raise _Reject
        p = mp.mpf(p)
        return self.apply(v**p, p * v ** (p - 1), p * (p - 1) * v ** (p - 2))


def _mp_functions():
    """name -> (domain check, f, f', f'') at the current mpmath precision."""
    return {
        "sin": (lambda v: True, mp.sin, mp.cos, lambda v: -mp.sin(v)),
        "cos": (lambda v: True, mp.cos, lambda v: -mp.sin(v), lambda v: -mp.cos(v)),
        "tan": (
            lambda v: abs(mp.cos(v)) > mp.mpf(10) ** -8,
            mp.tan,
            lambda v: 1 + mp.tan(v) ** 2,
            lambda v: 2 * mp.tan(v) * (1 + mp.tan(v) ** 2),
        ),
        "exp": (lambda v: v < 600, mp.exp, mp.exp, mp.exp),
        "log": (lambda v: v > 0, mp.log, lambda v: 1 / v, lambda v: -1 / v**2),
        "sqrt": (
            lambda v: v > 0,
            mp.sqrt,
            lambda v: 1 / (2 * mp.sqrt(v)),
            lambda v: -1 / (4 * v**1.5),
        ),
        "arctan": (
            lambda v: True,
            mp.atan,
            lambda v: 1 / (1 + v**2),
            lambda v: -2 * v / (1 + v**2) ** 2,
        ),
        "arcsinh": (
            lambda v: True,
            mp.asinh,
            lambda v: 1 / mp.sqrt(1 + v**2),
            lambda v: -v / (1 + v**2) ** 1.5,
        ),
        "arctanh": (
            lambda v: abs(v) < 1,
            mp.atanh,
            lambda v: 1 / (1 - v**2),
            lambda v: 2 * v / (1 - v**2) ** 2,
        ),
    }


# -- random programs ---------------------------------------------------------------------------------
RATIONAL_OPS = [
    "add",
    "sub",
    "mul",
    "square",
    "div",
    "addc",
    "subc",
    "rsubc",
    "mulc",
    "cmul",
    "divc",
    "rdivc",
    "neg",
    "pow3",
    "powm2",
]
TRANSCENDENTAL_OPS = [*_mp_functions(), "pow1.5", "pow-0.5", "pow0.1"]


def _run(program, xs, *, ref: bool, fns=None):
    """Registers after running ``program`` on the variable jets ``xs`` (interval or reference)."""
    regs = list(xs)
    for op, i, j, c in program:
        a, b = regs[i % len(regs)], regs[j % len(regs)]
        if ref and isinstance(a.v, Fraction):
            c = Fraction(c)
        elif ref:
            c = mp.mpf(c)
        if op == "add":
            r = a + b
        elif op == "sub":
            r = a - b
        elif op == "mul":
            r = a * b
        elif op == "square":
            r = a * a
        elif op == "div":
            r = a / b
        elif op == "addc":
            r = a + c
        elif op == "subc":
            r = a - c
        elif op == "rsubc":
            r = c - a
        elif op == "mulc":
            r = a * c
        elif op == "cmul":
            r = c * a
        elif op == "divc":
            if ref and c == 0:
                raise _Reject
            r = a / c
        elif op == "rdivc":
            r = c / a
        elif op == "neg":
            r = -a
        elif op == "pow3":
            r = a**3
        elif op == "powm2":
            r = a**-2
        elif op.startswith("pow"):
            r = a ** float(op[3:])
        elif ref:
            ok, f0, f1, f2 = fns[op]
            if not ok(a.v):
                raise _Reject
            r = a.apply(f0(a.v), f1(a.v), f2(a.v))
        else:
            r = getattr(JET, op)(a)
        if ref:
            _check_size(r)
        regs.append(r)
    return regs


def _check_size(r):
    for e in [r.v, *r.g, *(e for row in r.h for e in row)]:
        if isinstance(e, Fraction):
            if e.denominator.bit_length() > 20_000 or abs(e) > 10**200:
                raise _Reject
        elif not mp.isfinite(e) or abs(e) > mp.mpf(10) ** 200:
            raise _Reject


def _bounds(e):
    """(lo, hi) floats of a jet coefficient (exact float or Interval of one box)."""
    if isinstance(e, float):
        return e, e
    iv = Interval.of(e)
    return float(np.ravel(iv.lo)[0]), float(np.ravel(iv.hi)[0])


def _encloses(e, exact, tol=0) -> bool:
    lo, hi = _bounds(e)
    if isinstance(exact, Fraction):
        return lo <= exact <= hi  # float vs Fraction compares exactly (inf included)
    return mp.mpf(lo) - tol <= exact <= mp.mpf(hi) + tol


def _assert_program_encloses(program, x, lo, hi, *, rational: bool):
    n = len(x)
    jets = _run(program, Jet.variables(lo[None, :], hi[None, :], order=2), ref=False)
    try:
        if rational:
            refs = _run(
                program,
                RefJet.variables([Fraction(float(v)) for v in x], Fraction(0), Fraction(1)),
                ref=True,
            )
        else:
            with mp.workdps(60):
                refs = _run(
                    program,
                    RefJet.variables([mp.mpf(float(v)) for v in x], mp.mpf(0), mp.mpf(1)),
                    ref=True,
                    fns=_mp_functions(),
                )
    except (_Reject, ZeroDivisionError, OverflowError):
        assume(False)
        return
    for k, (J, R) in enumerate(zip(jets, refs, strict=True)):
        tol = 0 if rational else mp.mpf(10) ** -40 * (1 + abs(R.v))
        assert _encloses(J.v, R.v, tol), (k, "value", J.v, R.v)
        for i in range(n):
            tg = 0 if rational else mp.mpf(10) ** -40 * (1 + abs(R.g[i]))
            assert _encloses(J.g[i], R.g[i], tg), (k, "grad", i, J.g[i], R.g[i])
            for j in range(i, n):
                th = 0 if rational else mp.mpf(10) ** -40 * (1 + abs(R.h[i][j]))
                assert _encloses(J.h[i][j], R.h[i][j], th), (k, "hess", i, j, J.h[i][j], R.h[i][j])


constants = st.one_of(
    st.floats(-100, 100, allow_nan=False, allow_infinity=False),
    st.sampled_from([0.1, 0.2, 0.3, 1 / 3, 2 / 3, 0.7, 1e-8, 1.1, 3.0, -0.1, 1e5 + 0.1, 2.0**-30]),
    st.integers(-5, 5).map(float),
)
coords = st.floats(-3, 3, allow_nan=False, allow_subnormal=False)
radii = st.sampled_from([0.0, 0.0, 1e-12, 1e-6, 1e-3, 0.05])


def _box(a, b, r1, r2):
    x = np.array([a, b])
    return x, x - np.array([r1, r2]), x + np.array([r2, r1])


def _program(ops):
    return st.lists(
        st.tuples(st.sampled_from(ops), st.integers(0, 50), st.integers(0, 50), constants),
        min_size=1,
        max_size=7,
    )


@settings(max_examples=400, deadline=None)
@given(_program(RATIONAL_OPS), coords, coords, radii, radii)
@example([("mulc", 0, 0, 0.1), ("mulc", 2, 0, 0.1)], 0.0, 0.0, 0.0, 0.0)
@example([("mulc", 0, 0, 0.1), ("mulc", 2, 0, 0.1)], 0.5, 0.0, 0.5, 0.0)
@example([("mulc", 0, 0, 0.1), ("square", 2, 0, 0.0), ("mulc", 3, 0, 1 / 3)], 1.0, 2.0, 0.0, 0.0)
def test_rational_jet_programs_enclose_exact_values(program, a, b, r1, r2):
    """Exact check in rational arithmetic: no float coefficient may be rounded to nearest."""
    x, lo, hi = _box(a, b, r1, r2)
    with np.errstate(all="ignore"):
        _assert_program_encloses(program, x, lo, hi, rational=True)


@settings(max_examples=300, deadline=None)
@given(_program(RATIONAL_OPS + TRANSCENDENTAL_OPS), coords, coords, radii, radii)
@example([("mulc", 0, 0, 0.1), ("sin", 2, 0, 0.0), ("mulc", 3, 0, 0.1)], 0.3, 0.0, 0.0, 0.0)
@example([("pow0.1", 0, 0, 0.0), ("mulc", 2, 0, 0.3)], 1.7, 0.0, 0.0, 0.0)
def test_transcendental_jet_programs_enclose_mpmath_values(program, a, b, r1, r2):
    """50-digit mpmath jets with the transcendental functions (enclosure up to 1e-40 relative)."""
    x, lo, hi = _box(a, b, r1, r2)
    with np.errstate(all="ignore"):
        _assert_program_encloses(program, x, lo, hi, rational=False)


def test_issue_example_product_of_constants_is_enclosed():
    (x,) = Jet.variables([[0.0]], [[1.0]], order=2)
    g = ((x * 0.1) * 0.1).g[0]
    assert isinstance(g, Interval)  # 0.1 * 0.1 is not a double
    exact = Fraction(0.1) * Fraction(0.1)
    lo, hi = _bounds(g)
    assert lo <= exact <= hi and lo < hi
    assert hi - lo < 2e-17  # and still tight (a few ulps of 0.01)
    # exact products of exact constants stay exact floats (no needless widening)
    assert ((x * 0.5) * 3.0).g[0] == 1.5
    assert isinstance(((x * 0.1) * 2.0).g[0], float)


def test_constants_entering_jets_and_intervals_are_enclosed():
    (x,) = Jet.variables([[1.0]], [[1.0]], order=1)
    third = Fraction(1, 3)
    for e in (Interval.of(third), (x * third).g[0], (x + third).v):
        lo, hi = _bounds(e)
        assert lo < third < hi or (lo <= third + 1 <= hi)
    big = 2**60 + 1  # not a double
    lo, hi = _bounds(Interval.of(big))
    assert lo <= big <= hi and lo < hi
    lo, hi = _bounds((x * big).g[0])
    assert lo <= big <= hi


def test_outward_rounding_never_tightens():
    """The fast outward rounding is at least one ulp wide, also at 0, subnormals and huge values."""
    from roa.proof._interval import LIBM_ULPS, round_down, round_up

    v = np.array([0.0, 5e-324, -5e-324, 2.0**-1022, 1.0, -1.0, 0.1, 1e300, -1e300, 1.7e308, 3.0])
    for k in (1, LIBM_ULPS):
        lo, hi = round_down(v, k), round_up(v, k)
        step_lo, step_hi = v.copy(), v.copy()
        for _ in range(k):
            step_lo, step_hi = np.nextafter(step_lo, -np.inf), np.nextafter(step_hi, np.inf)
        assert np.all(lo <= step_lo) and np.all(hi >= step_hi)
    with np.errstate(all="ignore"):
        big = Interval(np.array([1e308]))
        for s in (big + 1e308, big * 10.0, big * big, INTERVAL.exp(Interval(np.array([710.0])))):
            assert s.lo[0] <= np.finfo(float).max and s.hi[0] == np.inf  # overflow: 2e308 inside


# -- the Hessian of V' at the equilibrium, exactly ----------------------------------------------------
def _exact_jacobian(system):
    import sympy as sp

    from roa.model._backend import namespace

    xs = sp.symbols(f"x0:{system.n}")
    f = system.field(0.0, list(xs), namespace("sympy"))
    J = sp.Matrix(f).jacobian(sp.Matrix(xs)).subs(dict.fromkeys(xs, 0))
    return [
        [Fraction(str(sp.nsimplify(J[i, j], rational=True))) for j in range(system.n)]
        for i in range(system.n)
    ]


def _systems():
    from ipc_paper.system import transformed
    from ipc_paper.system.hybrid import hybrid
    from roa.systems.vanderpol import vanderpol

    return {"vanderpol": vanderpol, "ipc_flat": transformed, "ipc_hybrid": hybrid}


@pytest.mark.parametrize("name", list(_systems()))
def test_hessian_of_vdot_at_the_equilibrium_is_enclosed_exactly(name):
    """Issue 15: the exact Hessian 2 M'(PA + A'P)M of V'(c + M y) at y = 0 (rationals from the
    float P, M and the exact Jacobian A) lies in the jet enclosures of the one loop's local proof:
    at y = 0 and on the local box it proves (the whitened V of the loop, jets from the exact
    expansions in y, the cover of {V <= 2})."""
    import roa
    from roa.proof._cover import prove_cover
    from roa.proof._local import local_box
    from roa.proof._whiten import Whitened, whitened_system, whitening_for

    system = _systems()[name]()
    V = roa.default_lyapunov(system)
    n = V.n
    A = _exact_jacobian(system)
    Mf = whitening_for(V)
    assert Mf is not None  # the loop runs whitened for these V
    W = Whitened(V, system, Mf)
    Sw = whitened_system(system, W)
    M = [[Fraction(float(Mf[i, j])) for j in range(n)] for i in range(n)]
    P = [[Fraction(float(V.P[i, j])) for j in range(n)] for i in range(n)]

    def mat(X, Y):
        return [[sum(X[i][k] * Y[k][j] for k in range(n)) for j in range(n)] for i in range(n)]

    T = lambda X: [list(r) for r in zip(*X, strict=True)]  # noqa: E731
    PA = mat(P, A)
    S = [[2 * (PA[i][j] + PA[j][i]) for j in range(n)] for i in range(n)]
    H = mat(T(M), mat(S, M))
    zero = np.zeros((1, n))
    box, _, _ = prove_cover(W, 2.0, None, estimate=ray_box)
    assert box is not None
    found = local_box(Sw, W, *box)
    assert found is not None and found[2]["local_proof"] == "hessian"
    for lo, hi in ((zero, zero), (found[0][None, :], found[1][None, :])):
        vd = W.vdot_expr(Sw, Jet.variables(lo, hi, order=2), JET)
        for i in range(n):
            for j in range(i, n):
                assert _encloses(vd.h[i][j], H[i][j]), (name, i, j, vd.h[i][j], float(H[i][j]))
        if lo is zero:
            assert all(_encloses(g, Fraction(0)) for g in vd.g)
            assert _encloses(vd.v, Fraction(0))


# -- certified sectors --------------------------------------------------------------------------------
def test_certified_sector_of_a_disc_along_a_line():
    from roa.proof._sector import certified_sector, quadratic_form

    form = quadratic_form(np.eye(2))
    t = certified_sector(form, 5.0, lambda s, xp: (s, 0.5 * s), 10.0)  # 1.25 s^2 <= 5: |s| <= 2
    assert 2.0 - 1e-8 < t <= 2.0
    # an asymmetric curve: (s + s^2)^2 <= 1 holds for all s <= 0 and up to (sqrt 5 - 1)/2
    t = certified_sector(form, 1.0, lambda s, xp: (s + s * s, 0.0), 3.0)
    golden = (mp.sqrt(5) - 1) / 2
    assert golden - mp.mpf(1e-8) < t <= golden
    # not even s = 0: form(curve(0)) = 1 > 0.5
    assert certified_sector(form, 0.5, lambda s, xp: (s + 1.0, 0.0), 1.0) == -np.inf
    # the whole range
    assert certified_sector(form, 1e6, lambda s, xp: (s, s), 2.0) == 2.0


def _ipc_form_mp(P, level, s, coords="flat"):
    th = mp.mpf(s)
    w1 = mp.tan(th)
    y = [mp.asinh(w1) if coords == "flat" else mp.mpf(0), mp.mpf(0), w1, mp.mpf(0)]
    Pm = [[mp.mpf(float(P[i, j])) for j in range(4)] for i in range(4)]
    return mp.fsum(y[i] * Pm[i][j] * y[j] for i in range(4) for j in range(4)) - mp.mpf(level)


@pytest.mark.parametrize("coords", ["flat", "hybrid"])
def test_ipc_certified_sector_is_a_lower_bound_of_the_exact_sector(coords):
    """_physical: the certified sector (interval) is <= the exact one (50 digits), close to the
    float estimate, and both are reported."""
    from ipc_paper.certify_runs import _physical
    from ipc_paper.system import REFERENCE_BOX
    from ipc_paper.system.lyapunov import paper_lyapunov

    P = paper_lyapunov().P
    if coords == "hybrid":
        J = np.eye(4)
        J[0, 2] = 1.0
        P = J.T @ P @ J
    level = 2.28
    out = _physical(P, level, REFERENCE_BOX, 500, 0, coords)
    t, tf = out["sector_rad"], out["sector_float_rad"]
    assert 0.1 < t <= tf + 1e-12 and tf - t < 1e-7
    assert out["sector_deg"] <= float(np.degrees(t)) and out["sector_float_deg"] > 0
    with mp.workdps(50):
        for s in np.linspace(-t, t, 101):  # V <= level on the certified sector (necessary)
            assert _ipc_form_mp(P, level, s, coords) <= 0
        root = mp.findroot(lambda s: _ipc_form_mp(P, level, s, coords), mp.mpf(tf))
        assert t <= root < t + 1e-7
        assert mp.mpf(out["sector_deg"]) <= mp.degrees(mp.mpf(t))


def test_certified_sector_rejects_bad_input():
    from roa.proof._sector import certified_sector, degrees_lower, quadratic_form

    form = quadratic_form(np.eye(2))
    curve = lambda s, xp: (s, s)  # noqa: E731
    for kw in ({"level": np.nan}, {"t_max": 0.0}, {"t_max": np.inf}, {"pieces": 1}, {"tol": 0.0}):
        args = {"form": form, "level": 1.0, "curve": curve, "t_max": 1.0, **kw}
        with pytest.raises(RoaInputError):
            certified_sector(**args)
    with pytest.raises(RoaInputError):
        quadratic_form(np.ones((2, 3)))
    with pytest.raises(RoaInputError):
        degrees_lower(-1.0)
    assert (
        degrees_lower(np.pi)
        < 180.0
        <= float(np.nextafter(degrees_lower(np.pi), 200, dtype=float)) + 1e-12
    )


def test_interval_namespace_sector_matches_float_form():
    """quadratic_form gives the same function in the float and the interval namespace."""
    from roa.model._backend import NP
    from roa.proof._sector import quadratic_form

    P = np.array([[2.0, 0.3], [0.1, 1.0]])  # not symmetric: P_ij + P_ji = 0.4 (not a double)
    form = quadratic_form(P)
    x = np.array([0.7, -1.3])
    val = form(list(x), NP)
    iv = form([Interval(v) for v in x], INTERVAL)
    assert iv.lo <= val <= iv.hi
    exact = sum(
        Fraction(float(P[i, j])) * Fraction(x[i]) * Fraction(x[j])
        for i in range(2)
        for j in range(2)
    )
    assert iv.lo <= exact <= iv.hi


def test_jet_centring_is_decided_per_expression_not_by_process_history():
    """No process-global state: meeting a kink once no longer centres every later jet (box counts
    of a validation do not depend on what ran before it in the process)."""
    from roa.proof._jet import jabs, nonsmooth

    lo, hi = np.array([[-1.0, 0.5]]), np.array([[1.0, 2.0]])
    assert nonsmooth(lambda: jabs(Jet.variables(lo, hi)[0]))
    assert not nonsmooth(lambda: Jet.variables(lo, hi)[0] * 2.0 + 1.0)
    jabs(Jet.variables(lo, hi)[0])  # a kink outside any probe leaves no trace either
    assert all(x.c is None for x in Jet.variables(lo, hi, order=2))
    assert all(x.c is not None for x in Jet.variables(lo, hi, order=2, centred=True))
