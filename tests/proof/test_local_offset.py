"""The local proof near an equilibrium that the field's rounded constants move by O(ulp)
(issue: a user-written field with float constants loses its local proof).

The two-machine power system as a user writes it, ``x2' = -0.5 x2 - (sin(x1 + pi/3) -
math.sin(pi/3))`` with ``math.pi``: 0 at the origin in floats, but with its constants taken as the
exact rationals they are its zero is ``O(1e-16)`` away, so ``f(x_eq) = 0`` is not exact and the
interval enclosure of ``f(0)`` is a small interval around 0. The local proof is then the
contraction argument of :mod:`roa.proof._local` (3.), whose claim is convergence to the field's
unique zero near ``x_eq``: the tests check the certified and refuted levels around the optimum
``rho* = 1.0410816`` (an earlier release; recomputed here along rays, independently of the code
under test) and that the true zero (50-digit mpmath) lies within the reported radius.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

import roa
from roa.lyapunov import QuadraticLyapunov
from roa.proof._local import contraction_box, local_box
from roa.proof._validate import validate_level
from roa.search._rays import ray_box

P_POWER = [[2.0, 1.0], [1.0, 3.0]]
RHO_POWER = 1.0410816  # the earlier release's optimum of V = x' P x for this field


def _power_field(t, x, xp):  # as a user writes it: math.pi and math.sin are doubles
    x1, x2 = x[0], x[1]
    return (x2, -0.5 * x2 - (xp.sin(x1 + math.pi / 3) - math.sin(math.pi / 3)))


def _power() -> roa.System:
    return roa.System(name="power-as-written", field=_power_field, equilibrium=(0.0, 0.0),
                      state_names=("x1", "x2"), lyapunov=P_POWER)  # fmt: skip


def _optimum_along_rays() -> float:
    """min V on {V' = 0} minus the origin, numpy only: along each ray the first sign change of
    V' (grid of radii, then bisection) and V there; 2000 directions, then 2000 more within one
    step of the best."""
    P = np.array(P_POWER)

    def vdot(x):
        f = np.stack([x[..., 1], -0.5 * x[..., 1] - (np.sin(x[..., 0] + np.pi / 3)
                                                     - np.sin(np.pi / 3))], axis=-1)  # fmt: skip
        return 2 * np.einsum("...i,ij,...j->...", x, P, f)

    def first_zero(th):
        u = np.stack([np.cos(th), np.sin(th)], axis=1)
        r = np.linspace(1e-3, 3.0, 1500)
        vd = vdot(r[None, :, None] * u[:, None, :])
        up = np.argmax(vd >= 0, axis=1)  # rays that never reach V' >= 0 give index 0: dropped
        keep = up > 0
        u, lo, hi = u[keep], r[up[keep] - 1], r[up[keep]]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            neg = vdot(mid[:, None] * u) < 0
            lo, hi = np.where(neg, mid, lo), np.where(neg, hi, mid)
        values = hi**2 * np.einsum("ki,ij,kj->k", u, P, u)
        k = int(np.argmin(values))
        return float(values[k]), float(np.arctan2(u[k, 1], u[k, 0]))

    step = 2 * np.pi / 2000
    _, th = first_zero(np.arange(2000) * step)
    best, _ = first_zero(np.linspace(th - step, th + step, 2001))
    return best


def test_the_optimum_along_rays_is_the_earlier_release_one():
    assert _optimum_along_rays() == pytest.approx(RHO_POWER, rel=1e-7)


def test_the_field_as_written_is_certified_below_its_optimum_and_refuted_above():
    system = _power()
    V = roa.default_lyapunov(system)
    np.testing.assert_array_equal(V.P, P_POWER)
    cert = roa.certify(system, V, level=0.995 * RHO_POWER, validator="interval")
    assert cert.status == "certified", cert.message
    meta = cert.validation.meta
    assert meta["local_proof"] == "contraction (f(x_eq) enclosed)"
    assert "not proved 0" in cert.message
    above = roa.certify(system, V, level=1.001 * RHO_POWER, validator="interval")
    assert above.status == "refuted" and above.validation.witness_check["confirmed"]


def test_the_true_zero_lies_within_the_reported_radius():
    """The zero of the field with its doubles as exact rationals: x2 = 0 and
    sin(x1 + c) = s, c = fl(pi/3), s = fl(sin(pi/3)); 50 digits."""
    system = _power()
    v = validate_level(
        system, roa.default_lyapunov(system), 0.995 * RHO_POWER, cover_estimate=ray_box
    )
    assert v.status == "certified"
    with mpmath.workdps(50):
        c, s = mpmath.mpf(math.pi / 3), mpmath.mpf(math.sin(math.pi / 3))  # exact: binary
        offset = abs(mpmath.asin(s) - c)
    assert 0 < offset < 1e-15  # not x_eq: the Hessian argument's premise fails
    radius = v.meta["equilibrium_radius"]
    assert offset <= radius < 1e-10


def _linear(shift: float, A) -> roa.System:
    A = np.asarray(A, dtype=float)

    def field(t, x, xp):
        return tuple(sum(float(A[i, j]) * (x[j] - shift) for j in range(2)) for i in range(2))

    return roa.System(name="linear", field=field, equilibrium=(0.0, 0.0), state_names=("a", "b"))


def test_contraction_box_refuses_a_point_proved_not_an_equilibrium():
    """x' = -(x - e), e = 1e-13: f(0) = (1e-13, 1e-13) is enclosed away from 0, so x_eq is
    proved not to be an equilibrium and no claim is made about it."""
    system = _linear(1e-13, -np.eye(2))
    V = QuadraticLyapunov(np.eye(2), [0.0, 0.0])
    assert contraction_box(system, V, -np.ones(2), np.ones(2)) is None


def test_contraction_box_bounds_the_offset_of_a_rounded_constant():
    """x_i' = -x_i + sin(x_i + pi) - math.sin(math.pi) (doubles): 0 at the origin in floats, its
    zero at x_i = t with -t + sin(t + c) = s (c = fl(pi), s = fl(sin(c))), |t| ~ 1e-32 (50-digit
    mpmath). The Jacobian is -1 + cos(x_i + pi) ~ -2 I, so with P = I the rate proved is half of
    4: mu = 2 (to 1e-6 on the box), and the reported radius bounds |(t, t)|."""

    def field(t, x, xp):
        return tuple(-x[i] + xp.sin(x[i] + math.pi) - math.sin(math.pi) for i in range(2))

    system = roa.System(name="rounded", field=field, equilibrium=(0.0, 0.0),
                        state_names=("a", "b"))  # fmt: skip
    V = QuadraticLyapunov(np.eye(2), [0.0, 0.0])
    found = contraction_box(system, V, -np.ones(2), np.ones(2))
    assert found is not None
    lo, hi, info = found
    np.testing.assert_array_equal(hi, -lo)
    assert info["contraction_rate"] == pytest.approx(2.0, rel=0.5)
    with mpmath.workdps(60):
        c, s = mpmath.mpf(math.pi), mpmath.mpf(math.sin(math.pi))  # the doubles, exactly
        t = mpmath.findroot(lambda u: -u + mpmath.sin(u + c) - s, mpmath.mpf(0))
    assert 0 < abs(t) < 1e-30
    assert float(abs(t)) * math.sqrt(2) <= info["equilibrium_radius"] < 1e-12


def test_contraction_box_refuses_a_candidate_that_does_not_contract():
    """A = [[0, 1], [-1, -1]], P = I: P A + A'P = diag(0, -2) is not negative definite."""
    system = _linear(0.0, [[0.0, 1.0], [-1.0, -1.0]])
    V = QuadraticLyapunov(np.eye(2), [0.0, 0.0])
    assert contraction_box(system, V, -np.ones(2), np.ones(2)) is None


def test_the_exact_example_keeps_its_hessian_proof():
    """examples/power_system.py writes the sines exactly (sympy): f(x_eq) = 0 and the Hessian
    argument proves the local box, as before."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parents[2] / "examples"))
    try:
        from power_system import power_system
    finally:
        sys.path.pop(0)
    system = power_system()
    V = QuadraticLyapunov.for_system(system, P_POWER)
    found = local_box(system, V, -np.ones(2), np.ones(2))
    assert found is not None and found[2]["local_proof"] == "hessian"
