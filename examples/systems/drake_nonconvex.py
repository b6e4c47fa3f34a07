"""Drake's non-convex region of attraction (``region_of_attraction_test.cc``, NonConvexROA), scaled.

``U(x) = |A1 x|^2 |A2 x|^2 / d`` with ``A1 = [[1, 2], [3, 4]]``, ``A2 = [[-1, 2], [-3, 4]]`` and
``x' = (U - 1) grad U``. With ``V = |x|^2``, ``V' = 2 x . grad U (U - 1) = 8 U (U - 1)`` (``U`` is
homogeneous of degree 4, so ``x . grad U = 4 U``): ``V'`` starts at degree 4 (a degenerate
equilibrium for the SOS program) and ``V' < 0`` exactly where ``0 < U < 1``. The largest level is
``rho = min |x|^2`` on ``{U = 1}`` ``= sqrt(d / max_{|u| = 1} |A1 u|^2 |A2 u|^2)``: 0.05 for
``d = 1`` and 0.5 for ``d = 100`` (the maximum on the unit circle is 400).
"""

import numpy as np

from roa import System

A1 = np.array([[1.0, 2.0], [3.0, 4.0]])
A2 = np.array([[-1.0, 2.0], [-3.0, 4.0]])


def make(d: float) -> System:
    """The system for the divisor ``d``."""

    def field(t, x, xp):
        a = [A1[0, 0] * x[0] + A1[0, 1] * x[1], A1[1, 0] * x[0] + A1[1, 1] * x[1]]
        b = [A2[0, 0] * x[0] + A2[0, 1] * x[1], A2[1, 0] * x[0] + A2[1, 1] * x[1]]
        p = a[0] * a[0] + a[1] * a[1]
        q = b[0] * b[0] + b[1] * b[1]
        U = p * q / d
        # grad U = (q grad p + p grad q) / d, grad p = 2 A1' a
        gp = [2 * (A1[0, 0] * a[0] + A1[1, 0] * a[1]), 2 * (A1[0, 1] * a[0] + A1[1, 1] * a[1])]
        gq = [2 * (A2[0, 0] * b[0] + A2[1, 0] * b[1]), 2 * (A2[0, 1] * b[0] + A2[1, 1] * b[1])]
        return tuple((U - 1) * (q * gp[i] + p * gq[i]) / d for i in range(2))

    return System(f"drake-nonconvex-d{d:g}", field, (0.0, 0.0), ("x", "y"),
                  lyapunov=((1.0, 0.0), (0.0, 1.0)))  # fmt: skip


D1 = make(1.0)
D100 = make(100.0)
SYSTEM = D1
