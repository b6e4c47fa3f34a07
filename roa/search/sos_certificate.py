"""Numerical SOS certificate of a fixed level (proposes only; :mod:`roa.proof.sos_check` proves).

For a polynomial field, a polynomial ``V`` (``d = x - x_eq``) and a level ``c``, one semidefinite
program (cvxpy, Clarabel) finds Gram matrices ``Q0``, ``Q1`` with, coefficient by coefficient::

    -V'(d) - eps |d|^(2k) - lambda(d) (c - V(d)) = m0(d)' Q0 m0(d),   lambda = m1(d)' Q1 m1(d),

maximising the least eigenvalue ``t`` of both (``Q0, Q1 >= t I``, ``t <= 1``): the margin the
exact rounding and projection need. ``2k`` is the lowest degree of ``V'``; ``m0`` holds the
monomials of degree ``k..D`` (``2D`` the degree of the identity, the least even number >= the
degree of ``V'`` and of ``lambda V``), ``m1`` those of degree ``k..L`` (``lambda(0) = 0`` is forced
by the constant term; ``2L`` the multiplier's degree, default the least with ``2L + deg V >=
deg V'``). A degenerate equilibrium, ``V'`` starting at degree ``2k > 2``, forces every term of
``lambda`` below degree ``2k`` to vanish (the lowest one, ``c lambda_j``, has nothing to cancel it:
``sigma`` starts at ``2k`` and ``lambda V`` at ``j + 2``), so ``m1`` starts at degree ``k``, as
the Newton polytope says; a basis reaching lower would leave no strictly feasible point, which
Peyrl-Parrilo rounding needs. The float Grams are a candidate: only
:func:`roa.proof.sos_check.check_certificate` decides.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import scipy.sparse as sps

from roa.proof.sos_check import ExactData, norm_power
from roa.search.polysdp import MAX_SDP_BYTES, monomials, sdp_bytes, solve_margin

Mono = tuple[int, ...]


@dataclass(frozen=True)
class SosCandidate:
    """Bases and float Gram matrices of a numerical certificate (``Q1`` None: ``lambda = 0``)."""

    basis0: list[Mono]
    Q0: np.ndarray | None
    basis1: list[Mono]
    Q1: np.ndarray | None
    eps: Fraction
    margin: float | None  # the solver's least eigenvalue t
    solver_status: str
    seconds: float


def default_eps(data: ExactData, scale: float = 1e-6) -> Fraction:
    """``scale`` x the largest |coefficient| of the lowest-degree part of ``V'`` (a dyadic)."""
    top = max((abs(float(c)) for m, c in data.Vdot.items() if sum(m) == data.low), default=1.0)
    return Fraction(2.0 ** round(np.log2(scale * top)))


def gram_columns(rows: dict[Mono, int], basis: list[Mono], times: dict[Mono, float]
                 ) -> tuple[list[int], list[int], list[float]]:  # fmt: skip
    """Sparse columns of ``m' Q m * times`` over the vectorised Gram matrix ``Q``: row indices
    of the resulting monomials (``rows`` grows with new ones), column ``i * nb + j``, value."""
    r, c, v = [], [], []
    nb = len(basis)
    for i, j in itertools.product(range(nb), range(nb)):
        bij = tuple(p + q for p, q in zip(basis[i], basis[j], strict=True))
        for m, coef in times.items():
            key = tuple(p + q for p, q in zip(bij, m, strict=True))
            r.append(rows.setdefault(key, len(rows)))
            c.append(i * nb + j)
            v.append(coef)
    return r, c, v


def degrees(data: ExactData, multiplier_degree: int | None = None) -> tuple[int, int, int]:
    """``(k, D, L)`` of the program: ``sigma``'s monomials of degree ``k..D``, ``lambda``'s of
    degree ``1..L`` (``multiplier_degree`` None: the lowest even degree that balances
    ``lambda V`` against ``V'``)."""
    k = data.low // 2
    degV = max(sum(m) for m in data.V)
    degVd = max((sum(m) for m in data.Vdot), default=2)
    if multiplier_degree is None:
        multiplier_degree = max(2, degVd - degV + (degVd - degV) % 2)
    L = max(multiplier_degree // 2, k)
    D = (max(degVd, 2 * L + degV) + 1) // 2
    return max(k, 1), D, L


def propose_certificate(
    data: ExactData,
    level: float,
    *,
    eps: Fraction | None = None,
    multiplier_degree: int | None = None,
    solver_options: dict[str, Any] | None = None,
) -> SosCandidate:
    """Solve the SOS program for the level ``level`` (see the module docstring)."""
    t0 = time.perf_counter()
    n = data.n
    eps = default_eps(data) if eps is None else Fraction(eps)
    low, D, L = degrees(data, multiplier_degree)
    basis0 = monomials(n, D, low)
    basis1 = monomials(n, L, low) if L >= low else []  # lambda starts at degree 2k (below)
    if sdp_bytes(len(basis0)) > MAX_SDP_BYTES:
        status = (f"too large: a Gram block of {len(basis0)} monomials needs an estimated "
                  f"{sdp_bytes(len(basis0)) / 2**30:.3g} GiB (budget "
                  f"{MAX_SDP_BYTES / 2**30:.3g} GiB); not built")  # fmt: skip
        return SosCandidate(basis0, None, basis1, None, eps, None, status,
                            time.perf_counter() - t0)  # fmt: skip
    target: dict[Mono, float] = {}
    for m, c in data.Vdot.items():
        target[m] = target.get(m, 0.0) - float(c)
    for m, c in norm_power(n, data.low // 2).items():
        target[m] = target.get(m, 0.0) - float(eps * c)
    Q0, Q1, margin, status = gram_program(target, basis0, basis1, data.V, level,
                                          solver_options)  # fmt: skip
    return SosCandidate(basis0, Q0, basis1, Q1, eps, margin, status, time.perf_counter() - t0)


def gram_program(
    target: dict[Mono, float],
    basis0: list[Mono],
    basis1: list[Mono],
    Vq: dict[Mono, Any],
    level: float,
    solver_options: dict[str, Any] | None = None,
) -> tuple[np.ndarray | None, np.ndarray | None, float | None, str]:
    """The one program of a fixed level: Gram matrices with, coefficient by coefficient,
    ``target = m0' Q0 m0 + (m1' Q1 m1) (c - V)`` (no multiplier for an empty ``basis1``),
    maximising their least eigenvalue ``t <= 1``. ``(Q0, Q1, t, status)``, the matrices None
    when the solver gives no usable point."""
    import cvxpy as cp

    n = len(basis0[0])
    rows: dict[Mono, int] = {}
    for m in target:
        rows.setdefault(m, len(rows))
    zero = tuple([0] * n)
    parts = [gram_columns(rows, basis0, {zero: 1.0})]
    c_minus_V: dict[Mono, float] = {m: -float(c) for m, c in Vq.items()}
    c_minus_V[zero] = c_minus_V.get(zero, 0.0) + float(level)
    if basis1:
        parts.append(gram_columns(rows, basis1, c_minus_V))
    nrow = len(rows)
    b = np.zeros(nrow)
    for m, value in target.items():
        b[rows[m]] = value
    n0, n1 = len(basis0), len(basis1)
    Q0 = cp.Variable((n0, n0), symmetric=True)
    t = cp.Variable()
    A0 = sps.csr_matrix((parts[0][2], (parts[0][0], parts[0][1])), shape=(nrow, n0 * n0))
    expr = A0 @ cp.vec(Q0, order="C")
    cons = [Q0 - t * np.eye(n0) >> 0, t <= 1]
    Q1 = None
    if basis1:
        Q1 = cp.Variable((n1, n1), symmetric=True)
        A1 = sps.csr_matrix((parts[1][2], (parts[1][0], parts[1][1])), shape=(nrow, n1 * n1))
        expr = expr + A1 @ cp.vec(Q1, order="C")
        cons.append(Q1 - t * np.eye(n1) >> 0)
    cons.append(expr == b)
    status, usable = solve_margin(cp.Problem(cp.Maximize(t), cons), solver_options)
    if not (usable and Q0.value is not None):
        return None, None, None, status
    return (np.asarray(Q0.value), None if Q1 is None else np.asarray(Q1.value),
            None if t.value is None else float(t.value), status)  # fmt: skip
