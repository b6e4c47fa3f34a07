"""Estimates of a region of attraction as values: a set, how it was obtained, and its status.

A :class:`Region` is ``{x : form(coords(x)) <= level}`` where ``form`` is a quadratic form
``y' P y`` in the *analysis* coordinates ``y = coords(x)``. ``coords`` maps the states of the
simulated system into those coordinates (identity when they coincide; for the IPC the map (2.2)
from physical to flat coordinates). Basin maps draw ``form(coords(x)) = level`` on a slice,
Monte Carlo samples test containment, certificates certify a level.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import check_positive_definite


def symmetric_extent(
    inside_at: Callable[[np.ndarray], np.ndarray], t_max: float, *, n_grid: int, n_bisect: int
) -> float:
    """Largest t in [0, t_max] with ``inside_at(s)`` true for every |s| <= t.

    ``inside_at`` maps an array of curve parameters to booleans. A grid of ``n_grid`` points finds
    the first exit on each side, ``n_bisect`` bisection steps refine it; returns the smaller side.
    """
    grid = np.linspace(0.0, t_max, n_grid)[1:]
    out = []
    for sgn in (1.0, -1.0):
        inside = inside_at(sgn * grid)
        if inside.all():
            out.append(t_max)
            continue
        k = int(np.argmin(inside))
        lo, hi = (grid[k - 1] if k > 0 else 0.0), grid[k]
        for _ in range(n_bisect):
            mid = 0.5 * (lo + hi)
            if inside_at(np.array([sgn * mid]))[0]:
                lo = mid
            else:
                hi = mid
        out.append(lo)
    return float(min(out))


#: Status of an estimate: how much it is worth.
REGION_STATUSES = (
    "claimed",  # stated by a paper, not checked
    "sampled",  # largest level found by sampling/optimisation (no proof)
    "certified",  # proved, checked independently of the solver that produced it
    "refuted",  # a counterexample exists
    "inconclusive",
)


@dataclass(frozen=True)
class Region:
    """A sublevel set of a quadratic form, in analysis coordinates, with its provenance."""

    name: str
    P: np.ndarray
    level: float
    status: str
    coords: Callable[[np.ndarray], np.ndarray] | None = None
    meta: dict[str, Any] = field(default_factory=dict, compare=False, hash=False)

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "P", check_positive_definite(self.P, what=f"region {self.name!r} P")
        )
        if not (np.isfinite(self.level) and self.level > 0):
            raise RoaInputError(
                f"region {self.name!r}: level must be finite and > 0, got {self.level!r}"
            )
        if self.status not in REGION_STATUSES:
            raise RoaInputError(
                f"region {self.name!r}: status {self.status!r} not in {REGION_STATUSES}"
            )

    def form(self, x: np.ndarray) -> np.ndarray:
        """``y' P y`` with ``y = coords(x)``; ``inf`` where ``coords`` is undefined (outside its domain)."""
        x = np.asarray(x, dtype=float)
        if self.coords is None:
            y = x
        else:
            y = self.coords(x)
        return np.einsum("...i,ij,...j->...", y, self.P, y)

    def contains(self, x: np.ndarray) -> np.ndarray:
        return self.form(x) <= self.level

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "P": self.P.tolist(),
            "level": float(self.level),
            "status": self.status,
            **self.meta,
        }
