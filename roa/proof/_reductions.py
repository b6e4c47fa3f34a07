"""Reductions of an exact SOS problem, each with ``accepts`` / ``apply`` / ``invert``.

As in cvxpy's reduction chain, a reduction says whether it applies (``accepts``), maps a problem
to one or more exact problems plus what its inverse needs (``apply``), and maps the certificates
(stored parts, :mod:`roa.proof._sos_stored`) of those problems back to one of the original
(``invert``). Every route (the exact check of a fresh certificate, the re-check of a stored one)
applies the same reductions. Each states why a certificate of the reduced problems proves the
original.

Of the problem ``(system, V, level)``:

* :class:`ParameterBox`: uncertain parameters become indeterminates (module claim below); its
  inverse stores the box.
* :class:`Recast`: the field made polynomial (:func:`roa.proof._recast.recast_exact`: sin/cos,
  rational terms, half-integer powers; the one recast of every route), with the box when the
  system has one; its inverse stores the Taylor order, the scale and the box.

Of exact data (:class:`roa.proof._sos_check.ExactData`):

* :class:`IndependentBlocks`: ``V`` and ``V'`` split over disjoint sets of variables (the
  claim below: the blocks' certificates at one level prove the whole); one part per block,
  naming its variables.
* :class:`Rescale`: the variables ``d = diag(scale) y`` with positive rationals (a bijection;
  ``eps |y|^2k > 0`` for ``d != 0``), only to balance the program; the stored certificate
  carries ``scale``.

Sign symmetry and correlative cliques are patterns of the programs that propose
(:mod:`roa.search._sos_program`): they change a certificate's
blocks, never what is checked.

**The parameter box.** For a system with uncertain parameters ``p_j`` in ``[low_j, high_j]``,
:meth:`ParameterBox.apply` gives exact sympy substitutions ``p_j = mid_j + half_j w_j``
(``mid_j``, ``half_j`` the exact rationals of ``(low_j + high_j) / 2`` and ``(high_j - low_j) /
2`` computed from the doubles of the box, ``half_j > 0``), and :func:`box_constraints` the
polynomials ``g_j(w) = 1 - w_j^2``. Every parameter value of the box is ``w_j = (p_j - mid_j) /
half_j`` in ``[-1, 1]``, where ``g_j(w) >= 0``; ``g_j`` is ``(p_j - low_j)(high_j - p_j) /
half_j^2``, the box constraint of Putinar's form up to a positive factor. So a polynomial
identity in ``(z, w)``

    -N(z, w) - eps |d|^2k - lambda(z, w) (c - V) - sum_i sigma_i g_i(z) - sum_j tau_j(z, w) g_j(w)
        - sum_e mu_e h_e = sigma0(z, w)

with every ``sigma``, ``tau``, ``lambda`` SOS and ``eps > 0`` a constant (the same for every
parameter) proves ``-N(z(x), w(p)) >= eps |d|^2k > 0`` for every state ``x != x_eq`` of
``{V <= c}`` and every ``p`` of the box, i.e. ``V' < 0`` there for every parameter of the box
(:func:`roa.proof._putinar.check_level` checks the identity; the parameters are the last variables
of ``z``, and nothing else about them is assumed). The field evaluated in sympy sees each
uncertain parameter as a real symbol (:class:`roa.model._parameters.RangeField`); the fixed parameters
are floats taken as their exact rationals. ``f(x_eq, p) = 0`` must hold identically in ``p``. The
box is read from the system (never from a certificate file).

**Independent blocks** (:func:`blocks`, :func:`restrict`; correlative sparsity, decoupled case).
Let the exact data of :mod:`roa.proof._sos_check` split over disjoint sets of variables
``I_1, ..., I_m`` (in ``d = x - x_eq``): every monomial of ``V`` and of ``V'`` has its variables in
one ``I_j``, and neither has a constant term. Then ``V = sum_j V_j(d_j)`` and
``V' = sum_j W_j(d_j)``. If ``V >= mu |d|^2`` (the caller's Gram cover), each ``V_j >= mu |d_j|^2``
(the other blocks set to 0). If, for every ``j``, ``W_j < 0`` on ``{V_j <= c}`` minus ``d_j = 0``
(the block's own SOS certificate, checked exactly), then ``V' < 0`` on ``{V <= c}`` minus
``d = 0``: on ``{V <= c}`` each ``V_j(d_j) <= V(d) <= c`` since the others are ``>= 0``, each
``W_j(d_j) < 0`` where ``d_j != 0`` and ``W_j(0) = 0``, and ``d != 0`` has a block with
``d_j != 0``. ``W_j`` need not be ``V_j``'s own derivative: the argument uses only the split.

The blocks are the connected components of the graph on the variables that joins two variables
when they occur in one monomial of ``V`` or ``V'``.
Coupled systems have one block, and nothing changes; decoupled copies of a system have one per copy,
so their Gram matrices are as small as one copy's. A connected but sparse graph is handled by
the chordal cliques of :func:`roa.search._sos_program.clique_pattern` (checked by :mod:`roa.proof._putinar`), for the
whole or for a block.
"""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any

from roa.proof._sos_check import ExactData, NotPolynomial, QPoly, rational, scale_data

#: Names of the recast's own variables: a parameter named like one of them is refused.
_RESERVED = re.compile(r"[xdsqu]\d+")


@dataclass(frozen=True)
class BoxVariables:
    """The system over its box (``system``: its sympy field sees real symbols), the normalised
    variables ``w_j`` (sympy Dummies), the substitution ``p_j -> mid_j + half_j w_j`` and the
    exact box ``(name, low, high)`` per parameter."""

    system: Any
    symbols: tuple[Any, ...]
    subs: dict[Any, Any]
    parameters: tuple[tuple[str, Fraction, Fraction], ...]


@dataclass(frozen=True)
class ParameterBox:
    """Uncertain parameters as indeterminates of the certificate (module docstring)."""

    def accepts(self, system: Any) -> bool:
        return bool(getattr(system, "parameters", None))

    def apply(self, system: Any) -> BoxVariables:
        """The exact parameter variables of ``system``; raises :class:`NotPolynomial` for a
        parameter name that clashes with the recast's variables (``x0``, ``d1``, ``s0``...) or
        an empty box."""
        import sympy as sp

        from roa.model._parameters import ParameterBox as Box, over

        box = Box.of(system)
        clash = [k for k in box.names if _RESERVED.fullmatch(k)]
        if clash:
            raise NotPolynomial(f"parameter name {clash[0]!r} clashes with the recast's variables")
        ws, subs, params = [], {}, []
        for name, lo, hi in zip(box.names, box.lo, box.hi, strict=True):
            low, high = Fraction(float(lo)), Fraction(float(hi))
            if not low < high:
                raise NotPolynomial(f"parameter {name!r}: empty box [{lo}, {hi}]")
            mid, half = (low + high) / 2, (high - low) / 2
            w = sp.Dummy(f"w_{name}", real=True)
            ws.append(w)
            subs[sp.Symbol(name, real=True)] = rational(mid) + rational(half) * w
            params.append((name, low, high))
        return BoxVariables(over(system), tuple(ws), subs, tuple(params))

    def invert(self, cert: dict[str, Any],
               parameters: tuple[tuple[str, Fraction, Fraction], ...]) -> dict[str, Any]:  # fmt: skip
        return {**cert, "parameters": box_json(parameters)} if parameters else cert


def box_constraints(nv: int, parameters: tuple[tuple[str, Fraction, Fraction], ...]
                    ) -> list[tuple[str, QPoly]]:  # fmt: skip
    """``1 - w_j^2 >= 0`` per parameter, ``w_j`` the ``j``-th of the last ``len(parameters)``
    variables of ``nv``."""
    first = nv - len(parameters)
    return [(f"({name} - {low})({high} - {name}) >= 0 (box of {name}, normalised)",
             {tuple([0] * nv): Fraction(1), tuple(2 * (i == first + j) for i in range(nv)): Fraction(-1)})
            for j, (name, low, high) in enumerate(parameters)]  # fmt: skip


def describe(parameters: tuple[tuple[str, Fraction, Fraction], ...]) -> str:
    """``mu in [0.8, 1.2]``, ... (the doubles of the box, shortest repr)."""
    return ", ".join(f"{k} in [{float(lo)!r}, {float(hi)!r}]" for k, lo, hi in parameters)


def box_json(parameters: tuple[tuple[str, Fraction, Fraction], ...]) -> dict[str, list[str]]:
    """The exact box as stored with a certificate (informational: a re-check reads the box from
    the system and refuses a certificate whose stored box differs)."""
    return {k: [str(lo), str(hi)] for k, lo, hi in parameters}


Block = tuple[int, ...]


def blocks(data: ExactData) -> list[Block]:
    """The variable blocks of ``data`` (sorted, covering ``range(n)``); one block when coupled or
    when ``V`` or ``V'`` has a constant term."""
    zero = tuple([0] * data.n)
    if data.V.get(zero, 0) or data.Vdot.get(zero, 0):
        return [tuple(range(data.n))]
    return components(graph(range(data.n), (data.V, data.Vdot)))


def graph(nodes: Any, polys: Any) -> Any:
    """The graph (networkx) on ``nodes`` joining two variables of one monomial (nonzero
    coefficient) of ``polys``."""
    import networkx as nx

    G = nx.Graph()
    G.add_nodes_from(nodes)
    for poly in polys:
        for m, c in poly.items():
            if c:
                G.add_edges_from(itertools.combinations([i for i, e in enumerate(m) if e], 2))
    return G


def components(G: Any) -> list[Block]:
    """The connected components of the graph ``G``, each sorted, in order of least variable."""
    import networkx as nx

    return sorted(tuple(sorted(int(i) for i in c)) for c in nx.connected_components(G))


def restrict(data: ExactData, block: Block) -> ExactData:
    """The data of one block: ``V_j`` and ``W_j`` in the block's variables (in its order).

    Raises ``ValueError`` if a monomial of ``V`` or ``V'`` touches the block and another variable
    (``block`` is then not a union of blocks)."""
    inside = set(block)

    def part(poly: QPoly) -> QPoly:
        out: QPoly = {}
        for m, c in poly.items():
            support = {i for i, k in enumerate(m) if k}
            if not c or not support & inside:
                continue
            if not support <= inside:
                raise ValueError(f"monomial {m} couples block {list(block)} to other variables")
            out[tuple(m[i] for i in block)] = c
        return out

    V, W = part(data.V), part(data.Vdot)
    low = min((sum(m) for m in W), default=0)
    center = tuple(data.center[i] for i in block)
    return replace(data, n=len(block), center=center, V=V, Vdot=W, low=low)


def check_partition(parts: Any, n: int) -> list[Block]:
    """Stored blocks as a partition of ``range(n)`` (``ValueError`` unless disjoint and covering)."""
    if not isinstance(parts, list) or not parts:
        raise ValueError("blocks must be a non-empty list of variable lists")
    out: list[Block] = []
    for p in parts:
        if not (isinstance(p, list) and p and all(type(i) is int and 0 <= i < n for i in p)):
            raise ValueError(f"every block must be a non-empty list of variable indices < {n}")
        out.append(tuple(p))
    flat = sorted(i for p in out for i in p)
    if flat != list(range(n)):
        raise ValueError("blocks must cover every variable exactly once")
    return out


@dataclass(frozen=True)
class IndependentBlocks:
    """One problem per block of variables (:func:`blocks`), or the blocks
    ``given`` (a stored partition: :func:`restrict` refuses one that a
    monomial couples)."""

    given: tuple[Block, ...] | None = None

    def accepts(self, data: ExactData) -> bool:
        return len(self.blocks(data)) > 1

    def blocks(self, data: ExactData) -> list[Block]:
        return list(self.given) if self.given is not None else blocks(data)

    def apply(self, data: ExactData) -> tuple[list[ExactData], list[Block]]:
        parts = self.blocks(data)
        if len(parts) == 1:
            return [data], parts
        return [restrict(data, b) for b in parts], parts

    def invert(self, parts: list[dict[str, Any]], inverse: list[Block]) -> dict[str, Any]:
        return {"parts": [{**p, "variables": list(b)} for p, b in zip(parts, inverse, strict=True)]}


@dataclass(frozen=True)
class Rescale:
    """The variables ``d = diag(scale) y`` (any positive rationals)."""

    scale: tuple[Fraction, ...]

    def accepts(self, data: ExactData) -> bool:
        return any(r != 1 for r in self.scale)

    def apply(self, data: ExactData) -> tuple[list[ExactData], tuple[Fraction, ...]]:
        return [scale_data(data, self.scale)], self.scale

    def invert(self, parts: list[dict[str, Any]], inverse: tuple[Fraction, ...]) -> dict[str, Any]:
        return {"parts": parts, "scale": [str(r) for r in inverse]}
