"""Sparse float polynomials (``{exponent tuple: float}``): the arithmetic of the programs of
:mod:`roa.search._sdp` (which holds the monomial bases and the program itself).
"""

from __future__ import annotations

import itertools
from typing import Any

import sympy as sp

from roa.search._sdp import Poly


def poly_of(expr: Any, gens: list[sp.Symbol]) -> Poly:
    poly = sp.Poly(sp.expand(expr), *gens)
    return {m: float(c) for m, c in poly.terms() if c != 0}


def mul(a: Poly, b: Poly) -> Poly:
    out: Poly = {}
    for (ma, ca), (mb, cb) in itertools.product(a.items(), b.items()):
        m = tuple(x + y for x, y in zip(ma, mb, strict=True))
        out[m] = out.get(m, 0.0) + ca * cb
    return out


def monomial(m: tuple[int, ...]) -> Poly:
    """The polynomial ``y^m``."""
    return {m: 1.0}


def total_degree(p: Poly) -> int:
    """The total degree of ``p``."""
    return max(sum(m) for m in p)


def add(a: Poly, b: Poly) -> Poly:
    out = dict(a)
    for m, c in b.items():
        out[m] = out.get(m, 0.0) + c
    return out


def poly_sum(ps: list[Poly]) -> Poly:
    """The sum of the polynomials ``ps``."""
    out: Poly = {}
    for p in ps:
        out = add(out, p)
    return out


def power(p: Poly, k: int, nv: int) -> Poly:
    """``p^k`` in ``nv`` variables."""
    out: Poly = {tuple([0] * nv): 1.0}
    for _ in range(k):
        out = mul(out, p)
    return out


def scale(a: Poly, c: float) -> Poly:
    return {m: v * c for m, v in a.items()}


def diff(m: tuple[int, ...], i: int) -> Poly:
    """d(y^m)/dy_i."""
    if m[i] == 0:
        return {}
    return {tuple(k - (j == i) for j, k in enumerate(m)): float(m[i])}


def is_even(polys: list[Poly], nd: int, *, odd: bool = False) -> bool:
    """Every monomial has even (``odd=True``: odd) total degree in the first ``nd`` variables."""
    return all(sum(m[:nd]) % 2 == int(odd) for p in polys for m in p)
