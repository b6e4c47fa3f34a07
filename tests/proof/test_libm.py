"""The libm assumption of the interval layer, measured: numpy's transcendental functions are within
``LIBM_ULPS`` ulps of the exact value (``roa.proof._interval`` widens their results by that much).

For every function the interval namespace evaluates with numpy (sin, cos, tan, exp, log, sqrt,
arctan, arcsinh, arctanh, tanh and log1p -- the network activations: tanh directly, sigmoid and
softplus as interval compositions of exp and log1p -- and power for ``Interval ** p``), numpy's result is compared with a
50-digit mpmath value on many points: random points of every magnitude, near the poles of tan and
the zeros of sin/cos, huge arguments (1e15 ... 1.7e308, the classic hard case of argument
reduction), tiny and subnormal arguments, values next to 1 for log, next to +-1 for arctanh, next
to the overflow and underflow thresholds of exp. numpy may use different code paths (SIMD loops
for contiguous arrays, scalar loops for strided ones, scalar calls for 0-d values); each point is
evaluated in all three ways. The error is ``|numpy - exact| / ulp(exact)`` with
``ulp(y) = 2^(floor(log2 |y|) - 52)`` (``2^-1074`` in the subnormal range). Points where the
exact value overflows the double range are skipped (the interval layer gives no finite bound
there). sqrt is correctly rounded (IEEE); the interval layer assumes 1 ulp for it.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

from roa.proof._interval import INTERVAL, LIBM_ULPS, TRIG_ARGUMENT_LIMIT, Interval

DIGITS = 50
_MAX = np.finfo(float).max
_rng = np.random.default_rng(20260115)


def _near(values, k: int = 3) -> np.ndarray:
    """The floats ``values`` and their ``k`` neighbours on each side."""
    v = np.asarray(values, dtype=float)
    out = [v]
    lo, hi = v.copy(), v.copy()
    with np.errstate(over="ignore"):
        for _ in range(k):
            lo, hi = np.nextafter(lo, -np.inf), np.nextafter(hi, np.inf)
            out += [lo, hi]
    out = np.concatenate(out)
    return out[np.isfinite(out)]


def _log_uniform(n: int, lo_exp: float, hi_exp: float, signed: bool = True) -> np.ndarray:
    x = 10.0 ** _rng.uniform(lo_exp, hi_exp, n)
    return x * _rng.choice([-1.0, 1.0], n) if signed else x


_HUGE = np.array(
    [
        1e15,
        1e16,
        1e22,
        1e50,
        1e100,
        1e200,
        1e300,
        1.7e308,
        _MAX,
        2.0**1023,
        6381956970095103 * 2.0**797,
    ]
)
_TINY = np.array([5e-324, 1e-320, 2.0**-1022, 1e-300, 1e-200, 1e-100, 1e-20, 1e-8, 1.5e-8])


def _half_pi_multiples() -> np.ndarray:
    """The doubles nearest to k pi/2 (zeros of sin/cos, poles of tan; 60-digit rounding), for
    small k, random k up to the trig limit, and powers of two: the hard argument reductions."""
    k = [*range(-200, 201), *(2**j for j in range(1, 40)), *_rng.integers(1, 2**39, 300).tolist()]
    with mp.workdps(60):
        return np.array([float(mp.mpf(int(j)) * mp.pi / 2) for j in k])


def _trig_points() -> np.ndarray:
    return np.concatenate(
        [
            _near(_half_pi_multiples(), 2),
            _near([TRIG_ARGUMENT_LIMIT, 1e12, 1e11, 1e9, 12345678.9], 2),
            _near(np.concatenate([_HUGE, -_HUGE, _TINY, -_TINY]), 2),
            _rng.uniform(-10, 10, 3000),
            _log_uniform(3000, -30, 308),
            [0.0, -0.0],
        ]
    )


def _points(name: str) -> np.ndarray:
    if name in ("sin", "cos", "tan"):
        return _trig_points()
    if name == "exp":
        edges = [
            709.782712893384,
            709.78,
            709.0,
            -708.39641853226408,
            -708.4,
            -730.0,
            -744.44,
            -745.13,
        ]
        ln2k = np.arange(-1074, 1024) * np.log(2.0)
        return np.concatenate(
            [
                _near(edges, 3),
                _near(ln2k[::7], 1),
                _rng.uniform(-745, 709.7, 3000),
                _log_uniform(2000, -320, 2.8),
                _near(_TINY, 2),
                _near(-_TINY, 2),
                [0.0],
            ]
        )
    if name == "log":
        one = np.array([1.0])
        near_one = np.array(
            [1.0 + j * 2.0**-52 for j in (1, 2, 3, 10, 1000, 10**6)]
            + [1.0 - j * 2.0**-53 for j in (1, 2, 3, 10, 1000, 10**6)]
        )
        return np.concatenate(
            [
                _near(np.concatenate([one, near_one, [np.e, 2.0, 0.5, 10.0]]), 3),
                1.0 + _rng.uniform(-1e-3, 1e-3, 1500),
                _log_uniform(3000, -323, 308, signed=False),
                _near(np.concatenate([_TINY, _HUGE]), 2),
            ]
        )
    if name == "sqrt":
        return np.concatenate(
            [
                _log_uniform(4000, -323, 308, signed=False),
                _near(np.concatenate([_TINY, _HUGE, [1.0, 2.0, 4.0]]), 2),
                [0.0],
            ]
        )
    if name == "arctan":
        return np.concatenate(
            [
                _log_uniform(3000, -320, 308),
                _rng.uniform(-5, 5, 2000),
                _near(np.concatenate([_TINY, _HUGE, [1.0, -1.0, 0.5, 2.0]]), 2),
                [0.0],
            ]
        )
    if name == "arcsinh":
        return np.concatenate(
            [
                _log_uniform(3000, -320, 308),
                _rng.uniform(-5, 5, 2000),
                _near(np.concatenate([_TINY, -_TINY, _HUGE, -_HUGE, [1.0, -1.0, 0.5]]), 2),
                [0.0],
            ]
        )
    if name == "arctanh":
        edge = np.array([1.0 - j * 2.0**-53 for j in (1, 2, 3, 10, 1000)] + [0.5, 0.9, 0.99, 1e-8])
        return np.concatenate(
            [
                _rng.uniform(-1, 1, 3000),
                _log_uniform(2000, -320, -1e-9),
                _near(np.concatenate([edge, -edge, _TINY, -_TINY]), 2),
                [0.0],
            ]
        )
    if name == "tanh":  # tanh(x) rounds to +-1 from |x| ~ 19.06 on
        return np.concatenate(
            [
                _log_uniform(3000, -320, 308),
                _rng.uniform(-25, 25, 3000),
                _near(np.concatenate([_TINY, -_TINY, [0.5, 1.0, 19.06, 20.0, 0.55, 0.549306]]), 3),
                _near(-np.array([0.5, 1.0, 19.06, 20.0]), 3),
                [0.0],
            ]
        )
    if name == "log1p":
        near_minus_one = np.array([-1.0 + j * 2.0**-53 for j in (1, 2, 3, 10, 1000, 10**6)])
        return np.concatenate(
            [
                _log_uniform(3000, -320, 308, signed=False),
                -_log_uniform(2000, -320, -1e-12, signed=False),
                _rng.uniform(-1, 1, 2000),
                _near(np.concatenate([near_minus_one, _TINY, -_TINY, [1.0, np.e - 1, 1e-8]]), 3),
                [0.0],
            ]
        )
    raise AssertionError(name)


_FUNCTIONS = {
    "sin": (np.sin, mp.sin),
    "cos": (np.cos, mp.cos),
    "tan": (np.tan, mp.tan),
    "exp": (np.exp, mp.exp),
    "log": (np.log, mp.log),
    "sqrt": (np.sqrt, mp.sqrt),
    "arctan": (np.arctan, mp.atan),
    "arcsinh": (np.arcsinh, mp.asinh),
    "arctanh": (np.arctanh, mp.atanh),
    "tanh": (np.tanh, mp.tanh),
    "log1p": (np.log1p, mp.log1p),
}
#: The error bound the interval layer assumes (ulps): sqrt is an IEEE operation (1 ulp assumed,
#: 1/2 guaranteed), everything else LIBM_ULPS.
ASSUMED = {name: (1.0 if name == "sqrt" else float(LIBM_ULPS)) for name in [*_FUNCTIONS, "power"]}


def _ulps(computed: float, exact: mp.mpf) -> float:
    """``|computed - exact|`` in ulps of ``exact``; NaN where ``exact`` leaves the double range."""
    if mp.isinf(exact) or abs(exact) > _MAX:
        return float("nan")
    if exact == 0:
        return 0.0 if computed == 0 else float("inf")
    if not np.isfinite(computed):
        return float("inf")
    e = int(mp.frexp(exact)[1]) - 1  # 2^e <= |exact| < 2^(e+1)
    ulp = mp.ldexp(1, max(e - 52, -1074))
    return float(abs(mp.mpf(computed) - exact) / ulp)


def _numpy_three_ways(fn, x: np.ndarray, *args) -> list[np.ndarray]:
    """Contiguous array, strided array, and one 0-d call per point."""
    with np.errstate(all="ignore"):
        contiguous = fn(np.ascontiguousarray(x), *args)
        buf = np.empty(2 * len(x))
        buf[::2] = x
        strided = fn(buf[::2], *args)
        scalar = np.array([fn(np.float64(v), *args) for v in x])
    return [contiguous, strided, scalar]


def measure(name: str) -> tuple[np.ndarray, np.ndarray]:
    """The test points of numpy's ``name`` and the error (ulps) at each, worst of the three ways."""
    fn, ref = _FUNCTIONS[name]
    x = _points(name)
    worst = np.zeros(len(x))
    with mp.workdps(DIGITS):
        exact = [ref(mp.mpf(float(v))) for v in x]
        for values in _numpy_three_ways(fn, x):
            for i, (c, y) in enumerate(zip(values, exact, strict=True)):
                if isinstance(y, mp.mpc):  # outside the real domain (not reached by the points)
                    continue
                err = _ulps(float(c), y)
                if not err <= worst[i]:  # NaN (overflow) stays NaN
                    worst[i] = err
    return x, worst


def _worst(x: np.ndarray, err: np.ndarray) -> tuple[float, float]:
    if not np.any(np.isfinite(err) | np.isinf(err)):
        return 0.0, float("nan")
    k = int(np.nanargmax(err))
    return float(err[k]), float(x[k])


_POWERS = [3, 5, 7, 9, 0.5, -0.5, 1.5, -1.5, 2.5, 0.1, 1.0 / 3.0, 2.0 / 3.0]


def measure_power() -> tuple[float, tuple[float, float]]:
    """Largest error (ulps) of ``x ** p`` for the exponents the interval layer uses."""
    worst, at = 0.0, (float("nan"), float("nan"))
    base = np.concatenate(
        [
            _log_uniform(600, -30, 30, signed=False),
            _rng.uniform(0, 4, 400),
            _near(np.array([1.0, 2.0, 0.5, 10.0, 1e-8, 1e8]), 2),
        ]
    )
    with mp.workdps(DIGITS):
        for p in _POWERS:
            x = np.concatenate([base, -base]) if isinstance(p, int) else base
            exact = [mp.power(mp.mpf(float(v)), p if isinstance(p, int) else mp.mpf(p)) for v in x]
            for values in _numpy_three_ways(np.power, x, p):
                for v, c, y in zip(x, values, exact, strict=True):
                    err = _ulps(float(c), y)
                    if err > worst:
                        worst, at = err, (float(v), p)
    return worst, at


@pytest.mark.parametrize("name", list(_FUNCTIONS))
def test_numpy_function_within_assumed_ulps(name):
    x, err = measure(name)
    used = np.ones(len(x), dtype=bool)
    if name in ("sin", "cos", "tan"):
        # beyond TRIG_ARGUMENT_LIMIT the interval layer does not use numpy's values: check that
        used = np.abs(x) <= TRIG_ARGUMENT_LIMIT
        far = Interval(x[~used])
        enc = getattr(INTERVAL, name)(far)
        full = (-1.0, 1.0) if name != "tan" else (-np.inf, np.inf)
        assert np.all(enc.lo == full[0]) and np.all(enc.hi == full[1])
        w, at = _worst(x[~used], err[~used])
        print(f"{name}: beyond |x| > 2^40 (not used) max error {w:.3f} ulps (at x = {at!r})")
    worst, at = _worst(x[used], err[used])
    print(f"{name}: max error {worst:.3f} ulps (at x = {at!r}) on {int(used.sum())} points")
    assert worst <= ASSUMED[name], f"numpy {name} is off by {worst:.3f} ulps at x = {at!r}"


def test_numpy_power_within_assumed_ulps():
    worst, at = measure_power()
    print(f"power: max error {worst:.3f} ulps (at x, p = {at!r})")
    assert worst <= ASSUMED["power"], f"numpy power is off by {worst:.3f} ulps at x, p = {at!r}"


def test_ulp_measure_itself():
    with mp.workdps(DIGITS):
        assert _ulps(1.0, mp.mpf(1)) == 0.0
        assert _ulps(float(np.nextafter(1.0, 2.0)), mp.mpf(1)) == 1.0
        assert _ulps(5e-324, mp.mpf(0)) == float("inf")
        assert _ulps(1e-323, mp.mpf(5e-324)) == 1.0  # subnormal spacing
        assert np.isnan(_ulps(float("inf"), mp.exp(1000)))
        assert _ulps(0.1, mp.mpf(1) / 10) < 0.5  # correctly rounded
