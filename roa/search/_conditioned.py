"""The best-conditioned quadratic Lyapunov candidate of a linearisation.

For ``V = d' P d`` and the linearisation ``A`` at the equilibrium, ``V' = -d' Q d + O(|d|^3)``
with ``Q = -(A'P + PA)``. In the whitened frame ``y = P^(1/2) d`` (where the interval branch and
bound cuts its boxes) the quadratic part of ``-V'`` is ``y' H y`` with ``H = P^(-1/2) Q P^(-1/2)``;
its condition number ``kappa = lambda_max(H) / lambda_min(H)`` measures how unevenly V decreases
around its level sets. A box's enclosure of ``V'`` is loose by about the largest rate times its
width, while the decrease it must show is the smallest rate times ``|y|^2``: a large ``kappa``
forces small boxes everywhere. ``A'P + PA = -I`` ignores this; :func:`conditioned_lyapunov`
minimises it.

Program: ``t P <= Q(P) <= kappa t P`` with ``P >= I`` is a linear matrix inequality in ``P`` for a
fixed decay rate ``t`` and ``kappa``; ``kappa`` is bisected (log scale) at each rate of a grid
over ``(0, 2 alpha)``, ``alpha`` the stability margin of ``A`` (no rate beyond ``2 alpha`` is
feasible), then at rates of a golden-section search around the best. The result is a
candidate like any other: its level is searched and certified by the same calls.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import QuadraticLyapunov
from roa.model._system import System


def condition_number(A: np.ndarray, P: np.ndarray) -> float:
    """``lambda_max / lambda_min`` of ``-P^(-1/2) (A'P + PA) P^(-1/2)`` (inf when that matrix is
    not positive definite)."""
    Li = np.linalg.inv(np.linalg.cholesky(P))
    H = -Li @ (A.T @ P + P @ A) @ Li.T
    e = np.linalg.eigvalsh(0.5 * (H + H.T))
    return float(e[-1] / e[0]) if e[0] > 0 else float("inf")


class _Program:
    """``P >= I`` with ``r P <= Q(P) <= s P`` (``r``, ``s`` parameters: compiled once)."""

    def __init__(self, A: np.ndarray) -> None:
        import cvxpy as cp

        n = len(A)
        self.P = cp.Variable((n, n), symmetric=True)
        self.r, self.s = cp.Parameter(nonneg=True), cp.Parameter(nonneg=True)
        Q = -(A.T @ self.P + self.P @ A)
        cons = [self.P >> np.eye(n), Q - self.r * self.P >> 0, self.s * self.P - Q >> 0]
        self.problem = cp.Problem(cp.Minimize(cp.trace(self.P)), cons)

    def __call__(self, rate: float, kappa: float) -> np.ndarray | None:
        """``P`` of decay rate ``rate`` and condition number at most ``kappa``, or None."""
        from roa.search._sdp import solve

        self.r.value, self.s.value = rate, kappa * rate
        res = solve(self.problem)
        if res.group != "optimal" or self.P.value is None:
            return None
        P = 0.5 * (self.P.value + self.P.value.T)
        return P if np.linalg.eigvalsh(P)[0] > 0 else None


def best_conditioned(A: Any, *, rates: int = 8, steps: int = 14) -> tuple[np.ndarray, float]:
    """``(P, kappa)``: the ``P`` (trace ``n``) of least :func:`condition_number` found by the
    module's program for the Hurwitz matrix ``A`` (a grid of ``rates`` decay rates, then a
    golden-section search of the rate around the best; ``steps`` bisections of ``kappa`` each);
    RoaInputError when ``A`` is not Hurwitz."""
    A = np.asarray(A, dtype=float)
    if A.ndim != 2 or A.shape[0] != A.shape[1] or not np.all(np.isfinite(A)):
        raise RoaInputError(f"A must be a finite square matrix, got shape {A.shape}")
    alpha = -float(np.max(np.linalg.eigvals(A).real))
    if not alpha > 0:
        raise RoaInputError(
            f"the linearisation is not exponentially stable (largest real part {-alpha:.3g} >= 0):"
            " no quadratic Lyapunov function"
        )
    feasible = _Program(A)
    found: dict[float, tuple[float, np.ndarray | None]] = {}

    def at(rate: float) -> float:
        """The least kappa (bisected) at this decay rate (inf when none is feasible)."""
        if rate not in found:
            lo, hi = 1.0, 1e6
            P = feasible(rate, hi)
            if P is not None:
                for _ in range(steps):
                    mid = float(np.sqrt(lo * hi))
                    Q = feasible(rate, mid)
                    lo, hi, P = (lo, mid, Q) if Q is not None else (mid, hi, P)
            found[rate] = (condition_number(A, P), P) if P is not None else (np.inf, None)
        return found[rate][0]

    width = 2 * alpha / (rates + 1)
    grid = width * np.arange(1, rates + 1)
    best = float(grid[int(np.argmin([at(float(r)) for r in grid]))])
    a, b = max(best - width, 1e-3 * alpha), min(best + width, 1.999 * alpha)
    g = (np.sqrt(5) - 1) / 2
    for _ in range(12):  # golden section on the rate
        c, d = b - g * (b - a), a + g * (b - a)
        a, b = (a, d) if at(c) <= at(d) else (c, b)
    kappa, P = min(found.values(), key=lambda kp: kp[0])
    if P is None:
        raise RoaInputError("no well-conditioned P found (the LMIs were not solved)")
    return P * (len(A) / np.trace(P)), kappa  # kappa does not depend on P's scale


def conditioned_lyapunov(system: System) -> QuadraticLyapunov:
    """The best-conditioned quadratic candidate of a continuous-time ``system`` (module doc):
    ``V = (x - x_eq)' P (x - x_eq)`` with ``P`` minimising the condition number of the
    linearised decrease in V's whitened frame. A candidate only: certify its level as any V's.

    Examples
    --------
    >>> import roa
    >>> from roa.search import conditioned_lyapunov
    >>> from roa.systems.vanderpol import vanderpol
    >>> V = conditioned_lyapunov(vanderpol())
    >>> V.name.startswith("conditioned V")
    True
    """
    from roa.model._linearisation import jacobian

    if system.equilibrium is None:
        raise RoaInputError(f"system {system.name!r} has no equilibrium: no Lyapunov candidate")
    if system.time == "discrete":
        raise RoaInputError(
            f"system {system.name!r} is a map: conditioned_lyapunov is for flows (use "
            "roa.default_lyapunov, A'PA - P = -I)"
        )
    P, kappa = best_conditioned(jacobian(system))
    return QuadraticLyapunov(
        P, np.asarray(system.x_eq, float), f"conditioned V (kappa {kappa:.3g})"
    )
