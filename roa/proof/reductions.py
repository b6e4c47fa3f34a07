"""Reductions of an exact SOS problem, each with ``accepts`` / ``apply`` / ``invert``.

As in cvxpy's reduction chain, a reduction says whether it applies to a problem's exact data
(``accepts``), maps the data to one or more smaller problems plus what its inverse needs
(``apply``), and maps the certificates (stored parts, :mod:`roa.proof.sos_stored`) of those
problems back to one of the original (``invert``). Each states why a certificate of the reduced
problems proves the original:

* :class:`IndependentBlocks`: ``V`` and ``V'`` split over disjoint sets of variables
  (:mod:`roa.proof.sos_blocks` proves that the blocks' certificates at one level prove the
  whole); one part per block, naming its variables.
* :class:`Rescale`: the variables ``d = diag(scale) y`` with positive rationals (a bijection;
  ``eps |y|^2k > 0`` for ``d != 0``), only to balance the program; the stored certificate
  carries ``scale``.

The recast of non-polynomial fields and the parameter box are applied by
:func:`roa.proof.recast.recast_exact` (extra variables and constraints of one problem), sign
symmetry and correlative cliques by the programs that propose (:mod:`roa.search.sos_symmetry`,
:mod:`roa.search.sos_sparse`): they change a certificate's blocks, never what is checked.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Protocol

from roa.proof.sos_blocks import Block, blocks, restrict
from roa.proof.sos_check import ExactData, scale_data


class Reduction(Protocol):
    """A reduction of exact SOS data (module docstring)."""

    def accepts(self, data: ExactData) -> bool: ...

    def apply(self, data: ExactData) -> tuple[list[ExactData], Any]: ...

    def invert(self, parts: list[dict[str, Any]], inverse: Any) -> dict[str, Any]: ...


@dataclass(frozen=True)
class IndependentBlocks:
    """One problem per block of variables (:func:`roa.proof.sos_blocks.blocks`), or the blocks
    ``given`` (a stored partition: :func:`roa.proof.sos_blocks.restrict` refuses one that a
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
