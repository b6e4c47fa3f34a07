"""The recast field's constrained SOS program split by sign symmetry (proposes only).

The program of :mod:`roa.search.sos_putinar` has one Gram matrix per multiplier over all the
monomials of its basis. When sign flips of some variables of ``z`` (states, the recast's
auxiliaries, parameters) leave every polynomial of the identity unchanged (``N``, ``V``, every
constraint, ``|d|^2k``), averaging a certificate over the group of those flips gives another one
(each Gram matrix averaged with its flipped copies: positive definite with at least the same
least eigenvalue) whose Gram entries only join monomials ``a``, ``b`` with ``a + b`` in the span
over GF(2) of the polynomials' exponent parities, and whose equality multipliers only hold such
monomials (:func:`roa.search.sos_sdd.sign_classes`). Solving for that structure is as good and
much smaller: one block per class. The blocks are put back into one matrix per multiplier over
the original basis (zeros between classes), so the candidate is the one
:func:`roa.proof.sos_putinar.check_putinar` checks and the stored certificate is unchanged.
The planar and the spatial quadrotor split by the flips of their decoupled lateral chains
(position, velocity, angle and its sine).
"""

from __future__ import annotations

import time
from fractions import Fraction
from typing import Any

import numpy as np
import scipy.sparse as sps

from roa.proof.recast import RecastData
from roa.proof.sos_putinar import Blocks, target_poly, times_polys
from roa.search.polysdp import solve_margin
from roa.search.sos_certificate import gram_columns
from roa.search.sos_putinar import PutinarCandidate, bases, default_eps
from roa.search.sos_sdd import _parity_span, _reduce

Mono = tuple[int, ...]


def _key(m: Mono, span: list[int]) -> int:
    return _reduce(sum(1 << i for i, e in enumerate(m) if e % 2), span)


def symmetry_span(data: RecastData, eps: Fraction) -> list[int]:
    """The GF(2) span of the exponent parities of every polynomial of the identity."""
    polys = [target_poly(data, eps), data.V, *[g for _, g in data.inequalities],
             *[h for _, h in data.equalities]]  # fmt: skip
    return _parity_span(polys)


def propose_symmetric(data: RecastData, level: float, *, eps: Fraction | None = None,
                      solver_options: dict[str, Any] | None = None
                      ) -> PutinarCandidate | None:  # fmt: skip
    """The program of :func:`roa.search.sos_putinar.propose_putinar` with its Gram matrices
    split by sign-symmetry class (module docstring); None when there is no symmetry (every
    basis in one class), and the caller solves the unsplit program."""
    import cvxpy as cp

    t0 = time.perf_counter()
    eps = default_eps(data) if eps is None else Fraction(eps)
    span = symmetry_span(data, eps)
    m0, m1, mj, me = bases(data)
    gram_bases = [m0, m1, *mj]
    split: list[list[list[int]]] = []  # per multiplier: index lists of its classes
    for B in gram_bases:
        classes: dict[int, list[int]] = {}
        for i, m in enumerate(B):
            classes.setdefault(_key(m, span), []).append(i)
        split.append(list(classes.values()))
    if all(len(s) <= 1 for s in split):
        return None
    free = [[m for m in B if _key(m, span) == 0] for B in me]
    times = [{m: float(c) for m, c in p.items()} for p in times_polys(data, Fraction(level))]
    rows: dict[Mono, int] = {}
    target = {m: float(c) for m, c in target_poly(data, eps).items()}
    for m in target:
        rows.setdefault(m, len(rows))
    blocks: list[tuple[int, list[int]]] = []  # (multiplier, indices into its basis)
    parts = []
    for g, (B, T) in enumerate(zip(gram_bases, times, strict=True)):
        for idx in split[g]:
            blocks.append((g, idx))
            parts.append(gram_columns(rows, [B[i] for i in idx], T))
    fparts = []
    for B, (_, h) in zip(free, data.equalities, strict=True):
        r: list[int] = []
        c: list[int] = []
        v: list[float] = []
        for k, bm in enumerate(B):
            for m, coef in h.items():
                r.append(rows.setdefault(tuple(p + q for p, q in zip(bm, m, strict=True)),
                                         len(rows)))  # fmt: skip
                c.append(k)
                v.append(float(coef))
        fparts.append((r, c, v))
    nrow = len(rows)
    b = np.zeros(nrow)
    for m, value in target.items():
        b[rows[m]] = value
    t = cp.Variable()
    cons: list[Any] = [t <= 1]
    expr: Any = 0
    Qs = []
    for (_, idx), (r, c, v) in zip(blocks, parts, strict=True):
        nb = len(idx)
        Q = cp.Variable((nb, nb), symmetric=True)
        expr = expr + sps.csr_matrix((v, (r, c)), shape=(nrow, nb * nb)) @ cp.vec(Q, order="C")
        cons.append(Q - t * np.eye(nb) >> 0)
        Qs.append(Q)
    mus = []
    for B, (r, c, v) in zip(free, fparts, strict=True):
        mu = cp.Variable(len(B)) if B else None
        if mu is not None:
            expr = expr + sps.csr_matrix((v, (r, c)), shape=(nrow, len(B))) @ mu
        mus.append(mu)
    cons.append(expr == b)
    status, usable = solve_margin(cp.Problem(cp.Maximize(t), cons), solver_options)
    ok = usable and all(Q.value is not None for Q in Qs) and t.value is not None
    out = None
    if ok:
        full = [np.zeros((len(B), len(B))) for B in gram_bases]
        for (g, idx), Q in zip(blocks, Qs, strict=True):
            full[g][np.ix_(idx, idx)] = np.asarray(Q.value)
        coeffs = []
        for B, Bf, mu in zip(me, free, mus, strict=True):
            vals = dict(zip(Bf, np.asarray(mu.value) if mu is not None else [], strict=True))
            coeffs.append(np.array([vals.get(m, 0.0) for m in B]))
        out = Blocks(list(zip(gram_bases, full, strict=True)), list(zip(me, coeffs, strict=True)))
    sizes = {"rows": nrow, "gram_sizes": [len(B) for B in gram_bases],
             "symmetry_blocks": [len(idx) for _, idx in blocks if len(idx) > 1],
             "free": sum(len(B) for B in free)}  # fmt: skip
    return PutinarCandidate(out, eps, float(np.asarray(t.value)) if ok else None, status,
                            time.perf_counter() - t0, sizes)  # fmt: skip
