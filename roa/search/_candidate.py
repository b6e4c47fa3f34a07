"""The candidate an analysis uses: the caller's V, a matrix, or the system's default quadratic V."""

from __future__ import annotations

from typing import Any

from roa.errors import RoaInputError
from roa.lyapunov._base import Lyapunov
from roa.lyapunov._polynomial import QuadraticLyapunov
from roa.model._system import System


def as_lyapunov(system: System, V: Any = None) -> Lyapunov:
    """``V`` as a Lyapunov candidate of ``system``: ``None`` (the default candidate), any
    :class:`Lyapunov` (e.g. ``QuadraticLyapunov``, ``PolynomialLyapunov``, ``FunctionLyapunov``),
    or an n x n matrix ``P``."""
    if V is None:
        return default_lyapunov(system)
    if isinstance(V, Lyapunov):
        if V.n != system.n:
            raise RoaInputError(f"V has {V.n} states, system {system.name!r} has {system.n}")
        return V
    return QuadraticLyapunov.for_system(system, V, name="P")


def default_lyapunov(system: System) -> QuadraticLyapunov:
    """The quadratic Lyapunov candidate of a system.

    ``system.lyapunov`` when the system comes with one (a paper's or a benchmark's matrix, or the
    Riccati solution ``S`` of a loop built by :meth:`roa.System.from_control` from
    ``control.lqr``), else
    ``P`` solving ``A'P + PA = -I`` for the linearisation ``A`` at the equilibrium
    (``A'PA - P = -I`` for a discrete-time system ``x+ = F(x)``, ``A = DF(x_eq)``).

    For a system with uncertain parameters, that candidate (at the nominal values) is kept when
    ``A(p)'P + PA(p) < 0`` at every sample point ``p`` of the box (nominal value, vertices and
    three points along each axis, :func:`roa.model._parameters.sample_points`). Otherwise it is not a
    Lyapunov function at some parameter value, and the candidate is designed for the box: ``P``
    of the common Lyapunov LMIs at those points (:func:`roa.search._box_lyapunov.box_lyapunov`), when
    they are feasible (else the nominal candidate, whose failure the analyses then report). Either
    is only a candidate: the level of ``{V <= level}`` is decided for every parameter of the box by
    :func:`roa.certify`.

    Examples
    --------
    >>> import roa
    >>> from roa.systems.vanderpol import vanderpol
    >>> roa.default_lyapunov(vanderpol()).P.tolist()
    [[1.5, -0.5], [-0.5, 1.0]]
    """
    if system.equilibrium is None:
        raise RoaInputError(f"system {system.name!r} has no equilibrium: no Lyapunov candidate")
    from roa.model._checks import check_system

    check_system(system)  # a malformed field or a false equilibrium: a clear error first
    if system.lyapunov is not None:
        label = system.meta.get("lyapunov_name") or f"{system.name} V"
        V = QuadraticLyapunov.for_system(system, system.lyapunov, name=str(label))
    else:
        from roa.model._linearisation import lyapunov_matrix

        at = system.nominal() if system.parameters else system
        eq = "A'PA - P = -I" if system.time == "discrete" else "A'P + PA = -I"
        V = QuadraticLyapunov.for_system(system, lyapunov_matrix(at), name=f"P from {eq}")
    if (
        system.parameters
        and system.time == "continuous"  # the common Lyapunov LMIs are those of a flow
        and worst_linearisation(system, V) is not None
    ):
        from roa.search._box_lyapunov import box_lyapunov

        res = box_lyapunov(system)
        P = res.P  # the LMIs' matrix (a result's field, not a V's representation)
        if res.feasible and P is not None:
            where = "vertices" if res.affine else f"{len(res.points)} points"
            return QuadraticLyapunov.for_system(
                system, P, name=f"P from common Lyapunov LMIs at the box's {where}"
            )
    return V


def worst_linearisation(
    system: System, V: Lyapunov, per_axis: int = 3
) -> tuple[dict[str, float], float] | None:
    """The first sample point ``p`` of ``system``'s parameter box (nominal value, vertices and
    ``per_axis`` points along each axis) where ``V'`` is not negative definite at the equilibrium
    (largest eigenvalue of ``A(p)'P + PA(p)`` >= 0, ``P`` half the Hessian of V at its centre), with
    that eigenvalue; None when there is none, or when the system has no uncertain parameters. A
    check at those points only: nothing is claimed between them."""
    if not system.parameters:
        return None
    from roa.lyapunov._local import locally_negative
    from roa.model._parameters import sample_points

    for p in sample_points(system, per_axis=per_axis):
        ok, lam = locally_negative(system.at(**p), V)
        if not ok:
            return p, lam
    return None
