"""Shared base of the level-set search methods (:mod:`roa.levelset`): the problem and its witness.

Given a system with an equilibrium ``x0``, a quadratic candidate ``V`` centred on it and a *shape*
``s(x) = (x - x0)' S (x - x0)`` (``S`` positive definite), the largest level is::

    c* = sup { c > 0 : V'(x) < 0 for all x with 0 < s(x) <= c, x inside the system's domain }
       = inf { s(x) : x != x0, V'(x) >= 0 or x outside the domain }

Each method (:mod:`roa.levelset_sampled`, :mod:`roa.levelset_casadi`) returns a
:class:`LevelSetResult` whose witness lies on the boundary of the admissible set, moved exactly onto
``V' = 0`` along its ray by :func:`finish`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import linalg, optimize

from roa.errors import RoaInputError
from roa.linearisation import jacobian
from roa.lyapunov import QuadraticLyapunov, check_positive_definite
from roa.system import System

#: Relative agreement required between the two methods.
AGREEMENT_RTOL = 1e-4
#: A witness is accepted when |V'(witness)| is below this.
WITNESS_ATOL = 1e-8


@dataclass(frozen=True)
class LevelSetResult:
    """A largest level ``c*`` of the shape, with how it was found and a point that proves it tight."""

    value: float
    status: str
    method: str
    shape: str
    witness: np.ndarray | None
    vdot_witness: float | None
    witness_kind: str | None = None  # "vdot_zero" or "domain_boundary"
    details: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "value": float(self.value),
            "status": self.status,
            "method": self.method,
            "shape": self.shape,
            "witness": None if self.witness is None else self.witness.tolist(),
            "vdot_witness": self.vdot_witness,
            "witness_kind": self.witness_kind,
            **self.details,
        }


@dataclass(frozen=True)
class _Problem:
    system: System
    V: QuadraticLyapunov
    S: np.ndarray
    shape: str
    Linv_T: np.ndarray  # x = x0 + Linv_T @ y with |y|^2 = s(x)

    def vdot(self, X: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):
            return self.V.derivative(self.system, X)

    def bad(self, X: np.ndarray) -> np.ndarray:
        """Violation: V' >= 0, not finite, or outside the domain."""
        vd = self.vdot(X)
        out = ~(vd < 0)
        if self.system.margin is not None:
            out |= ~self.system.inside(X)
        return out

    def points(self, U: np.ndarray, r: np.ndarray) -> np.ndarray:
        """States at shape radius ``r`` (s = r^2) along unit directions ``U`` (broadcast)."""
        return self.V.center + (r[..., None] * U) @ self.Linv_T.T


def problem(system: System, V: QuadraticLyapunov, S: Any, shape: str) -> _Problem:
    S = check_positive_definite(S, what=f"shape {shape!r} matrix")
    if S.shape != V.P.shape:
        raise RoaInputError(f"shape matrix must be {V.P.shape}, got {S.shape}")
    if system.equilibrium is None:
        raise RoaInputError(f"system {system.name!r} has no equilibrium: no level-set search")
    if not np.allclose(system.x_eq, V.center):
        raise RoaInputError(
            f"V must be centred at the equilibrium of {system.name!r} {system.x_eq.tolist()}, "
            f"got center {V.center.tolist()}"
        )
    L = np.linalg.cholesky(S)  # S = L L'
    return _Problem(system, V, S, shape, np.linalg.inv(L.T))


def unit(Z: np.ndarray) -> np.ndarray:
    """Rows of ``Z`` scaled to unit Euclidean norm."""
    return Z / np.linalg.norm(Z, axis=-1, keepdims=True)


def locally_negative(system: System, V: QuadraticLyapunov) -> tuple[bool, float]:
    """Whether V' < 0 near the equilibrium. Returns (ok, largest eigenvalue of A'P + PA).

    A'P + PA < 0 decides it. When its largest eigenvalue is zero to rounding (a degenerate
    linearisation, e.g. a zero Jacobian), higher-order terms decide: V' is then sampled on small
    level sets of V (levels 1e-4 to 1e-6), which is an estimate, not a proof.
    """
    A = jacobian(system)
    Q = A.T @ V.P + V.P @ A
    lam = float(np.linalg.eigvalsh(0.5 * (Q + Q.T))[-1])
    scale = max(1.0, float(np.abs(Q).max()), float(np.abs(V.P).max()))
    if abs(lam) > 1e-10 * scale:
        return lam < 0, lam
    rng = np.random.default_rng(0)
    U = unit(rng.standard_normal((4000, system.n)))
    Linv_T = np.linalg.inv(np.linalg.cholesky(V.P).T)
    for r in (1e-2, 3e-3, 1e-3):
        X = V.center + (r * U) @ Linv_T.T
        with np.errstate(all="ignore"):
            vd = V.derivative(system, X)
        if not np.all(vd < 0):
            return False, lam
    return True, lam


def inner_level(P_outer: Any, level: float, S_inner: Any) -> float:
    """Largest c with {y'S y <= c} inside {y'P y <= level}: ``level / lambda_max(P, S)``."""
    lam = linalg.eigh(np.asarray(P_outer, float), np.asarray(S_inner, float), eigvals_only=True)
    return float(level / lam[-1])


def finish(prob: _Problem, x: np.ndarray, method: str, details: dict[str, Any]) -> LevelSetResult:
    """Put ``x`` exactly on V' = 0 along its ray (if it is a V' root), evaluate, wrap."""
    x = np.asarray(x, dtype=float)
    c = prob.V.center
    inside = prob.system.margin is None or bool(prob.system.inside(x))
    vd = float(prob.vdot(x))
    if inside and np.isfinite(vd):

        def g(t: float) -> float:
            return float(prob.vdot(c + t * (x - c)))

        for width in (1e-9, 1e-6, 1e-3):
            a, b = 1 - width, 1 + width
            if g(a) * g(b) < 0:
                t = optimize.brentq(g, a, b, xtol=1e-15, rtol=4 * np.finfo(float).eps)
                x = c + t * (x - c)
                vd = float(prob.vdot(x))
                break
    d = x - c
    value = float(d @ prob.S @ d)
    kind = (
        "vdot_zero"
        if inside and abs(vd) < WITNESS_ATOL
        else ("domain_boundary" if not inside else None)
    )
    status = "found" if kind is not None else "failed"
    return LevelSetResult(value, status, method, prob.shape, x, vd, kind, details)


