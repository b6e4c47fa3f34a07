"""The linearisation of a system at its equilibrium: Jacobian, classification, Lyapunov matrix.

For a discrete-time system ``x+ = F(x)`` the Jacobian is that of the map, stability means every
eigenvalue inside the unit circle (Schur) and the Lyapunov matrix solves ``A'PA - P = -I``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg

from roa.errors import RoaInputError
from roa.model._system import System

#: Real parts within this (relative to the Jacobian's norm) of zero count as zero.
DEGENERATE_RTOL = 1e-9


def jacobian(system: System, x: np.ndarray | None = None) -> np.ndarray:
    """Jacobian of the field (of the map, for a discrete-time system) at ``x`` (default the
    equilibrium), exact via CasADi's AD.

    Examples
    --------
    >>> from roa.systems.vanderpol import vanderpol
    >>> jacobian(vanderpol()).tolist()
    [[0.0, -1.0], [1.0, -1.0]]
    """
    import casadi as ca

    from roa.model._backend import namespace

    x = system.x_eq if x is None else np.asarray(x, dtype=float)
    sym = ca.SX.sym("x", system.n)
    f = ca.vertcat(*system.dynamics(0.0, [sym[i] for i in range(system.n)], namespace("casadi")))
    return np.array(ca.Function("J", [sym], [ca.jacobian(f, sym)])(x), dtype=float)


@dataclass(frozen=True)
class Linearisation:
    """``A`` at the equilibrium, its eigenvalues and its kind.

    ``kind`` is ``"hurwitz"`` (every eigenvalue has a negative real part), ``"unstable"`` (one has a
    positive real part) or ``"degenerate"`` (none positive, at least one on the imaginary axis:
    stability is decided by higher-order terms). For a discrete-time system: ``"schur"`` (every
    eigenvalue of modulus < 1), ``"unstable"`` (one > 1) or ``"degenerate"`` (one on the unit
    circle).
    """

    A: np.ndarray
    eigenvalues: np.ndarray
    kind: str

    @property
    def stable(self) -> bool:
        """The linearisation is asymptotically stable (Hurwitz, or Schur for a map)."""
        return self.kind in ("hurwitz", "schur")


def linearise(system: System) -> Linearisation:
    """Jacobian at the equilibrium and its classification (see :class:`Linearisation`).

    The field must apply no numpy function to a state (:func:`roa.model._field_probe.check_functions`: CasADi
    would differentiate numpy's own) and have a finite Jacobian there."""
    from roa.model._field_probe import check_functions

    check_functions(system)
    A = jacobian(system)
    if not np.all(np.isfinite(A)):
        raise RoaInputError(
            f"system {system.name!r}: the Jacobian of the field at the equilibrium "
            f"{system.x_eq.tolist()} is not finite ({np.array2string(A, precision=4)}): the field "
            "is not differentiable there (or overflows), so it has no linearisation"
        )
    eig = np.linalg.eigvals(A)
    if system.time == "discrete":
        mod = np.abs(eig)
        if np.any(mod > 1 + DEGENERATE_RTOL):
            return Linearisation(A, eig, "unstable")
        return Linearisation(A, eig, "schur" if np.all(mod < 1 - DEGENERATE_RTOL) else "degenerate")
    scale = max(1.0, float(np.abs(A).max()))
    re = eig.real
    if np.any(re > DEGENERATE_RTOL * scale):
        kind = "unstable"
    elif np.all(re < -DEGENERATE_RTOL * scale):
        kind = "hurwitz"
    else:
        kind = "degenerate"
    return Linearisation(A, eig, kind)


def lyapunov_matrix(system: System) -> np.ndarray:
    """P solving A'P + PA = -I for the linearisation A at the equilibrium (A must be Hurwitz);
    for a discrete-time system P solving A'PA - P = -I (A must be Schur)."""
    lin = linearise(system)
    discrete = system.time == "discrete"
    if not lin.stable:
        eig = lin.eigenvalues
        worst = eig[np.argmax(np.abs(eig) if discrete else eig.real)]
        what, eq = ("Schur", "A'PA - P = -I") if discrete else ("Hurwitz", "A'P + PA = -I")
        raise RoaInputError(
            f"linearisation of {system.name!r} is not {what} (eigenvalue {worst:.4g}): no "
            f"quadratic Lyapunov function from {eq}; pass V explicitly (or give the system a "
            "lyapunov matrix)"
        )
    if discrete:
        P = linalg.solve_discrete_lyapunov(lin.A.T, np.eye(system.n))
    else:
        P = linalg.solve_continuous_lyapunov(lin.A.T, -np.eye(system.n))
    return 0.5 * (P + P.T)


def decrease_matrix(system: System, A: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Half the Hessian at the equilibrium of the decrease of ``V = d'Pd + O(|d|^3)`` along the
    linearisation ``A``: ``A'P + PA`` (``V'``), or ``A'PA - P`` (``V(F(x)) - V(x)``, a map)."""
    if system.time == "discrete":
        return A.T @ P @ A - P
    return A.T @ P + P @ A
