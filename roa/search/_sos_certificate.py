"""Numerical SOS certificate of a fixed level (proposes only; :mod:`roa.proof._sos_check` proves).

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
:func:`roa.proof._putinar.check_level` decides.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from roa.proof._putinar import Certificate
from roa.proof._sos_check import ExactData, norm_power
from roa.search._sdp import MAX_SDP_BYTES, Program, monomials, sdp_bytes, solve
from roa.search._sos_symmetry import sign_symmetries, split

Mono = tuple[int, ...]


@dataclass(frozen=True)
class Candidate:
    """A certificate proposed by a program, in floats (only :mod:`roa.proof._putinar` decides):
    ``certificate`` None when the solver gave no usable point; ``margin`` the least eigenvalue
    ``t`` of the Gram blocks the program maximised; ``sizes`` the program's figures."""

    certificate: Certificate | None
    eps: Fraction
    margin: float | None
    solver_status: str
    seconds: float
    sizes: dict[str, Any] = field(default_factory=dict)

    @property
    def feasible(self) -> bool:
        """A solution with a positive margin (every block positive definite numerically)."""
        return self.certificate is not None and self.margin is not None and self.margin > 0


def default_eps(data: Any, scale: float = 1e-6) -> Fraction:
    """``scale`` x the largest |coefficient| of the lowest-degree part of ``N`` (``V'``, or its
    recast numerator; the degree in the state variables, parameters not counted), a dyadic:
    the one default of every route."""
    nz = data.nv - len(getattr(data, "parameters", ()))
    top = max((abs(float(c)) for m, c in data.N.items() if sum(m[:nz]) == data.low),
              default=1.0)  # fmt: skip
    return Fraction(2.0 ** round(np.log2(scale * top)))


def level_target(data: ExactData, eps: Fraction) -> dict[Mono, float]:
    """``-V' - eps |d|^(2k)`` in floats (the side of the identity the Gram forms must match)."""
    target: dict[Mono, float] = {}
    for m, c in data.Vdot.items():
        target[m] = target.get(m, 0.0) - float(c)
    for m, c in norm_power(data.n, data.low // 2).items():
        target[m] = target.get(m, 0.0) - float(eps * c)
    return target


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
) -> Candidate:
    """Solve the SOS program for the level ``level`` (see the module docstring)."""
    t0 = time.perf_counter()
    n = data.n
    eps = default_eps(data) if eps is None else Fraction(eps)
    low, D, L = degrees(data, multiplier_degree)
    basis0 = monomials(n, D, low)
    basis1 = monomials(n, L, low) if L >= low else []  # lambda starts at degree 2k (below)
    target = level_target(data, eps)
    syms = sign_symmetries([target, data.V], n)  # the Gram blocks by parity class
    sos, lam = split(basis0, syms), split(basis1, syms)
    sizes = {"gram_sizes": [len(b) for b in sos + lam], "sign_symmetries": len(syms)}
    if sdp_bytes(len(basis0)) > MAX_SDP_BYTES:
        status = (f"too large: a Gram block of {len(basis0)} monomials needs an estimated "
                  f"{sdp_bytes(len(basis0)) / 2**30:.3g} GiB (budget "
                  f"{MAX_SDP_BYTES / 2**30:.3g} GiB); not built")  # fmt: skip
        return Candidate(None, eps, None, status, time.perf_counter() - t0, sizes)
    cert, margin, status = gram_program(target, sos, lam, data.V, level, solver_options)
    return Candidate(cert, eps, margin, status, time.perf_counter() - t0, sizes)


def gram_program(
    target: dict[Mono, float],
    sos: list[list[Mono]],
    lam: list[list[Mono]],
    Vq: dict[Mono, Any],
    level: float,
    solver_options: dict[str, Any] | None = None,
) -> tuple[Certificate | None, float | None, str]:
    """The one program of a fixed level: Gram blocks with, coefficient by coefficient,
    ``target = sum_b m_b' Q_b m_b + (sum_j l_j' L_j l_j) (c - V)`` (``sos`` the bases of the
    ``Q_b``, ``lam`` those of the ``L_j``: none, the multiplier is 0), maximising their least
    eigenvalue ``t <= 1``. ``(certificate, t, status)``, the certificate None when the solver
    gives no usable point."""
    n = len(sos[0][0])
    zero = tuple([0] * n)
    prog = Program(n)
    prog.const({m: -v for m, v in target.items()})
    t = prog.scalar()
    c_minus_V: dict[Mono, float] = {m: -float(c) for m, c in Vq.items()}
    c_minus_V[zero] = c_minus_V.get(zero, 0.0) + float(level)
    for b in sos:
        prog.gram(b, None, sign=1.0, margin=t)
    for b in lam:
        prog.gram(b, c_minus_V, sign=1.0, margin=t)
    res = solve(prog.problem(t, extra=[t <= 1]), options=solver_options)
    if not (res.usable and all(Q.value is not None for _, Q in prog.grams)):
        return None, None, res.status
    grams = tuple((0 if i < len(sos) else 1, b, np.asarray(Q.value))
                  for i, (b, Q) in enumerate(prog.grams))  # fmt: skip
    return Certificate(grams), None if t.value is None else float(t.value), res.status
