"""Certified terminal sets: trajectories that enter an interval-validated level set are finished.

A :class:`TerminalSet` is a sublevel set ``{V <= level}`` of a quadratic ``V(y) = (y - center)' P
(y - center)`` that ``roa certify`` validated (interval branch and bound): it is invariant and lies in
the region of attraction, so a trajectory that enters it converges. ``V`` may live in *analysis
coordinates* ``y = coords(x)`` other than the simulated ones (the IPC is simulated in physical
coordinates, its certified V lives in flat coordinates ``xi = to_flat(x)``): the system then
declares them in ``system.meta["analysis_coords"]`` (a callable ``name -> numpy map`` with a
``systems`` dict ``certified system name -> coordinates name``), and its numba factory
``system.meta["numba"](coords=name)`` returns the compiled map as a fourth element (the fast path
``system.meta["numba_fast"](coords=name)`` the map and the field fused with it, so the test after
each step costs only V; see roa/systems/ipc/fast.py).

Membership uses ``V(y) <= level (1 - REL_MARGIN)``: float error cannot let a point outside count.
Runs that enter are finished with status ``converged`` at the time of the accepted step that enters
(the batch integrators test every accepted step after the usual events, which take precedence);
initial conditions that start inside cost one evaluation of V.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.system import System

#: Relative margin of the membership test V <= level (1 - REL_MARGIN).
REL_MARGIN = 1e-9
#: Internal status code of the batch kernels for "entered the certified set" (reported as
#: CONVERGED, with ``entered`` set; never stored in chunk files).
ENTERED = 6
#: The reason reported for runs finished by the terminal set.
REASON = "entered certified set"


@dataclass(frozen=True, eq=False)
class TerminalSet:
    """A certified sublevel set ``{y : (y - center)' P (y - center) <= level}``, ``y = coords(x)``.

    Parameters
    ----------
    P : array (n, n)
        Symmetric positive-definite matrix of V.
    center : array (n,)
        Centre of V in the analysis coordinates (the equilibrium there).
    level : float
        The certified level (> 0).
    coords : str, optional
        Name of the analysis coordinates (``system.meta["analysis_coords"]``); None: the system's
        own coordinates.
    name : str
        A description for reports.
    """

    P: np.ndarray
    center: np.ndarray
    level: float
    coords: str | None = None
    name: str = "certified set"

    def __post_init__(self) -> None:
        P = np.array(self.P, dtype=float)
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
        c = np.array(self.center, dtype=float).reshape(-1)
        if c.shape != (P.shape[0],) or not np.isfinite(c).all():
            raise RoaInputError(f"TerminalSet.center must be {P.shape[0]} finite numbers")
        level = float(self.level)
        if not (np.isfinite(level) and level > 0):
            raise RoaInputError(
                f"TerminalSet.level must be a finite number > 0, got {self.level!r}"
            )
        if self.coords is not None and not isinstance(self.coords, str):
            raise RoaInputError(f"TerminalSet.coords must be a name or None, got {self.coords!r}")
        P.setflags(write=False)
        c.setflags(write=False)
        object.__setattr__(self, "P", P)
        object.__setattr__(self, "center", c)
        object.__setattr__(self, "level", level)

    def __repr__(self) -> str:  # exact (it enters run fingerprints)
        return (
            f"TerminalSet(P={self.P.tolist()!r}, center={self.center.tolist()!r}, "
            f"level={self.level!r}, coords={self.coords!r})"
        )

    @property
    def threshold(self) -> float:
        """Membership bound: ``V <= level (1 - REL_MARGIN)``."""
        return self.level * (1.0 - REL_MARGIN)

    def value(self, y: np.ndarray) -> np.ndarray:
        """V at analysis-coordinate points ``y`` of shape ``(..., n)`` (inf/NaN rows give inf/NaN)."""
        d = np.asarray(y, dtype=float) - self.center
        with np.errstate(all="ignore"):
            return np.einsum("...i,ij,...j->...", d, self.P, d)

    @classmethod
    def from_certificate(cls, source: str | Path | dict[str, Any], system: System) -> TerminalSet:
        """The certified set of ``roa certify --json`` output (a file or its dict) for ``system``.

        Refused (:class:`roa.errors.RoaInputError`) unless its status is ``certified`` and it is
        for ``system`` itself or for analysis coordinates ``system`` declares.
        """
        where = "terminal set" if isinstance(source, dict) else f"terminal set {source}"
        if isinstance(source, dict):
            data = source
        else:
            path = Path(source)
            if not path.is_file():
                raise RoaInputError(
                    f"{where}: no such file (give the JSON of `roa certify --json`)"
                )
            try:
                data = json.loads(path.read_text())
            except (OSError, ValueError, UnicodeDecodeError) as exc:
                raise RoaInputError(f"{where}: not a readable JSON file ({exc})") from None
        if not isinstance(data, dict):
            raise RoaInputError(
                f"{where}: expected the JSON object written by `roa certify --json`"
            )
        missing = [k for k in ("P", "level", "status", "system") if k not in data]
        if missing:
            raise RoaInputError(
                f"{where}: missing {', '.join(missing)} (expected the JSON of `roa certify --json`)"
            )
        if data["status"] != "certified":
            raise RoaInputError(
                f"{where}: status {data['status']!r}, not 'certified': only an interval-validated "
                "level set may finish trajectories"
            )
        cert_system = str(data["system"])
        if cert_system == system.name:
            coords = None
        else:
            declared = getattr(system.meta.get("analysis_coords"), "systems", {}) or {}
            if cert_system not in declared:
                raise RoaInputError(
                    f"{where}: the certificate is for system {cert_system!r}, not {system.name!r}"
                    + (f" (allowed: {', '.join([system.name, *declared])})" if declared else "")
                )
            coords = declared[cert_system]
        if data["level"] is None:
            raise RoaInputError(f"{where}: no level")
        try:
            P = np.asarray(data["P"], dtype=float)
        except (TypeError, ValueError):
            raise RoaInputError(f"{where}: P must be a list of rows of numbers") from None
        center = coords_map(system, coords)(system.x_eq[None, :])[0]
        name = f"{data.get('lyapunov', 'V')} <= {float(data['level']):.6g} ({cert_system})"
        return cls(P, center, data["level"], coords, name)

    def bind(self, system: System) -> BoundTerminal:
        """Check the set against ``system`` and resolve its coordinate map."""
        n = self.P.shape[0]
        if n != system.n:
            raise RoaInputError(
                f"terminal set: V has {n} variables, system {system.name!r} has {system.n} states"
            )
        cmap = coords_map(system, self.coords)
        if system.equilibrium is not None:
            v_eq = float(self.value(cmap(system.x_eq[None, :]))[0])
            if not v_eq < self.threshold:
                raise RoaInputError(
                    f"terminal set: the equilibrium of {system.name!r} is not inside it (V = "
                    f"{v_eq:.6g} at x_eq, level {self.level:.6g}); wrong centre or coordinates?"
                )
        return BoundTerminal(self, cmap)


def coords_map(system: System, coords: str | None) -> Callable[[np.ndarray], np.ndarray]:
    """The numpy map ``(m, n) -> (m, n)`` of the named analysis coordinates of ``system``."""
    if coords is None:
        return lambda x: np.asarray(x, dtype=float)
    provider = system.meta.get("analysis_coords")
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
            v = self.terminal.value(self.cmap(x))
        return v <= self.terminal.threshold  # NaN compares False
