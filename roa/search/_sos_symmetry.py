"""Sign symmetry of an SOS program: Gram blocks split by the sign flips that fix its data.

A sign symmetry is a set ``S`` of variables such that flipping the sign of every variable of
``S`` leaves each polynomial of the identity unchanged: every monomial ``z^m`` of them has
``sum_{i in S} m_i`` even. Such ``S`` form a vector space over GF(2) (:func:`sign_symmetries`
returns a basis: the null space of the monomials' exponents mod 2). A monomial ``b`` of a Gram
basis has, per basis vector ``s``, the parity ``s . b mod 2``; the group acts on ``m' Q m`` by
diagonal +-1 matrices, so averaging any certificate over the group keeps the identity (its data
are fixed) and positive definiteness, and zeroes every entry of ``Q`` between monomials of
different parities: the Gram matrix of an invariant certificate is block-diagonal by parity
class (Gatermann and Parrilo 2004; TSSOS's sign symmetries). :func:`split` returns those blocks,
so the program is the same optimum with smaller blocks, and any pattern (dense, cliques) is
split further. The exact check proves whatever blocks it is given.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

Mono = tuple[int, ...]


def sign_symmetries(polys: Iterable[dict[Mono, Any]], nv: int) -> list[Mono]:
    """A basis of the sign symmetries of ``polys`` in ``nv`` variables (0/1 vectors ``s`` with
    ``s . m`` even for every monomial ``m`` of every polynomial; empty when none but 0)."""
    pivots: dict[int, int] = {}  # pivot column -> reduced row (bit masks, bit i = variable i)
    for p in polys:
        for m in p:
            row = sum(1 << i for i, e in enumerate(m) if e % 2)
            for col, prow in pivots.items():
                if row >> col & 1:
                    row ^= prow
            if row:
                col = (row & -row).bit_length() - 1
                for c in list(pivots):  # keep the rows reduced: clear the new pivot elsewhere
                    if pivots[c] >> col & 1:
                        pivots[c] ^= row
                pivots[col] = row
    out = []
    for free in range(nv):  # one null vector per free column
        if free in pivots:
            continue
        s = [0] * nv
        s[free] = 1
        for col, row in pivots.items():
            if row >> free & 1:
                s[col] = 1
        out.append(tuple(s))
    return out


def split(basis: list[Mono], symmetries: list[Mono]) -> list[list[Mono]]:
    """``basis`` split into its parity classes under ``symmetries`` (in order of first
    appearance; the whole basis when there is no symmetry)."""
    if not symmetries:
        return [basis] if basis else []
    classes: dict[tuple[int, ...], list[Mono]] = {}
    for m in basis:
        key = tuple(sum(a * b for a, b in zip(s, m, strict=True)) % 2 for s in symmetries)
        classes.setdefault(key, []).append(m)
    return list(classes.values())
