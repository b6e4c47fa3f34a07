"""Certified terminal sets: trajectories that enter an interval-validated level set are finished.

A :class:`TerminalSet` is a sublevel set ``{V <= level}`` of a quadratic ``V(y) = (y - center)' P
(y - center)`` that ``roa certify`` validated (interval branch and bound): it is invariant and lies in
the region of attraction, so a trajectory that enters it converges. ``V`` may live in *analysis
coordinates* ``y = coords(x)`` other than the simulated ones (the IPC is simulated in physical
coordinates, its certified V lives in flat coordinates ``xi = to_flat(x)``): the system then
declares them in ``system.analysis_coords`` (a callable ``name -> numpy map`` with a
``systems`` dict ``certified system name -> coordinates name``), and its numba factory
``system.numba(coords=name)`` returns the compiled map as a fourth element (the fast path
``system.numba_fast(coords=name)`` the map and the field fused with it, so the test after
each step costs only V; see ipc_paper/system/fast.py).

Membership uses ``V(y) <= level (1 - REL_MARGIN)``: float error cannot let a point outside count.

A polynomial V (``roa certify --degree D``, ``candidate_kind`` in its JSON) is accepted too: a
degree-2 one becomes the quadratic form above; for a higher degree the set is ``{V <= level}``
inside a box proved to lie in the bounding box of the certified component of the level set (the
one holding the equilibrium; :mod:`roa.proof._component`), tested with the same
arithmetic in numpy and in the numba kernels (:mod:`roa.integration._terminal_poly`, which also
allows for the rounding error of V).
Runs that enter are finished with status ``converged`` at the time of the accepted step that enters
(the batch integrators test every accepted step after the usual events, which take precedence);
initial conditions that start inside cost one evaluation of V.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from roa.errors import RoaInputError
from roa.integration._terminal_poly import PolyArrays, member_numpy, poly_arrays
from roa.model._system import System
from roa.proof._component import component_box

if TYPE_CHECKING:
    from roa.lyapunov import PolynomialLyapunov

#: Relative margin of the membership test V <= level (1 - REL_MARGIN).
REL_MARGIN = 1e-9
#: Internal status code of the batch kernels for "entered the certified set" (reported as
#: CONVERGED, with ``entered`` set; never stored in chunk files).
ENTERED = 6
#: The reason reported for runs finished by the terminal set.
REASON = "entered certified set"


class TerminalSet:
    """A certified sublevel set ``{y : V(y) <= level}``, ``y = coords(x)``.

    Quadratic (the fast path of the numba kernels): ``TerminalSet(P, center, level, coords, name)``
    with ``V(y) = (y - center)' P (y - center)``. Polynomial: :meth:`polynomial` with a
    :class:`~roa.lyapunov.PolynomialLyapunov` and the box (in the validation frame
    ``z = M^-1 (y - center)``) of :func:`roa.proof._component.component_box`: the set is
    ``{V <= level}`` inside that box (the certified component).

    Parameters
    ----------
    P : array (n, n)
        Symmetric positive-definite matrix of a quadratic V.
    center : array (n,)
        Centre of V in the analysis coordinates (the equilibrium there).
    level : float
        The certified level (> 0).
    coords : str, optional
        Name of the analysis coordinates (``system.analysis_coords``); None: the system's
        own coordinates.
    name : str
        A description for reports.
    """

    __slots__ = ("_P", "center", "level", "coords", "name", "V", "frame", "box", "poly")
    _P: np.ndarray | None
    center: np.ndarray
    level: float
    coords: str | None
    name: str
    V: PolynomialLyapunov | None
    frame: np.ndarray | None
    box: tuple[np.ndarray, np.ndarray] | None
    poly: PolyArrays | None

    def __init__(
        self,
        P: Any,
        center: Any,
        level: float,
        coords: str | None = None,
        name: str = "certified set",
    ) -> None:
        P = np.array(P, dtype=float)
        if P.ndim != 2 or P.shape[0] != P.shape[1] or P.shape[0] == 0:
            raise RoaInputError(f"TerminalSet.P must be a square matrix, got shape {P.shape}")
        if not np.isfinite(P).all():
            raise RoaInputError("TerminalSet.P must be finite")
        if not np.allclose(P, P.T, rtol=1e-12, atol=0.0):
            raise RoaInputError("TerminalSet.P must be symmetric")
        P = 0.5 * (P + P.T)
        try:
            np.linalg.cholesky(P)
        except np.linalg.LinAlgError:
            raise RoaInputError("TerminalSet.P must be positive definite") from None
        P.setflags(write=False)
        self._init(P, center, level, coords, name, None, None, None)

    def _init(self, P: np.ndarray | None, center: Any, level: float, coords: str | None,
              name: str, V: Any, frame: Any, box: Any) -> None:  # fmt: skip
        n = P.shape[0] if P is not None else V.n
        c = np.array(center, dtype=float).reshape(-1)
        if c.shape != (n,) or not np.isfinite(c).all():
            raise RoaInputError(f"TerminalSet.center must be {n} finite numbers")
        lvl = float(level)
        if not (np.isfinite(lvl) and lvl > 0):
            raise RoaInputError(f"TerminalSet.level must be a finite number > 0, got {level!r}")
        if coords is not None and not isinstance(coords, str):
            raise RoaInputError(f"TerminalSet.coords must be a name or None, got {coords!r}")
        c.setflags(write=False)
        poly = None if V is None else poly_arrays(V, frame, box)
        for k, v in (("_P", P), ("center", c), ("level", lvl), ("coords", coords),
                     ("name", str(name)), ("V", V), ("frame", frame), ("box", box),
                     ("poly", poly)):  # fmt: skip
            object.__setattr__(self, k, v)

    @classmethod
    def polynomial(
        cls,
        V: PolynomialLyapunov,
        level: float,
        coords: str | None = None,
        name: str = "certified set",
        *,
        frame: Any,
        box: Any = None,
        propose: Callable[..., Any] | None = None,
    ) -> TerminalSet:
        """``{y : V(y) <= level(1 - REL_MARGIN), z in box}`` with ``z = frame^-1 (y - V.center)``.

        ``frame`` must be the frame ``M`` of the validation that proved the level (``x = x_eq +
        M y``; the ``"M"`` of its JSON, or :attr:`roa.proof._reverify.Reverified.frame`): the
        component box is sound in that frame only, so there is no default. ``box`` ``(lo, hi)``
        must lie in the bounding box of the component of ``{V <= level}`` holding the centre;
        without it, ``propose(V, level, M)`` proposes points of the component's sides
        (:func:`roa.search.component_candidates`) and
        :func:`roa.proof._component.component_box` proves the box from them."""

        if not V.is_polynomial:
            raise RoaInputError(
                f"TerminalSet.polynomial: V must be a PolynomialLyapunov, got {type(V).__name__}"
            )
        n = V.n
        try:
            M = np.array(frame, dtype=float)
        except (TypeError, ValueError):
            raise RoaInputError(f"TerminalSet.frame must be an invertible {n}x{n} matrix") from None
        if M.shape != (n, n) or not np.isfinite(M).all() or abs(np.linalg.det(M)) == 0:
            raise RoaInputError(f"TerminalSet.frame must be an invertible {n}x{n} matrix")
        if box is None:
            if propose is None:
                raise RoaInputError(
                    "TerminalSet.polynomial: give the component box (box=) or its proposer "
                    "(propose=roa.search.component_candidates)"
                )
            box = component_box(V, float(level), M, propose(V, float(level), M))
        lo, hi = (np.array(b, dtype=float).reshape(-1) for b in box)
        if (
            lo.shape != (n,)
            or hi.shape != (n,)
            or not (np.isfinite(lo).all() and np.isfinite(hi).all())
        ):
            raise RoaInputError(f"TerminalSet.box must be two vectors of {n} finite numbers")
        for a in (M, lo, hi):
            a.setflags(write=False)
        self = cls.__new__(cls)
        self._init(None, V.center, level, coords, name, V, M, (lo, hi))
        return self

    def __setattr__(self, key: str, value: Any) -> None:
        raise AttributeError(f"TerminalSet is immutable: cannot set {key!r}")

    def __reduce__(self) -> tuple[Any, ...]:  # immutable with slots: pickled by its fields
        fields = (self._P, self.center, self.level, self.coords, self.name, self.V, self.frame,
                  self.box)  # fmt: skip
        return (_restore, fields)

    @property
    def quadratic(self) -> bool:
        """Whether V is quadratic (an ellipsoid with its matrix :attr:`P`)."""
        return self._P is not None

    @property
    def P(self) -> np.ndarray:
        """The matrix of a quadratic V; a polynomial V has none (see :attr:`poly`)."""
        if self._P is None:
            raise RoaInputError(
                f"terminal set {self.name!r}: V is a degree-{self.degree} polynomial, not x'Px"
            )
        return self._P

    @property
    def n(self) -> int:
        return int(self.center.shape[0])

    @property
    def degree(self) -> int:
        return 2 if self.V is None else int(self.V.degree)

    def __repr__(self) -> str:  # exact (it enters run fingerprints)
        if self._P is not None:
            return (
                f"TerminalSet(P={self._P.tolist()!r}, center={self.center.tolist()!r}, "
                f"level={self.level!r}, coords={self.coords!r})"
            )
        assert self.V is not None and self.frame is not None and self.box is not None
        poly = self.V.polynomial_view()
        assert poly is not None  # checked by TerminalSet.polynomial
        terms = [[list(a), c] for a, c in poly.items()]
        return (
            f"TerminalSet(V={terms!r}, center={self.center.tolist()!r}, level={self.level!r}, "
            f"coords={self.coords!r}, frame={self.frame.tolist()!r}, "
            f"box={[self.box[0].tolist(), self.box[1].tolist()]!r})"
        )

    @property
    def threshold(self) -> float:
        """Membership bound: ``V <= level (1 - REL_MARGIN)``."""
        return self.level * (1.0 - REL_MARGIN)

    def value(self, y: np.ndarray) -> np.ndarray:
        """V at analysis-coordinate points ``y`` of shape ``(..., n)`` (inf/NaN rows give inf/NaN)."""
        if self._P is not None:
            d = np.asarray(y, dtype=float) - self.center
            with np.errstate(all="ignore"):
                return np.einsum("...i,ij,...j->...", d, self._P, d)
        assert self.V is not None
        y = np.asarray(y, dtype=float)
        ok = np.isfinite(y).all(axis=-1)
        with np.errstate(all="ignore"):
            v = self.V.value(np.where(ok[..., None], y, self.center))
        return np.where(ok, v, np.where(np.isnan(y).any(axis=-1), np.nan, np.inf))

    def contains(self, y: np.ndarray) -> np.ndarray:
        """Analysis-coordinate points ``y`` (shape ``(m, n)``) inside the set, with the margin."""
        y = np.asarray(y, dtype=float)
        if self.poly is not None:  # the kernels' arithmetic (roa/integration/_terminal_poly.py)
            return member_numpy(y, self.center, self.poly, self.threshold)
        return self.value(y) <= self.threshold  # NaN compares False

    def bind(self, system: System) -> BoundTerminal:
        """Check the set against ``system`` and resolve its coordinate map."""
        n = self.n
        if n != system.n:
            raise RoaInputError(
                f"terminal set: V has {n} variables, system {system.name!r} has {system.n} states"
            )
        cmap = coords_map(system, self.coords)
        if system.equilibrium is not None:
            y_eq = cmap(system.x_eq[None, :])
            v_eq = float(self.value(y_eq)[0])
            if not (v_eq < self.threshold and self.contains(y_eq)[0]):
                raise RoaInputError(
                    f"terminal set: the equilibrium of {system.name!r} is not inside it (V = "
                    f"{v_eq:.6g} at x_eq, level {self.level:.6g}); wrong centre or coordinates?"
                )
        return BoundTerminal(self, cmap)


def _restore(*fields: Any) -> TerminalSet:
    out = TerminalSet.__new__(TerminalSet)
    out._init(*fields)
    return out


def coords_map(system: System, coords: str | None) -> Callable[[np.ndarray], np.ndarray]:
    """The numpy map ``(m, n) -> (m, n)`` of the named analysis coordinates of ``system``."""
    if coords is None:
        return lambda x: np.asarray(x, dtype=float)
    provider = system.analysis_coords
    names = getattr(provider, "names", ())
    if provider is None or coords not in names:
        raise RoaInputError(
            f"terminal set: system {system.name!r} declares no analysis coordinates {coords!r}"
            + (f" (it has {', '.join(names)})" if names else "")
        )
    return provider(coords)


@dataclass(frozen=True)
class BoundTerminal:
    """A :class:`TerminalSet` resolved for one system (numpy membership test)."""

    terminal: TerminalSet
    cmap: Callable[[np.ndarray], np.ndarray]

    def inside(self, x: np.ndarray) -> np.ndarray:
        """Rows of ``x`` (simulated coordinates) strictly inside the set (with the margin)."""
        if x.shape[0] == 0:
            return np.zeros(0, bool)
        with np.errstate(all="ignore"):
            y = self.cmap(x)
        return self.terminal.contains(y)  # NaN compares False


def kernel_terminal(terminal: TerminalSet | None, n: int) -> tuple[Any, ...]:
    """The terminal set as the numba kernels take it: ``(kind, P, center, threshold, Mi, E, A,
    B, g, D)``, kind 0 (none), 1 (quadratic: ``P``) or 2 (polynomial: the arrays of
    :class:`roa.integration._terminal_poly.PolyArrays`; unused entries are empty)."""
    z2, e = np.zeros((n, n)), np.zeros((0, n), np.int64)
    if terminal is None:
        return (0, z2, np.zeros(n), -np.inf, z2, e, np.zeros(0), np.zeros((2, n)), 0.0, 0)
    c, thr = np.array(terminal.center), float(terminal.threshold)
    if terminal.quadratic:
        return (1, np.array(terminal.P), c, thr, z2, e, np.zeros(0), np.zeros((2, n)), 0.0, 0)
    assert terminal.poly is not None
    Mi, E, A, B, g, D = terminal.poly
    return (2, z2, c, thr, Mi, E, A, B, g, D)
