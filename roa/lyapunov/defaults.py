"""The candidate an analysis uses: the caller's V, a matrix, or the system's default quadratic V."""

from __future__ import annotations

from typing import Any

from roa.errors import RoaInputError
from roa.lyapunov.base import Lyapunov
from roa.lyapunov.polynomial import QuadraticLyapunov
from roa.system import System


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

    ``system.lyapunov`` when the system comes with one (a paper's or a benchmark's matrix), else
    ``P`` solving ``A'P + PA = -I`` for the linearisation ``A`` at the equilibrium.

    Examples
    --------
    >>> import roa
    >>> from roa.systems.vanderpol import vanderpol
    >>> roa.default_lyapunov(vanderpol()).P.tolist()
    [[1.5, -0.5], [-0.5, 1.0]]
    """
    if system.equilibrium is None:
        raise RoaInputError(f"system {system.name!r} has no equilibrium: no Lyapunov candidate")
    from roa.checks import check_system

    check_system(system)  # a malformed field or a false equilibrium: a clear error first
    if system.lyapunov is not None:
        return QuadraticLyapunov.for_system(system, system.lyapunov, name=f"{system.name} V")
    from roa.linearisation import lyapunov_matrix

    return QuadraticLyapunov.for_system(
        system, lyapunov_matrix(system), name="P from A'P + PA = -I"
    )
