"""Combinations of the SOS engine's reductions and patterns (issue 34 item 2), each on a small
system against an independent optimum (scipy SLSQP multistart of ``min V s.t. V' = 0``, or a
closed form): the certified level is at most the optimum, and just above it a point with
``V' > 0`` (checked at 50 digits with mpmath) refutes any certificate; the exact route does not
certify there."""

from __future__ import annotations

import json
import math

import mpmath
import numpy as np
import pytest
from references import complex_step_gradient
from scipy import optimize

import roa
import roa.io
from roa.certification import Certificate
from roa.lyapunov import PolynomialLyapunov
from roa.proof._sos_check import exact_data
from roa.search._sos_program import choose_route, clique_pattern

N, A = 6, 0.5


def ring_field(x, a=A):
    return [-x[i] + a * x[(i + 1) % N] + x[i] ** 3 for i in range(N)]


def ring(a=A):
    return roa.System("ring-6", lambda t, x, xp: tuple(ring_field(x, a)), (0.0,) * N,
                      tuple(f"x{i}" for i in range(N)))  # fmt: skip


def optimum(V, grad, field, n, *, starts=24, seed=0):
    """``min V(x) s.t. V'(x) = grad V(x) . f(x) = 0, |x| > 0`` by SLSQP from ``starts`` random
    first crossings of ``V' >= 0`` along rays (the constraint divided by ``|x|^2``, so that the
    equilibrium is not a solution): the least value and its point. The constraint's gradient is
    taken by complex steps (exact to rounding: the fields and gradients are analytic)."""
    rng = np.random.default_rng(seed)

    def vdots(X):  # V' at the points whose components are the arrays X
        return sum(gi * fi for gi, fi in zip(grad(X), field(X), strict=True))

    def vdot(x):
        return float(np.dot(grad(x), field(list(x))))

    def con_jac(x):
        dvd = complex_step_gradient(lambda X: vdots(list(X)), x)
        s = float(x @ x)
        return dvd / s - vdot(x) * 2 * x / s**2

    best = (math.inf, None)
    for _ in range(starts):
        u = rng.normal(size=n)
        u /= np.linalg.norm(u)
        ts = np.linspace(1e-3, 5, 2000)
        vd = vdots(list(ts[None, :] * u[:, None]))  # V' along the ray
        if not (vd >= 0).any():
            continue
        hit = ts[np.argmax(vd >= 0)]
        res = optimize.minimize(V, hit * u, method="SLSQP", jac=lambda x: np.asarray(grad(x)),
                                constraints=[{"type": "eq", "jac": con_jac,
                                              "fun": lambda x: vdot(x) / float(x @ x)}],
                                options={"ftol": 1e-14, "maxiter": 500})  # fmt: skip
        if res.success and abs(vdot(res.x)) < 1e-9 and res.fun < best[0]:
            best = (float(res.fun), res.x)
    assert best[1] is not None
    return best


def refuted_above(V, grad, field, point, opt, factor=1.001):
    """The point of the optimum moved out along its ray to ``V = factor x opt`` (bisection on
    the ray), where ``V' > 0`` at 50 digits: no level at or above ``factor x opt`` holds."""
    lo, hi = 1.0, 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if V(mid * point) < factor * opt else (lo, mid)
    x = [mpmath.mpf(float(v)) for v in hi * point]
    with mpmath.workdps(50):
        g = grad(x)
        f = field(x)
        vd = sum(gi * fi for gi, fi in zip(g, f, strict=True))
    return bool(vd > 0), float(V(hi * point))


def quad(P):
    P = np.asarray(P, float)
    return (
        lambda x: float(np.asarray(x, float) @ P @ np.asarray(x, float)),
        lambda x: list(2 * P @ np.asarray(x)),  # numbers, arrays (one per component) or mpf
    )


def test_non_separable_V_on_the_sparse_route():
    """A coupled V (``P = I + 0.3 C``, ``C`` the 6-cycle's adjacency) on the ring: the clique
    program's cross blocks follow V's groups (here one: every variable), so the sparse route
    takes it; certified at 0.99 x the SLSQP optimum, and a point just above it refutes."""
    C = np.roll(np.eye(N), 1, axis=1)
    P = np.eye(N) + 0.3 * (C + C.T)
    system = ring()
    V = roa.QuadraticLyapunov(P, np.zeros(N))
    data = exact_data(system, V)
    p, why = clique_pattern(data)
    assert p is not None, why
    assert choose_route(data, route="sparse")[0] == "sparse"
    f, g = quad(P)
    opt, point = optimum(f, g, ring_field, N)
    cert = roa.certify(system, V, level=0.99 * opt, validator=roa.SosValidator(route="sparse"))
    assert cert.certified, cert.message
    assert cert.validation.meta["route"] == "sparse"
    assert cert.level <= opt
    # the stored certificate is re-checked without a solver; a cross block negated is refused
    stored = json.loads(roa.io.to_json(cert.to_dict()))
    assert Certificate.from_dict(stored, system).reverify().certified
    grams = stored["certificate"]["parts"][0]["grams"]
    cross = [g for g in grams if g["multiplies"] == 0][-1]  # (a piece of) the last cross block
    cross["Q"] = [[v[1:] if v.startswith("-") else f"-{v}" for v in row] for row in cross["Q"]]
    assert not Certificate.from_dict(stored, system).reverify().certified
    ok, at = refuted_above(f, g, ring_field, point, opt)
    assert ok and at == pytest.approx(1.001 * opt, rel=1e-9)
    above = roa.certify(system, V, level=1.001 * opt, validator=roa.SosValidator(route="sparse"))
    assert not above.certified


def quartic(n, w):
    """``V = |x|^2 + w sum x_i^4`` (value, gradient, and the roa V)."""
    basis = [tuple(k * (j == i) for j in range(n)) for k in (1, 2) for i in range(n)]
    V = PolynomialLyapunov.from_gram(basis, np.diag([1.0] * n + [w] * n), np.zeros(n))
    return (
        lambda x: float(sum(v * v + w * v**4 for v in np.asarray(x, float))),
        lambda x: [2 * v + 4 * w * v**3 for v in x],
        V,
    )


def small_ring_field(x, a=A):
    n = len(x)
    return [-x[i] + a * x[(i + 1) % n] + x[i] ** 3 for i in range(n)]


@pytest.mark.parametrize(
    "route",
    [pytest.param("dense", marks=pytest.mark.slow), "sparse",
     pytest.param("sdsos", marks=pytest.mark.slow)],
)  # fmt: skip
def test_degree_4_V_on_every_polynomial_route(route):
    """``V = |x|^2 + 0.5 sum x_i^4`` on a ring of 4 (two cliques of 3): each route certifies 0.99
    x the SLSQP optimum (the multiplier of V's degree; the sparse route's cross blocks through
    V's groups: one per variable, over ``{d_q, d_q^2}``); just above, a point refutes and the
    route does not certify."""
    n = 4
    system = roa.System("ring-4", lambda t, x, xp: tuple(small_ring_field(x)), (0.0,) * n,
                        tuple(f"x{i}" for i in range(n)))  # fmt: skip
    f, g, V = quartic(n, 0.5)
    opt, point = optimum(f, g, small_ring_field, n)
    val = roa.SosValidator(route=route)
    cert = roa.certify(system, V, level=0.99 * opt, validator=val)
    assert cert.certified, cert.message
    assert cert.validation.meta.get("route", "dense") == route
    ok, at = refuted_above(f, g, small_ring_field, point, opt)
    assert ok and at == pytest.approx(1.001 * opt, rel=1e-9)
    assert not roa.certify(system, V, level=1.001 * opt, validator=val).certified


def _sin(x):
    return mpmath.sin if isinstance(x[0], mpmath.mpf) else np.sin


def trig_field(x, sin, ring):
    """``x_i' = -x_i + a sin x_{i+1} + x_i^3`` on a ring of ``len(x)`` cells, or on a path (the
    last cell uncoupled)."""
    n = len(x)
    return [-x[i] + (A * sin(x[(i + 1) % n]) if ring or i + 1 < n else 0) + x[i] ** 3
            for i in range(n)]  # fmt: skip


def trig_ring_field(x):
    return trig_field(x, _sin(x), True)


def trig_path_field(x):
    return trig_field(x, _sin(x), False)


def _system(name, field, n):
    """The system of ``field`` (its ``sin`` from the system's namespace: sympy, intervals...)."""
    ring = field is trig_ring_field
    return roa.System(name, lambda t, x, xp: tuple(trig_field(x, xp.sin, ring)), (0.0,) * n,
                      tuple(f"x{i}" for i in range(n)))  # fmt: skip


def _certify_and_refute(system, V, f, g, field, opt, point, validator):
    """0.99 x ``opt`` certified by ``validator`` (the exact check), its stored certificate
    re-checked without a solver and refused with a Gram block negated; just above, a point with
    ``V' > 0`` at 50 digits refutes and the route does not certify."""
    cert = roa.certify(system, V, level=0.99 * opt, validator=validator)
    assert cert.certified, cert.message
    assert cert.level <= opt
    stored = json.loads(roa.io.to_json(cert.to_dict()))
    assert Certificate.from_dict(stored, system).reverify().certified
    grams = stored["certificate"]["parts"][0]["grams"]
    first = next(g for g in grams if g["multiplies"] == 0)
    first["Q"] = [[v[1:] if v.startswith("-") else f"-{v}" for v in row] for row in first["Q"]]
    assert not Certificate.from_dict(stored, system).reverify().certified
    ok, at = refuted_above(f, g, field, point, opt)
    assert ok and at == pytest.approx(1.001 * opt, rel=1e-9)
    assert not roa.certify(system, V, level=1.001 * opt, validator=validator).certified
    return cert


@pytest.mark.parametrize("route", [pytest.param("dense", marks=pytest.mark.slow), "sdsos"])
def test_degree_4_V_on_a_recast_field(route):
    """``V = |x|^2 + 0.5 sum x_i^4`` with a sin coupling (``x0' = -x0 + 0.5 sin x1 + x0^3``):
    the recast identity (``s``, ``q`` of the angle, the circle, the Taylor bounds) with the quartic
    V and a multiplier of its degree, dense and SDSOS: 0.99 x the SLSQP optimum certified and its
    stored certificate re-checked (a negated Gram block refused); just above, a point refutes."""
    n = 2
    system = _system("trig-path-2", trig_path_field, n)
    f, g, V = quartic(n, 0.5)
    opt, point = optimum(f, g, trig_path_field, n)
    cert = _certify_and_refute(system, V, f, g, trig_path_field, opt, point,
                               roa.SosValidator(route=route, fallback=False))  # fmt: skip
    assert "recast field" in cert.message


@pytest.mark.parametrize(
    "field, n, cliques",
    [(trig_path_field, 3, [4, 6]),
     pytest.param(trig_ring_field, 4, [9, 9], marks=pytest.mark.slow)],
)  # fmt: skip
def test_a_trig_field_on_the_sparse_route(field, n, cliques):
    """sin coupling (recast: per angle ``s``, ``q``, the circle and Taylor bounds) on sparse
    cliques: a path of 3 cells (fast) and a ring of 4 (about 25 s; the dense program takes about
    130 s). The cliques are those of the states' graph, each angle's ``s``, ``q`` with its
    state."""
    system = _system(f"trig-{n}", field, n)
    V = roa.QuadraticLyapunov(np.eye(n), np.zeros(n))
    f, g = quad(np.eye(n))
    opt, point = optimum(f, g, field, n)
    cert = _certify_and_refute(system, V, f, g, field, opt, point,
                               roa.SosValidator(route="sparse", fallback=False))  # fmt: skip
    meta = cert.validation.meta
    assert meta["route"] == "sparse" and meta["blocks"]["cliques"] == cliques
    assert "recast field" in cert.message


@pytest.mark.parametrize(
    "n, cliques", [(4, [4, 4]), pytest.param(6, [4, 4, 4, 4], marks=pytest.mark.slow)]
)
def test_a_parameter_box_on_the_sparse_route(n, cliques):
    """A ring of ``n`` with its coupling ``a`` in ``[0.4, 0.6]``: ``V'`` is affine in ``a``, so
    the box's optimum is the lower of the two ends' (SLSQP at each); the parameter joins every
    clique, and the box's multiplier gets one block per clique. With the multiplier of degree 4
    (``lambda`` depending on the parameter) 0.99 x the optimum is certified (the default degree
    2 reaches about 0.98 at ``n = 6``, on the dense route too)."""
    lo, hi = 0.4, 0.6
    system = roa.System(f"ring-{n}-box", lambda t, x, xp, p: tuple(small_ring_field(x, p.a)),
                        (0.0,) * n, tuple(f"x{i}" for i in range(n)),
                        parameters={"a": (lo, A, hi)})  # fmt: skip
    V = roa.QuadraticLyapunov(np.eye(n), np.zeros(n))
    f, g = quad(np.eye(n))
    ends = {a: optimum(f, g, lambda x, a=a: small_ring_field(x, a), n) for a in (lo, hi)}
    worst = min(ends, key=lambda a: ends[a][0])
    opt, point = ends[worst]
    assert worst == hi
    val = roa.SosValidator(route="sparse", fallback=False, multiplier_degree=4)
    cert = _certify_and_refute(system, V, f, g, lambda x: small_ring_field(x, worst), opt, point,
                               val)  # fmt: skip
    meta = cert.validation.meta
    assert meta["route"] == "sparse" and meta["blocks"]["cliques"] == cliques
    assert "for every a in [0.4, 0.6]" in cert.message


def pendulums_field(x):
    sin = _sin(x)
    return [x[1], -sin(x[0]) - x[1], x[3], -2 * sin(x[2]) - 0.5 * x[3]]


def test_independent_blocks_of_a_recast_field():
    """Two decoupled damped pendulums (sin: recast) with a block-diagonal V: the auto route
    takes the disconnected interaction graph's components as cliques (one per pendulum, its
    ``s``, ``q`` with it), so the level is the lower block's; 0.99 x the SLSQP optimum of the
    whole is certified, and just above a point refutes."""
    P1, P2 = np.array([[1.5, 0.5], [0.5, 1.0]]), np.array([[2.5, 0.25], [0.25, 1.0]])
    P = np.block([[P1, np.zeros((2, 2))], [np.zeros((2, 2)), P2]])
    system = roa.System("two-pendulums", lambda t, x, xp: (x[1], -xp.sin(x[0]) - x[1], x[3],
                                                           -2 * xp.sin(x[2]) - 0.5 * x[3]),
                        (0.0,) * 4, ("a1", "w1", "a2", "w2"))  # fmt: skip
    V = roa.QuadraticLyapunov(P, np.zeros(4))
    f, g = quad(P)
    opt, point = optimum(f, g, pendulums_field, 4)
    assert opt == pytest.approx(3.75801, rel=1e-4) and np.linalg.norm(point[:2]) < 1e-6
    cert = _certify_and_refute(system, V, f, g, pendulums_field, opt, point,
                               roa.SosValidator(fallback=False))  # fmt: skip
    meta = cert.validation.meta
    assert meta["route"] == "sparse" and "independent blocks" in meta["why_sparse"]
    assert meta["certificate"]["parts"][0]["cliques"] == [[0, 1, 4, 5], [2, 3, 6, 7]]


@pytest.mark.parametrize("route", [pytest.param("dense", marks=pytest.mark.slow), "sdsos"])
def test_every_pattern_on_a_recast_field_and_a_parameter_box(route):
    """The dense and the SDSOS patterns (the sparse one: above) on the trig path of 3 and on the
    ring of 4 over its box: 0.99 x the optimum certified (SDSOS: the largest block scaled
    diagonally dominant, proved by exact dominance), the stored certificate re-checked and
    refused when tampered, refuted just above."""
    n = 3
    system = _system("trig-3", trig_path_field, n)
    V = roa.QuadraticLyapunov(np.eye(n), np.zeros(n))
    f, g = quad(np.eye(n))
    opt, point = optimum(f, g, trig_path_field, n)
    val = roa.SosValidator(route=route, fallback=False)
    cert = _certify_and_refute(system, V, f, g, trig_path_field, opt, point, val)
    grams = cert.validation.meta["certificate"]["parts"][0]["grams"]
    assert any(g.get("cone") == "sdd" for g in grams) == (route == "sdsos")
    n = 4
    box = roa.System("ring-4-box", lambda t, x, xp, p: tuple(small_ring_field(x, p.a)),
                     (0.0,) * n, tuple(f"x{i}" for i in range(n)),
                     parameters={"a": (0.4, A, 0.6)})  # fmt: skip
    V = roa.QuadraticLyapunov(np.eye(n), np.zeros(n))
    f, g = quad(np.eye(n))
    opt, point = optimum(f, g, lambda x: small_ring_field(x, 0.6), n)
    val = roa.SosValidator(route=route, fallback=False, multiplier_degree=4)
    _certify_and_refute(box, V, f, g, lambda x: small_ring_field(x, 0.6), opt, point, val)
