"""Numerical constrained SOS certificate of a level for a recast field (proposes only).

One semidefinite program (cvxpy, Clarabel) finds the Gram matrices and equality multipliers of
the identity of :func:`roa.proof._putinar.check_level`, maximising the least eigenvalue ``t`` of every
Gram matrix (``t <= 1``): the margin the exact rounding and projection need. Only
:func:`roa.proof._putinar.check_level` decides.

**Bases** (``z`` = states and the auxiliary variables): ``m0`` holds every monomial of degree
``1..D`` in ``z`` (``2D`` the least even degree >= that of ``N`` and of ``lambda V``, at least 4)
and, per angle, ``d^j``, ``d^j s``, ``d^j q`` up to degree ``H`` (``2H`` the degree of the
highest Taylor bound); ``m1`` has the degrees ``1..D - deg V / 2``; a constraint ``g`` of degree
``<= 2D - 2`` gets an SOS multiplier over the monomials of degree ``0..D - deg g / 2``, a higher
one a constant; the
circle's free multiplier spans the monomials of degree <= 2 and the angle's powers ``d^j`` (a
square root's, the monomials of degree <= 2). Every
product then lies in the span of ``m0 m0'`` except each circle's linear ``q``, which the check
matches with the multiplier's constant.
"""

from __future__ import annotations

import time
from fractions import Fraction
from typing import Any

import numpy as np

from roa.proof._putinar import Certificate, level_identity
from roa.proof._recast import RecastData
from roa.search._sdp import Program, monomials, solve
from roa.search._sos_certificate import Candidate, default_eps
from roa.search._sos_symmetry import sign_symmetries, split

Mono = tuple[int, ...]


def _unit(nv: int, i: int, p: int = 1) -> Mono:
    return tuple(p if k == i else 0 for k in range(nv))


def bases(data: RecastData) -> tuple[list[Mono], list[Mono], list[list[Mono]], list[list[Mono]]]:
    """``m0``, ``m1``, the inequalities' bases and the equalities' bases (module docstring)."""
    nv = data.nv
    deg_n = max((sum(m) for m in data.N), default=2)
    deg_v = max((sum(m) for m in data.V), default=2)
    D = max(2, (deg_n + 1) // 2, (deg_v + 3) // 2)  # m0 has degrees 1..D (plus angle powers)
    top = max((sum(m) for _, g in data.inequalities for m in g), default=2)
    H = max(D, (top + 1) // 2)
    m0 = monomials(nv, D, 1)
    angle_powers: list[list[Mono]] = []
    for a, i in enumerate(data.angles):
        si, qi = data.aux(a)
        extra = []
        for j in range(0, H + 1):
            for aux in (None, si, qi):
                m = list(_unit(nv, i, j))
                if aux is not None:
                    m[aux] += 1
                if D < sum(m) <= H:
                    extra.append(tuple(m))
        m0 += extra
        angle_powers.append([_unit(nv, i, j) for j in range(2 * D - 1, 2 * H - 1)])
    m1 = monomials(nv, D - (deg_v + 1) // 2, 1)
    mj = []
    for _, g in data.inequalities:
        deg_g = max(sum(m) for m in g)
        mj.append(monomials(nv, D - (deg_g + 1) // 2, 0) if deg_g <= 2 * D - 2 else
                  [tuple([0] * nv)])  # fmt: skip
    me = [monomials(nv, 2 * D - 2, 0) + (angle_powers[a] if a < len(angle_powers) else [])
          for a in range(len(data.equalities))]  # fmt: skip
    if data.parameters:  # V' = 0 at x_eq for every parameter: no block may be > 0 there
        boxes = len(data.parameters)
        m0, m1 = _moving(data, m0), _moving(data, m1)
        mj = [_moving(data, B, keep_one=True) for B in mj[:-boxes]] + [
            _moving(data, B) for B in mj[-boxes:]
        ]
        me = [_moving(data, B, keep_one=True) for B in me]
    return m0, m1, mj, me


def _moving(data: RecastData, basis: list[Mono], keep_one: bool = False) -> list[Mono]:
    """The monomials of ``basis`` that vanish at the equilibrium (state degree >= 1), and the
    constant with ``keep_one``: with the parameters as variables, a monomial in the parameters
    alone would make its block positive at ``x_eq`` where the identity's other side is 0 (no
    strictly feasible Gram matrix), or (times a constraint linear in a circle's ``q``) give a
    monomial ``w q`` that no block matches (only the plain ``q`` is matched, by the circle's
    multiplier's constant)."""
    return [m for m in basis if data.state_degree(m) >= 1 or (keep_one and sum(m) == 0)]


def propose_putinar(data: RecastData, level: float, *, eps: Fraction | None = None,
                    solver_options: dict[str, Any] | None = None) -> Candidate:  # fmt: skip
    """Solve the constrained SOS program for ``level`` (module docstring)."""
    t0 = time.perf_counter()
    eps = default_eps(data) if eps is None else Fraction(eps)
    m0, m1, mj, me = bases(data)
    gram_bases = [m0, m1, *mj]
    target, exact_times = level_identity(data, Fraction(level), eps)
    times = [{m: float(c) for m, c in p.items()} for p in exact_times]
    prog = Program(data.nv)
    prog.const({m: -float(c) for m, c in target.items()})
    t = prog.scalar()
    syms = sign_symmetries([target, *exact_times, *(h for _, h in data.equalities)], data.nv)
    factors = []  # each Gram basis split by parity class (an empty one: its multiplier is 0)
    for k, (B, T) in enumerate(zip(gram_bases, times, strict=True)):
        for piece in split(B, syms):
            prog.gram(piece, T, sign=1.0, margin=t)
            factors.append(k)
    # an invariant equality times mu: only mu's invariant monomials (the class of 1) matter
    me = [[m for m in B if not any(sum(a * b for a, b in zip(sym, m, strict=True)) % 2
                                   for sym in syms)] for B in me]  # fmt: skip
    mus = [prog.free({m: float(c) for m, c in h.items()}, B)
           for B, (_, h) in zip(me, data.equalities, strict=True)]  # fmt: skip
    res = solve(prog.problem(t, extra=[t <= 1]), options=solver_options)
    ok = res.usable and 0 in factors and all(Q.value is not None for _, Q in prog.grams)
    cert = None
    if ok:
        grams = [(k, B, np.asarray(Q.value)) for k, (B, Q) in zip(factors, prog.grams, strict=True)]
        cert = Certificate(tuple(grams), tuple((B, np.asarray(mu.value))
                                               for B, mu in zip(me, mus, strict=True)))  # fmt: skip
    sizes = {"rows": len(prog.rows), "gram_sizes": [len(B) for B, _ in prog.grams],
             "sign_symmetries": len(syms),
             "free": sum(len(B) for B in me)}  # fmt: skip
    return Candidate(cert, eps, float(t.value) if ok and t.value is not None else None,
                     res.status, time.perf_counter() - t0, sizes)  # fmt: skip
