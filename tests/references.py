"""Independent references shared by the tests (scipy and numpy only, no roa; not collected: no
``test_`` prefix): multistart SLSQP of ``min V s.t. V' = 0`` and complex-step gradients."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np
from scipy.optimize import minimize

#: The Van der Pol benchmark's V = x'Px.
VDP_P = np.array([[1.5, -0.5], [-0.5, 1.0]])


def complex_step_gradient(fun: Callable[[np.ndarray], np.ndarray], x: np.ndarray) -> np.ndarray:
    """The gradient of an analytic ``fun`` at ``x`` (``(n,)``), exact to rounding: ``fun`` takes
    ``(n, m)`` (one point per column) and returns ``(m,)``; one call for the ``n`` steps."""
    h = 1e-30
    return np.imag(fun(x[:, None] + 1j * h * np.eye(len(x)))) / h


def ring_slsqp(vdot, P: np.ndarray, starts: int = 60, vdot_grad=None) -> float:
    """min x'Px s.t. V'(x) = 0 on the ring |x| >= 0.3 (V' < 0 near 0) of a 2-state system,
    multistart SLSQP. ``vdot_grad``, when given, is the gradient of ``vdot`` (else SLSQP
    differences it)."""
    rng = np.random.default_rng(1)
    best = math.inf
    for _ in range(starts):
        x0 = rng.normal(size=2)
        x0 *= rng.uniform(0.5, 2.5) / np.linalg.norm(x0)
        r = minimize(lambda x: float(x @ P @ x), x0, method="SLSQP",
                     jac=lambda x: 2.0 * P @ x,
                     constraints=[{"type": "eq", "fun": vdot, "jac": vdot_grad},
                                  {"type": "ineq", "fun": lambda x: x @ x - 0.09,
                                   "jac": lambda x: 2.0 * x}],
                     options={"ftol": 1e-14, "maxiter": 500})  # fmt: skip
        if r.success and abs(vdot(r.x)) < 1e-9:
            best = min(best, float(r.x @ P @ r.x))
    return best


@functools.cache
def vdp_optimum(mu: float) -> float:
    """The largest level of the benchmark's V with V' < 0 for Van der Pol at ``mu``
    (x1' = -x2, x2' = x1 + mu (x1^2 - 1) x2), by :func:`ring_slsqp` with V's exact gradient."""

    def g(x: np.ndarray) -> np.ndarray:
        return np.array([-x[1], x[0] + mu * (x[0] ** 2 - 1) * x[1]])

    def vdot(x: np.ndarray) -> float:
        return float(2 * x @ VDP_P @ g(x))

    def vdot_grad(x: np.ndarray) -> np.ndarray:  # 2 (P g + J_g' P x)
        jg = np.array([[0.0, -1.0], [1 + 2 * mu * x[0] * x[1], mu * (x[0] ** 2 - 1)]])
        return 2 * (VDP_P @ g(x) + jg.T @ VDP_P @ x)

    return ring_slsqp(vdot, VDP_P, vdot_grad=vdot_grad)
