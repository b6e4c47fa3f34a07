"""The Lyapunov setting of Section 3.3 of the seed paper, for the closed loop (3.8).

* ``T`` of (3.9): ``q = T xi`` with ``xi = (z1, z2, w1, w2)``;
* (3.10): ``q' = -L q + beta(q) (3, 1, 0, 0)`` with ``beta = q4^2 phi0(w1)``, ``w1 = q3 - q4``;
* ``V = q'q/2 + (q3 - q4)^2/2 = q' P_q q`` of (3.11); as a :class:`QuadraticLyapunov` on
  :func:`ipc_paper.system.transformed` it has ``P = T' P_q T``;
* ``Phi(q) = -q'Mq + (3 q1 + q2) beta(q) + q3 q4 - q4^2`` of (3.12), ``M = (I + 11')/2``.

The flat closed loop :func:`ipc_paper.system.transformed` carries ``P = T' P_q T`` as its
``lyapunov`` and ``T'T`` as its ``norm`` (the paper's ball ``||q||^2``), so the generic analyses
(:func:`roa.level_search`, :func:`roa.certify`) use the paper's setting by default. The paper's
estimates and their reproduction live in the rest of the study (``ipc_paper.estimates``, ...), not
here.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ipc_paper.system.model import phi0
from roa.errors import RoaInputError
from roa.lyapunov import QuadraticLyapunov

#: (3.9): q = T (z1, z2, w1, w2).
T = np.array([[1.0, 3, 3, 1], [0, 1, 2, 1], [0, 0, 1, 1], [0, 0, 0, 1]])
_E34 = np.array([0.0, 0, 1, -1])
#: (3.11): V = q' P_q q = q'q/2 + (q3 - q4)^2/2.
P_Q = 0.5 * (np.eye(4) + np.outer(_E34, _E34))
#: (3.12): m_ii = 1, m_ij = 1/2.
M = 0.5 * (np.eye(4) + np.ones((4, 4)))
#: Linear part of (3.10): q' = -L q + beta (3, 1, 0, 0).
L_310 = np.array([[1.0, 0, 0, 0], [1, 1, 0, 0], [1, 1, 1, 0], [1, 1, 1, 1]])
#: Paper's printed values.
PAPER_C_STAR_SQ = 4.89
PAPER_C_TILDE = 2.25
PAPER_SECTOR_DEG = 60.0

SHAPES = ("ball", "level")


def lambda_min_M() -> float:
    """Smallest eigenvalue of M (the paper: 1/2)."""
    return float(np.linalg.eigvalsh(M)[0])


def beta(q: np.ndarray) -> np.ndarray:
    """beta(q) = q4^2 phi0(w1) with w1 = q3 - q4, on arrays ``(..., 4)``."""
    q = np.asarray(q, dtype=float)
    return q[..., 3] ** 2 * phi0(q[..., 2] - q[..., 3])


def q_dot(q: np.ndarray) -> np.ndarray:
    """The closed loop (3.10) in q coordinates, on arrays ``(..., 4)``."""
    q = np.asarray(q, dtype=float)
    b = beta(q)
    return -q @ L_310.T + b[..., None] * np.array([3.0, 1.0, 0.0, 0.0])


def Phi(q: np.ndarray) -> np.ndarray:
    """(3.12): Phi(q) = -q'Mq + (3 q1 + q2) beta(q) + q3 q4 - q4^2, on arrays ``(..., 4)``."""
    q = np.asarray(q, dtype=float)
    quad = np.einsum("...i,ij,...j->...", q, M, q)
    return -quad + (3 * q[..., 0] + q[..., 1]) * beta(q) + q[..., 2] * q[..., 3] - q[..., 3] ** 2


def flat_system() -> Any:
    from ipc_paper.system import transformed

    return transformed()


def paper_lyapunov() -> QuadraticLyapunov:
    """V of (3.11) on the flat closed loop: P = T' P_q T."""
    return QuadraticLyapunov(T.T @ P_Q @ T, np.zeros(4), "V (3.11)")


def shape_matrix(shape: str) -> np.ndarray:
    """Shape in flat coordinates: ``ball`` -> T'T (||q||^2), ``level`` -> T' P_q T (V)."""
    if shape == "ball":
        return T.T @ T
    if shape == "level":
        return T.T @ P_Q @ T
    raise RoaInputError(f"shape must be one of {SHAPES}, got {shape!r}")


def to_q(xi: np.ndarray) -> np.ndarray:
    return np.asarray(xi, dtype=float) @ T.T
