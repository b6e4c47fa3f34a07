"""The seed level of a search: the sampled largest level of the quadratic seed V0."""

from __future__ import annotations

from roa.lyapunov import QuadraticLyapunov
from roa.model._system import System


def seed_level(system: System, V0: QuadraticLyapunov) -> float:
    """The seed's sampled largest level (the whitening's scale; 1 when none is found)."""
    from roa.search._levelset import level_search

    res = level_search(system, V0, shape="level", method="sampled")
    return float(res.level) if res.level is not None and res.level > 0 else 1.0
