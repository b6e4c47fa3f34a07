"""Numerical Putinar certificate that a sublevel set lies in the domain (proposes only).

For a polynomial margin ``g`` and a polynomial ``V`` (``d = x - x_eq``), the one fixed-level
program (:class:`roa.search._sos_program.FixedLevel`) finds Gram matrices with, coefficient by
coefficient::

    g(d) - eps - lambda(d) (c - V(d)) = m0(d)' Q0 m0(d),   lambda = m1(d)' Q1 m1(d),

maximising the least eigenvalue ``t`` of both (``Q0, Q1 >= t I``, ``t <= 1``). ``m1`` holds the
monomials of degree ``0..L`` (``2L`` the least even degree with ``2L + deg V >= deg g``), ``m0``
those of degree ``0..D`` (``2D`` the least even degree >= ``deg g`` and ``2L + deg V``). The float
matrices are a candidate: only :func:`roa.proof._domain.check_domain_certificate` decides.
"""

from __future__ import annotations

import time
from fractions import Fraction
from typing import Any

import numpy as np

from roa.proof._domain import domain_target
from roa.proof._sos_check import QPoly
from roa.search._sdp import MAX_SDP_BYTES, monomials, sdp_bytes
from roa.search._sos_program import Candidate, FixedLevel, Pattern


def default_domain_eps(margin: QPoly, n: int) -> Fraction:
    """``1e-6`` x ``g(x_eq)`` (the margin at the equilibrium), as a dyadic."""
    g0 = float(margin.get(tuple([0] * n), Fraction(0)))
    return Fraction(2.0 ** round(np.log2(1e-6 * g0))) if g0 > 0 else Fraction(1, 2**40)


def propose_domain_certificate(
    margin: QPoly, Vq: QPoly, n: int, level: float, *, solver_options: dict[str, Any] | None = None
) -> Candidate:
    """Solve the program of the module docstring for ``{V <= level}``."""
    t0 = time.perf_counter()
    eps = default_domain_eps(margin, n)
    deg_g = max((sum(m) for m in margin), default=0)
    deg_V = max(sum(m) for m in Vq)
    L = max(0, (deg_g - deg_V + 1) // 2)
    D = (max(deg_g, 2 * L + deg_V) + 1) // 2
    basis0, basis1 = monomials(n, D, 0), monomials(n, L, 0)
    if sdp_bytes(len(basis0)) > MAX_SDP_BYTES:
        return Candidate(None, eps, None, f"too large: a Gram block of {len(basis0)} monomials; "
                         "not built", time.perf_counter() - t0,
                         {"gram_sizes": [len(basis0), len(basis1)]})  # fmt: skip
    times = [{tuple([0] * n): Fraction(1)}, {m: -c for m, c in Vq.items()}]
    pattern = Pattern("dense", ((0, basis0, "psd"), (1, basis1, "psd")))
    prog = FixedLevel(None, pattern, eps=eps, solver_options=solver_options,
                      identity=(n, domain_target(margin, eps, n), times, []))  # fmt: skip
    cand = prog.solve(level)
    return Candidate(cand.certificate, eps, cand.margin, cand.solver_status,
                     time.perf_counter() - t0, cand.sizes)  # fmt: skip
