"""Initial conditions for basin runs: 2D slices, seeded box samples, samples on/inside a Region.

A sampler is a small picklable object with ``n`` (number of points), ``dim`` and
``points(start, stop)`` returning rows ``start..stop-1`` in the simulated system's coordinates. The
rows depend only on their index (and the seed), never on how the run is chunked: random samplers
draw fixed blocks of :data:`BLOCK` rows from ``numpy.random.default_rng([seed, block])``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov._regions import Region
from roa.model._system import System

#: Rows per random block (a constant: chunk sizes never change the samples).
BLOCK = 4096
#: Most initial conditions of one sampler (a basin run keeps 5 bytes per initial condition, so
#: 5 GB at this bound); larger counts are refused before anything is allocated.
MAX_SAMPLES = 10**9


def check_count(n: Any, what: str = "n") -> int:
    """``n`` as an int in ``[1, MAX_SAMPLES]``, else :class:`RoaInputError` naming ``what``."""
    if isinstance(n, bool) or not isinstance(n, int | np.integer):
        raise RoaInputError(f"{what} must be an integer number of samples, got {n!r}")
    if not 1 <= int(n) <= MAX_SAMPLES:
        raise RoaInputError(f"{what} must be in [1, {MAX_SAMPLES:.0e}] (the maximum), got {n}")
    return int(n)


def _as_count(n: Any) -> int:
    """Accept integral floats such as ``1e6`` for a sample count, then check the bounds."""
    if isinstance(n, float | np.floating) and np.isfinite(n) and float(n).is_integer():
        n = int(n)
    return check_count(n, "samples (n)")


def _blocks(seed: int, start: int, stop: int, dim: int, draw: Callable) -> np.ndarray:
    out = []
    for b in range(start // BLOCK, (stop - 1) // BLOCK + 1):
        rows = draw(np.random.default_rng([int(seed), b]), (BLOCK, dim))
        lo, hi = max(start - b * BLOCK, 0), min(stop - b * BLOCK, BLOCK)
        out.append(rows[lo:hi])
    return np.concatenate(out) if out else np.empty((0, dim))


def _uniform(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    return rng.random(shape)


def _gauss_radius(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    # d Gaussian components (direction) and one uniform (radius), drawn together per block
    return np.concatenate([rng.standard_normal(shape), rng.random((shape[0], 1))], axis=1)


def axis_index(system: System, name: str) -> int:
    """Index of the state called ``name``; ValueError listing the allowed names."""
    if name not in system.state_names:
        raise RoaInputError(
            f"unknown state axis {name!r} for system {system.name!r}; "
            f"allowed: {', '.join(system.state_names)}"
        )
    return system.state_names.index(name)


@dataclass(frozen=True)
class GridSlice:
    """A ``nx x ny`` grid over two state axes, the other states fixed at ``base``.

    Row ``k`` is the point ``(ix, iy) = (k % nx, k // nx)``: ``x[axes[0]] = xs[ix]``,
    ``x[axes[1]] = ys[iy]``.
    """

    axes: tuple[int, int]
    xs: np.ndarray
    ys: np.ndarray
    base: np.ndarray

    @property
    def n(self) -> int:
        return len(self.xs) * len(self.ys)

    @property
    def dim(self) -> int:
        return len(self.base)

    @property
    def shape(self) -> tuple[int, int]:
        return (len(self.ys), len(self.xs))

    def points(self, start: int, stop: int) -> np.ndarray:
        k = np.arange(start, stop)
        x = np.repeat(self.base[None, :], k.size, axis=0)
        x[:, self.axes[0]] = self.xs[k % len(self.xs)]
        x[:, self.axes[1]] = self.ys[k // len(self.xs)]
        return x

    def fingerprint(self) -> dict[str, Any]:
        return {"kind": "grid", "axes": self.axes, "xs": self.xs, "ys": self.ys, "base": self.base}

    def describe(self, names: Sequence[str]) -> dict[str, Any]:
        """The samples in the states' names (what ``roa basin --json`` reports)."""
        axes = [names[i] for i in self.axes]
        return {"mode": "slice", "axes": axes, "grid": [len(self.xs), len(self.ys)],
                "ranges": [[float(v[0]), float(v[-1])] for v in (self.xs, self.ys)],
                "fixed": {n: float(self.base[i]) for i, n in enumerate(names) if i not in self.axes}}  # fmt: skip


def grid_slice(
    system: System,
    axes: Sequence[str],
    ranges: Sequence[tuple[float, float]],
    shape: tuple[int, int],
    *,
    fixed: dict[str, float] | None = None,
) -> GridSlice:
    """Build a slice over two named axes; fixed states default to the equilibrium.

    The fixed point (with the slice axes at their equilibrium values) must lie in the domain;
    slice values outside the domain are simply ``left_domain`` at t = 0.
    """
    if len(axes) != 2 or axes[0] == axes[1]:
        raise RoaInputError(f"axes: need two different state axes, got {list(axes)}")
    ia, ib = (axis_index(system, a) for a in axes)
    nx, ny = shape
    if nx < 2 or ny < 2:
        raise RoaInputError(f"shape: the grid must be at least 2x2, got {nx}x{ny}")
    base = system.x_eq.copy()
    for name, value in (fixed or {}).items():
        i = axis_index(system, name)
        if i in (ia, ib):
            raise RoaInputError(f"fixed: {name} is a slice axis, it cannot also be fixed")
        base[i] = float(value)
    shown = ", ".join(f"{n} = {float(v):g}" for n, v in zip(system.state_names, base, strict=True))
    system.check_state(base, what=f"fixed state ({shown})")
    for name, (lo, hi) in zip(axes, ranges, strict=True):
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise RoaInputError(f"range of {name}: need finite low < high, got ({lo}, {hi})")
    xs = np.linspace(*ranges[0], nx)
    ys = np.linspace(*ranges[1], ny)
    return GridSlice((ia, ib), xs, ys, base)


@dataclass(frozen=True)
class BoxSample:
    """``n`` seeded uniform samples of the box ``[low_i, high_i]``, optionally mapped by ``to_system``."""

    low: np.ndarray
    high: np.ndarray
    n: int
    seed: int
    to_system: Callable[[np.ndarray], np.ndarray] | None = None

    def __post_init__(self) -> None:
        if not (np.all(np.isfinite(self.low)) and np.all(np.isfinite(self.high))):
            raise RoaInputError("box bounds must be finite")
        if np.any(self.low > self.high):
            raise RoaInputError("box: every low bound must be <= its high bound")
        object.__setattr__(self, "n", check_count(self.n, "samples (n)"))

    @property
    def dim(self) -> int:
        return len(self.low)

    def points(self, start: int, stop: int) -> np.ndarray:
        u = _blocks(self.seed, start, stop, self.dim, _uniform)
        x = self.low + (self.high - self.low) * u
        return x if self.to_system is None else self.to_system(x)

    def fingerprint(self) -> dict[str, Any]:
        return {"kind": "box", "low": self.low, "high": self.high, "n": self.n, "seed": self.seed,
                "map": getattr(self.to_system, "__name__", None)}  # fmt: skip

    def describe(self, names: Sequence[str]) -> dict[str, Any]:
        """The samples in the states' names (what ``roa basin --json`` reports)."""
        box = {n: [float(a), float(b)] for n, a, b in zip(names, self.low, self.high, strict=True)}
        return {"mode": "box", "box": box, "seed": self.seed}


def box_sample(
    system: System, box: Sequence[tuple[float, float]], n: int, *, seed: int
) -> BoxSample:
    """Seeded uniform samples in a box of the system's states (one (low, high) per state)."""
    if len(box) != system.n:
        raise RoaInputError(
            f"box: needs {system.n} ranges ({', '.join(system.state_names)}), got {len(box)}"
        )
    arr = np.asarray(box, dtype=float)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or not 0 <= seed < 2**63:
        raise RoaInputError(f"seed must be an integer in [0, 2^63), got {seed!r}")
    return BoxSample(arr[:, 0], arr[:, 1], _as_count(n), int(seed))


@dataclass(frozen=True)
class RegionSample:
    """``n`` seeded samples inside (``mode="inside"``, uniform) or on the boundary (``"surface"``) of
    the ellipsoid ``{y : y'Py <= level}`` of a Region, in its analysis coordinates ``y``, mapped to
    the simulated system's coordinates by ``inverse`` (identity when ``None``)."""

    P: np.ndarray
    level: float
    n: int
    seed: int
    mode: str = "inside"
    inverse: Callable[[np.ndarray], np.ndarray] | None = None
    name: str = ""
    _Linv: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.mode not in ("inside", "surface"):
            raise RoaInputError(
                f"region sample mode must be 'inside' or 'surface', got {self.mode!r}"
            )
        object.__setattr__(self, "n", check_count(self.n, "samples (n)"))
        L = np.linalg.cholesky(self.P)  # P = L L'; y'Py = |L'y|^2
        object.__setattr__(self, "_Linv", np.linalg.inv(L.T))

    @property
    def dim(self) -> int:
        return self.P.shape[0]

    def analysis_points(self, start: int, stop: int) -> np.ndarray:
        raw = _blocks(self.seed, start, stop, self.dim, _gauss_radius)
        g, u = raw[:, : self.dim], raw[:, self.dim]
        d = g / np.linalg.norm(g, axis=1, keepdims=True)
        r = np.ones_like(u) if self.mode == "surface" else u ** (1.0 / self.dim)
        return (d * (r * np.sqrt(self.level))[:, None]) @ self._Linv.T

    def points(self, start: int, stop: int) -> np.ndarray:
        y = self.analysis_points(start, stop)
        return y if self.inverse is None else self.inverse(y)

    def fingerprint(self) -> dict[str, Any]:
        return {"kind": "region", "name": self.name, "P": self.P, "level": self.level, "n": self.n,
                "seed": self.seed, "mode": self.mode}  # fmt: skip


def region_sample(
    region: Region,
    n: int,
    *,
    seed: int,
    mode: str = "inside",
    inverse: Callable[[np.ndarray], np.ndarray] | None = None,
) -> RegionSample:
    """Sample a Region's set; ``inverse`` maps analysis coordinates back (e.g. ipc.from_flat)."""
    if region.coords is not None and inverse is None:
        raise RoaInputError(
            f"region {region.name!r} lives in other coordinates than the system: pass inverse= "
            "(the map from its analysis coordinates back to the system's)"
        )
    P = region.lyapunov.ellipsoid_matrix()
    if P is None:
        raise RoaInputError(
            f"region {region.name!r}: samples of a level set of a non-quadratic V are not "
            "implemented (ellipsoids only)"
        )
    return RegionSample(P, float(region.level), _as_count(n), int(seed), mode, inverse, region.name)
