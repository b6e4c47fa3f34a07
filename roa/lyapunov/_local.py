"""V' < 0 near the equilibrium: the linearisation's decrease matrix, or small spheres when it is
degenerate (a sampled estimate there, not a proof)."""

from __future__ import annotations

import numpy as np

from roa.lyapunov._base import Lyapunov
from roa.model._linearisation import decrease_matrix, jacobian
from roa.model._system import System


def locally_negative(system: System, V: Lyapunov) -> tuple[bool, float]:
    """Whether V' < 0 near the equilibrium. Returns (ok, largest eigenvalue of A'P + PA).

    ``P`` is V's quadratic matrix (half the Hessian of V at the equilibrium for a general V). A'P + PA < 0
    decides it. When its largest eigenvalue is zero to rounding (a degenerate linearisation, e.g.
    a zero Jacobian, or a V without a definite quadratic part), higher-order terms decide: V' is
    then sampled on small spheres (an estimate, not a proof).
    """
    A = jacobian(system)
    Pq = V.quadratic_matrix()
    P = Pq if Pq is not None else 0.5 * V.hessian_at_center()
    Q = decrease_matrix(system, A, P)  # A'P + PA, or A'PA - P for a map
    lam = float(np.linalg.eigvalsh(0.5 * (Q + Q.T))[-1])
    scale = max(1.0, float(np.abs(Q).max()), float(np.abs(P).max()))
    definite = Pq is not None or bool(np.linalg.eigvalsh(P)[0] > 1e-10 * scale)
    if abs(lam) > 1e-10 * scale and definite:
        return lam < 0, lam
    rng = np.random.default_rng(0)
    Z = rng.standard_normal((4000, system.n))
    U = Z / np.linalg.norm(Z, axis=-1, keepdims=True)
    Linv_T = V.whitening()
    for r in (1e-2, 3e-3, 1e-3):
        X = V.center + (r * U) @ Linv_T.T
        with np.errstate(all="ignore"):
            vd = V.derivative(system, X)
        if not np.all(vd < 0):
            return False, lam
    return True, lam
