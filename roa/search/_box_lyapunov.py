"""A quadratic V designed for a whole parameter box: common Lyapunov LMIs at points of the box.

For a system with uncertain parameters ``p`` in a box, the linearisation ``A(p)`` at the
equilibrium is computed (CasADi's exact AD, :func:`roa.model.jacobian`) at the box's
vertices and at ``per_axis`` interior points along each axis (:func:`roa.model._parameters.sample_points`,
nominal value included). One semidefinite program (cvxpy + Clarabel) then finds ``P`` with

    maximise t   subject to   A_i' P + P A_i <= -t I   (every point i),
                              P >= I,   trace(P) <= n * KAPPA

so ``P`` is positive definite with condition number at most ``n * KAPPA`` and ``t`` (> 0 when the
LMIs are feasible) is the decay margin of ``V = (x - x_eq)' P (x - x_eq)`` common to every point:
its robustness to the parameter values between the points. The constraints are homogeneous in
``(P, t)``: the result is scaled to ``trace(P) = n``, ``t`` with it.

**Claims and assumptions.** What this module states is only about the points it solved at, and
it re-checks them in numpy: the largest eigenvalue of ``A_i' P + P A_i`` is negative at every
point (``max_eig``; a solution failing it is returned with ``feasible=False``). When ``A(p)`` is
affine in ``p`` (``affine``: checked at the midpoints of the box's edges and at its centre, to
rounding), ``A(p)' P + P A(p)`` is affine in ``p`` too, so negativity at the vertices implies it on
the whole box (a convex combination of negative definite matrices). Otherwise nothing is claimed
between the points. Either way the result only *proposes* V: the local property at the
equilibrium says nothing about a level set, which the robust branch and bound (or the exact SOS
route) of :func:`roa.certify` decides for every parameter of the box.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.model._system import System
from roa.search._sdp import solve

#: Bound of the condition number of P per state (``trace(P) <= n * KAPPA``, ``P >= I``).
KAPPA = 100.0
#: Interior points along each parameter's axis, beside the vertices and the nominal point.
PER_AXIS = 3
#: Relative tolerance of the affinity check of ``A(p)``.
AFFINE_RTOL = 1e-9


@dataclass(frozen=True)
class BoxLyapunovResult:
    """The LMI's solution: ``P`` (None when the solver found none), the margin ``t``, the
    parameter ``points`` it was solved at, ``max_eig[i]`` the largest eigenvalue of
    ``A_i' P + P A_i`` recomputed in numpy, ``feasible`` (all of them < 0 and ``P`` positive
    definite), ``affine`` (whether ``A(p)`` was found affine in ``p``: then the vertices cover the
    box), the solver's ``status`` and a ``message``."""

    P: np.ndarray | None
    margin: float | None
    points: tuple[dict[str, float], ...]
    max_eig: tuple[float, ...]
    feasible: bool
    affine: bool
    status: str
    message: str
    seconds: float
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "P": None if self.P is None else self.P.tolist(),
            "margin": self.margin,
            "points": [dict(p) for p in self.points],
            "max_eig": list(self.max_eig),
            "feasible": self.feasible,
            "affine": self.affine,
            "status": self.status,
            "message": self.message,
            "seconds": self.seconds,
        }


def linearisations(system: System, points: list[dict[str, float]]) -> list[np.ndarray]:
    """``A(p)``, the Jacobian at the equilibrium, at each parameter point ``p``."""
    from roa.model._linearisation import jacobian

    return [jacobian(system.at(**p)) for p in points]


def is_affine(system: System) -> bool:
    """Whether ``A(p)`` is affine in ``p`` on the box, to rounding: ``A`` at the midpoint of each
    edge of the box through a vertex, and at the centre, equals the mean of ``A`` at the two
    (resp. all) vertices. A numerical check at those points (exact for the fields met in
    practice, whose entries are polynomials in ``p``: a non-affine one differs at a midpoint)."""
    from roa.model._parameters import ParameterBox

    box = ParameterBox.of(system)
    lo, hi = dict(zip(box.names, box.lo, strict=True)), dict(zip(box.names, box.hi, strict=True))
    checks: list[tuple[dict[str, float], list[dict[str, float]]]] = []
    for name in box.names:
        a, b = {**lo}, {**lo, name: hi[name]}
        checks.append(({**lo, name: 0.5 * lo[name] + 0.5 * hi[name]}, [a, b]))
        a, b = {**hi, name: lo[name]}, {**hi}
        checks.append(({**hi, name: 0.5 * lo[name] + 0.5 * hi[name]}, [a, b]))
    checks.append((box.midpoint, box.vertices()))
    for mid, ends in checks:
        A_mid = linearisations(system, [mid])[0]
        A_ends = linearisations(system, ends)
        mean = sum(A_ends) / len(A_ends)
        scale = max(1.0, float(np.abs(mean).max()))
        if float(np.abs(A_mid - mean).max()) > AFFINE_RTOL * scale:
            return False
    return True


def box_lyapunov(
    system: System, *, per_axis: int = PER_AXIS, kappa: float = KAPPA
) -> BoxLyapunovResult:
    """A common quadratic Lyapunov matrix ``P`` of the linearisations over the system's parameter
    box (module doc). Raises :class:`RoaInputError` when the system has no uncertain parameters
    or no equilibrium; an infeasible LMI (e.g. a point of the box where ``A`` is not Hurwitz, or
    no common ``P``) is a result with ``feasible=False``."""
    import cvxpy as cp

    from roa.model._parameters import sample_points

    t0 = time.perf_counter()
    if not system.parameters:
        raise RoaInputError(f"system {system.name!r} declares no uncertain parameters")
    if system.equilibrium is None:
        raise RoaInputError(f"system {system.name!r} has no equilibrium")
    if system.time != "continuous":
        raise RoaInputError(f"system {system.name!r} is discrete-time: these are the common "
                            "Lyapunov LMIs of flows (A'P + PA < 0)")  # fmt: skip
    if isinstance(per_axis, bool) or not isinstance(per_axis, int) or not 0 <= per_axis <= 50:
        raise RoaInputError(f"per_axis must be an integer in [0, 50], got {per_axis!r}")
    if not (np.isfinite(kappa) and kappa >= 1):
        raise RoaInputError(f"kappa must be a finite number >= 1, got {kappa!r}")
    points = sample_points(system, per_axis=per_axis)
    As = linearisations(system, points)
    affine = is_affine(system)
    n = system.n
    P = cp.Variable((n, n), symmetric=True)
    t = cp.Variable()
    eye = np.eye(n)
    cons = [P >> eye, cp.trace(P) <= n * kappa]
    for A in As:
        M = A.T @ P + P @ A
        cons.append(0.5 * (M + M.T) << -t * eye)
    prob = cp.Problem(cp.Maximize(t), cons)
    res = solve(prob)
    if res.status.startswith("solver error"):  # the solver gave up: no proposal
        return BoxLyapunovResult(None, None, tuple(points), (), False, affine, "solver_error",
                                 f"the LMI solver failed: {res.status}", time.perf_counter() - t0)  # fmt: skip
    status = res.status
    if P.value is None or t.value is None:
        return BoxLyapunovResult(None, None, tuple(points), (), False, affine, status,
                                 f"no common quadratic Lyapunov matrix (solver: {status})",
                                 time.perf_counter() - t0)  # fmt: skip
    # the LMIs are homogeneous in (P, t): report P scaled to trace(P) = n, t with it
    scale = n / float(np.trace(P.value))
    Pv = 0.5 * scale * (np.asarray(P.value, dtype=float) + np.asarray(P.value, dtype=float).T)
    tv = scale * float(t.value)
    eigs = tuple(float(np.linalg.eigvalsh(A.T @ Pv + Pv @ A)[-1]) for A in As)
    definite = bool(np.linalg.eigvalsh(Pv)[0] > 0)
    feasible = definite and max(eigs) < 0 and tv > 0
    from roa.model._parameters import describe_point

    worst = int(np.argmax(eigs))
    if feasible:
        where = (
            "every point of the box (A(p) affine in p)"
            if affine
            else (
                f"{len(points)} points of the box (A(p) not affine in p: nothing claimed between them)"
            )
        )
        message = (f"A'P + PA < 0 at {where}; largest eigenvalue {eigs[worst]:.4g} at "
                   f"{describe_point(points[worst])}; margin t = {tv:.4g}")  # fmt: skip
    else:
        message = (f"no common quadratic Lyapunov matrix: the LMI's solution has A'P + PA with "
                   f"eigenvalue {eigs[worst]:.4g} at {describe_point(points[worst])} "
                   f"(solver: {status}, margin {tv:.4g})")  # fmt: skip
    return BoxLyapunovResult(Pv, tv, tuple(points), eigs, feasible, affine, status,
                             message, time.perf_counter() - t0)  # fmt: skip
