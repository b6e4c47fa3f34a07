"""Estimates of a region of attraction as values: a set, how it was obtained, and its status.

A :class:`Region` is ``{x : V(coords(x)) <= level}`` for any Lyapunov candidate ``V``
(:class:`roa.lyapunov.Lyapunov`: quadratic, polynomial, any function) written in the *analysis*
coordinates ``y = coords(x)``. ``coords`` maps the states of the simulated system into those
coordinates (identity when they coincide; for the IPC the map (2.2) from physical to flat
coordinates). The quadratic case ``V(y) = y' P y`` is given by its matrix ``P`` (also used for
shapes that are no Lyapunov function, e.g. the paper's ball ``||T xi||^2``); any other V by
``V=`` (or :meth:`Region.from_lyapunov`). Basin maps draw ``V(coords(x)) = level`` on a slice,
Monte Carlo samples test containment, certificates certify a level.

For a non-quadratic V the set ``{V <= level}`` may have several connected components; a
certificate covers the one holding the equilibrium (``roa certify``), a Region holds them all.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov, QuadraticLyapunov, check_positive_definite, from_json


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
    """``{x : V(coords(x)) <= level}`` with its provenance.

    Give either ``P`` (the quadratic form ``y' P y``, the historical positional argument) or
    ``V`` (any :class:`roa.lyapunov.Lyapunov`, e.g. a ``PolynomialLyapunov``; a
    ``QuadraticLyapunov`` centred at 0 also sets ``P``). ``P`` is None for any other V.
    """

    name: str
    P: np.ndarray | None
    level: float
    status: str
    coords: Callable[[np.ndarray], np.ndarray] | None = None
    meta: dict[str, Any] = field(default_factory=dict, compare=False, hash=False)
    V: Lyapunov | None = field(default=None, compare=False, hash=False)

    def __post_init__(self) -> None:
        V, P = self.V, self.P
        if isinstance(P, Lyapunov):  # Region(name, V, level, status, ...)
            if V is not None:
                raise RoaInputError(f"region {self.name!r}: give P or V, not both")
            V, P = P, None
        if V is None:
            if P is None:
                raise RoaInputError(f"region {self.name!r}: give the matrix P or a Lyapunov V")
            P = check_positive_definite(P, what=f"region {self.name!r} P")
            V = QuadraticLyapunov(P, np.zeros(P.shape[0]), self.name)
        elif not isinstance(V, Lyapunov):
            raise RoaInputError(
                f"region {self.name!r}: V must be a roa.lyapunov.Lyapunov, got {type(V).__name__}"
            )
        elif P is not None:  # dataclasses.replace of a matrix region passes both: P wins
            E = V.ellipsoid_matrix()
            if E is None:
                raise RoaInputError(f"region {self.name!r}: give P or V, not both")
            P = check_positive_definite(P, what=f"region {self.name!r} P")
            if not np.array_equal(P, E):
                V = QuadraticLyapunov(P, np.zeros(P.shape[0]), V.name)
        else:
            P = V.ellipsoid_matrix()
        object.__setattr__(self, "P", P)
        object.__setattr__(self, "V", V)
        if not (np.isfinite(self.level) and self.level > 0):
            raise RoaInputError(
                f"region {self.name!r}: level must be finite and > 0, got {self.level!r}"
            )
        if self.status not in REGION_STATUSES:
            raise RoaInputError(
                f"region {self.name!r}: status {self.status!r} not in {REGION_STATUSES}"
            )

    @classmethod
    def from_lyapunov(
        cls,
        name: str,
        V: Lyapunov,
        level: float,
        status: str,
        coords: Callable[[np.ndarray], np.ndarray] | None = None,
        meta: dict[str, Any] | None = None,
    ) -> Region:
        """``{x : V(coords(x)) <= level}`` for any candidate ``V``."""
        return cls(name, None, level, status, coords, dict(meta or {}), V)

    @property
    def lyapunov(self) -> Lyapunov:
        """The candidate V (a ``QuadraticLyapunov`` centred at 0 for a region given by ``P``)."""
        assert self.V is not None  # set by __post_init__
        return self.V

    @property
    def degree(self) -> int | None:
        """The degree of a polynomial V (2 for a quadratic one), None for any other V."""
        V = self.lyapunov
        return V.degree

    def form(self, x: np.ndarray) -> np.ndarray:
        """``V(coords(x))`` (``y' P y`` for a quadratic V); ``inf`` where ``coords`` is undefined
        (non-finite analysis coordinates, outside the map's domain)."""
        x = np.asarray(x, dtype=float)
        y = x if self.coords is None else np.asarray(self.coords(x), dtype=float)
        ok = np.isfinite(y).all(axis=-1)
        V = self.lyapunov
        E = V.ellipsoid_matrix()
        with np.errstate(all="ignore"):
            if E is not None:
                v = np.einsum("...i,ij,...j->...", y, E, y)  # exactly as for a matrix P
            else:
                v = V.value(np.where(ok[..., None], y, V.center))
        return np.where(ok, v, np.inf)

    def contains(self, x: np.ndarray) -> np.ndarray:
        return self.form(x) <= self.level

    def describe_v(self) -> dict[str, Any]:
        """V as JSON: ``P`` (quadratic) or its kind, degree, monomials and coefficients, and its
        centre when not 0."""
        V = self.lyapunov
        P = V.quadratic_matrix()
        if P is not None:
            out: dict[str, Any] = {"P": P.tolist()}
        else:
            out = {k: v for k, v in V.describe().items() if k != "lyapunov"}
        if np.asarray(V.center).any():
            out["center"] = np.asarray(V.center, dtype=float).tolist()
        return out

    def to_json(self) -> dict[str, Any]:
        """``name``, ``P`` (quadratic V) or ``V`` (its kind, degree, monomials and coefficients),
        ``level``, ``status`` and the meta data; :meth:`from_json` reads it back."""
        v = self.describe_v()
        body = v if self.lyapunov.ellipsoid_matrix() is not None else {"V": v}
        return {"name": self.name, **body, "level": float(self.level), "status": self.status,
                **self.meta}  # fmt: skip

    @classmethod
    def from_json(
        cls,
        entry: Mapping[str, Any],
        coords: Callable[[np.ndarray], np.ndarray] | None = None,
        *,
        center: Any = None,
        meta: Mapping[str, Any] | None = None,
    ) -> Region:
        """A region from :meth:`to_json` (or any entry with ``name``, ``level``, ``status`` and
        ``P`` or a polynomial V, see :func:`roa.lyapunov.from_json`; ``center`` defaults to 0)."""
        for key in ("name", "level", "status"):
            if key not in entry:
                raise RoaInputError(f"region entry: missing {key!r}")
        name = str(entry["name"])
        drop = ("name", "P", "V", "center", "level", "status", "candidate_kind")
        extra = {k: v for k, v in entry.items() if k not in drop}
        extra.update(meta or {})
        if "P" in entry and not np.any(entry.get("center", 0.0)):  # the historical y' P y
            P = np.asarray(entry["P"], dtype=float)
            return cls(name, P, float(entry["level"]), str(entry["status"]), coords, extra)
        V = from_json(entry, center if center is not None else [], name=name)
        return cls.from_lyapunov(
            name, V, float(entry["level"]), str(entry["status"]), coords, extra
        )
