"""Numba-compiled scalar fields of the IPC closed loops, for the batch integrator.

The same formulas as :func:`ipc_paper.system.closed_loop` (physical coordinates, zero reference,
optional saturation) and :func:`ipc_paper.system.transformed` ((3.8), flat coordinates), written as
scalar code. ``ipc_paper/tests/test_montecarlo.py`` checks them against ``System.f`` on random states.
Parameters travel in an array ``params = (delta, h0, h1, h2, h3, saturation or nan)``.

Each function exists twice, from one body: as a ``numba.cfunc`` of the public signatures of
roa/integration/_integrator.py (``System.numba``, the protocol user systems follow) and as
a ``numba.njit`` function for the fast path (``System.numba_fast``, preferred by the
engine: the kernel is compiled for these functions and calls them directly, no call through a
pointer; :func:`roa.integration.compile_kernel`). The fast path also fuses the field
with the map to the coordinates of a terminal set, so the set test after each step reuses the
field's sin, cos and log. ``ipc_paper/tests/test_terminal_fastpath.py`` checks that both paths give the
same trajectories bit for bit.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np

from roa.integration import (
    COORDS_SIGNATURE,
    FIELD_SIGNATURE,
    MARGIN_SIGNATURE,
    LazyCfuncs,
    no_margin_njit,
)

if TYPE_CHECKING:
    from roa.model import System

HALF_PI = np.pi / 2


@numba.njit(cache=True, error_model="numpy", inline="always")
def physical_scalar(q, qd, th, thd, p):
    """The closed loop in physical coordinates, zero reference, on scalars: ``(q', q'', theta',
    theta'', s, c, sec, a)`` with ``s, c = sin, cos theta``, ``sec = 1 / c`` and ``a = log((1 +
    |s|) |sec|)`` (for the coordinate maps of :func:`_physical`)."""
    delta = p[0]
    s, c = np.sin(th), np.cos(th)
    sec = 1.0 / c
    w1 = s * sec
    # (2.2) with arsinh(tan th) = sign(sin th cos th) log((1 + |sin th|) / |cos th|)
    a = np.log((1.0 + abs(s)) * abs(sec))
    z1 = q + (a if s * c >= 0.0 else -a)
    z2 = qd + thd * sec
    w2 = thd * sec * sec
    v = -(p[1] * z1 + p[2] * z2 + p[3] * w1 + p[4] * w2)
    # corrected (2.5) simplified with 1 + w1^2 = sec^2 and delta (1 + w1^2) + w1^2 = den / cos^2:
    # phi2 / phi1 = (1 + delta) w1, 1 / phi1 = den |cos|, phi3 = w1 cos^2 (2 - cos^2 / den)
    den = delta + s * s
    inv_den = 1.0 / den
    c2 = c * c
    phi3 = w1 * c2 * (2.0 - c2 * inv_den)
    u = (1.0 + delta) * w1 + (w2 * w2 * phi3 - v) * den * abs(c)
    sat = p[5]
    if sat == sat:  # not NaN: saturate
        if u > sat:
            u = sat
        elif u < -sat:
            u = -sat
    f1 = (u + thd * thd * s - s * c) * inv_den
    f3 = (-u * c - thd * thd * s * c + (1.0 + delta) * s) * inv_den
    return qd, f1, thd, f3, s, c, sec, a


@numba.njit(cache=True, error_model="numpy", inline="always")
def _physical(x, p, out, w, mode):
    """The closed loop in physical coordinates (q, q', theta, theta'), zero reference, into
    ``out``; with ``mode`` 1 (2) also the flat (hybrid) coordinates of ``x`` into ``w``, bit for
    bit what :func:`_to_flat` (and ``physical_to_hybrid``) give, from the same sin, cos and
    log."""
    q, qd, th, thd = x[0], x[1], x[2], x[3]
    out[0], out[1], out[2], out[3], s, c, sec, a = physical_scalar(q, qd, th, thd, p)
    if mode == 0:
        return
    if not (abs(th) < HALF_PI) or not (abs(q) < np.inf and abs(qd) < np.inf and abs(thd) < np.inf):
        for i in range(4):
            w[i] = np.inf
        return
    # the expressions of _to_flat, on the same s, c, sec, a
    f0 = q + (a if s >= 0.0 else -a)
    if mode == 1:
        w[0] = f0
    else:  # hybrid: q where the flat z1 is finite (as physical_to_hybrid)
        w[0] = q if f0 < np.inf else np.inf
    w[1] = qd + thd * sec
    w[2] = s * sec  # w1, the same product
    w[3] = thd * sec * sec


def _physical_field(t: float, x: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """Closed loop in physical coordinates (q, q', theta, theta'), zero reference."""
    _physical(x, p, out, out, 0)


@numba.njit(cache=True, error_model="numpy")
def physical_field_njit(t: float, x: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """``physical_field`` for the fast path."""
    _physical(x, p, out, out, 0)


@numba.njit(cache=True, error_model="numpy")
def physical_field_flat_njit(
    t: float, x: np.ndarray, p: np.ndarray, out: np.ndarray, w: np.ndarray
) -> None:
    """``physical_field`` and ``physical_to_flat`` of ``x`` in one call (fast path)."""
    _physical(x, p, out, w, 1)


@numba.njit(cache=True, error_model="numpy")
def physical_field_hybrid_njit(
    t: float, x: np.ndarray, p: np.ndarray, out: np.ndarray, w: np.ndarray
) -> None:
    """``physical_field`` and ``physical_to_hybrid`` of ``x`` in one call (fast path)."""
    _physical(x, p, out, w, 2)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _margin(x, p):
    return HALF_PI - abs(x[2])


def _physical_margin(x: np.ndarray, p: np.ndarray) -> float:
    """pi/2 - |theta|."""
    return _margin(x, p)


@numba.njit(cache=True, error_model="numpy")
def physical_margin_njit(x: np.ndarray, p: np.ndarray) -> float:
    """``physical_margin`` for the fast path."""
    return _margin(x, p)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _flat(x, p, out):
    w1, w2 = x[2], x[3]
    r = 1.0 + w1 * w1
    out[0] = x[1]
    out[1] = w1 + w1 / (r * np.sqrt(r)) * w2 * w2
    out[2] = w2
    out[3] = -(p[1] * x[0] + p[2] * x[1] + p[3] * w1 + p[4] * w2)


def _flat_field(t: float, x: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """The closed loop (3.8) in flat coordinates (z1, z2, w1, w2)."""
    _flat(x, p, out)


@numba.njit(cache=True, error_model="numpy")
def flat_field_njit(t: float, x: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """``flat_field`` for the fast path."""
    _flat(x, p, out)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _to_flat(x, out):
    th = x[2]
    if not (abs(th) < HALF_PI) or not (abs(x[0]) < np.inf and abs(x[1]) < np.inf
                                        and abs(x[3]) < np.inf):  # fmt: skip
        for i in range(4):
            out[i] = np.inf
        return
    # as in physical_field: one sin, cos and log instead of tan, cos and arsinh (cheaper;
    # agrees with coordinates.to_flat to a few ulp, far inside the 1e-9 margin of the set test)
    s, c = np.sin(th), np.cos(th)
    sec = 1.0 / c
    a = np.log((1.0 + abs(s)) * abs(sec))
    out[0] = x[0] + (a if s >= 0.0 else -a)
    out[1] = x[1] + x[3] * sec
    out[2] = s * sec
    out[3] = x[3] * sec * sec


@numba.njit(cache=True, error_model="numpy", inline="always")
def _to_hybrid(x, out):
    _to_flat(x, out)
    if out[0] < np.inf:
        out[0] = x[0]


def _physical_to_flat(x: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """(2.2): physical -> flat ``(z1, z2, w1, w2)``; inf outside |theta| < pi/2 or if not finite."""
    _to_flat(x, out)


def _physical_to_hybrid(x: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """Physical -> hybrid ``(q, z2, w1, w2)`` (ipc_paper/system/hybrid.py); inf as above."""
    _to_hybrid(x, out)


@numba.njit(cache=True, error_model="numpy")
def physical_to_flat_njit(x: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """``physical_to_flat`` for the fast path."""
    _to_flat(x, out)


@numba.njit(cache=True, error_model="numpy")
def physical_to_hybrid_njit(x: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """``physical_to_hybrid`` for the fast path."""
    _to_hybrid(x, out)


#: The public cfuncs (``System.numba``), compiled on first access (not at import): each is
#: ``numba.cfunc(SIGNATURE, cache=True, error_model="numpy")`` of the function ``_NAME`` above.
__getattr__ = LazyCfuncs(
    __name__,
    {
        "physical_field": (FIELD_SIGNATURE, _physical_field),
        "physical_margin": (MARGIN_SIGNATURE, _physical_margin),
        "flat_field": (FIELD_SIGNATURE, _flat_field),
        "physical_to_flat": (COORDS_SIGNATURE, _physical_to_flat),
        "physical_to_hybrid": (COORDS_SIGNATURE, _physical_to_hybrid),
    },
)


def compiled_coords(name: str):
    """The compiled analysis-coordinate map ``name`` ("flat" or "hybrid") of the physical closed
    loop (terminal sets); KeyError for another name."""
    return __getattr__({"flat": "physical_to_flat", "hybrid": "physical_to_hybrid"}[name])


#: The same for the fast path: (map, field fused with the map).
FAST_COORDS = {
    "flat": (physical_to_flat_njit, physical_field_flat_njit),
    "hybrid": (physical_to_hybrid_njit, physical_field_hybrid_njit),
}


class PhysicalKernels:
    """Picklable factory for ``System.numba`` (physical coordinates).

    ``kernels()`` returns ``(field, margin, params)``; ``kernels(coords=name)`` adds the compiled
    map ``coords(x, params, out)`` to the analysis coordinates ``name`` (:func:`compiled_coords`)
    of a terminal set (roa/integration/_terminal.py).
    """

    def __init__(self, delta: float, h: Sequence[float], saturation: float | None) -> None:
        sat = np.nan if saturation is None else float(saturation)
        self.params = np.array([float(delta), *map(float, h), sat])

    def __call__(self, coords: str | None = None):
        field, margin = __getattr__("physical_field"), __getattr__("physical_margin")
        if coords is None:
            return field, margin, self.params
        return field, margin, self.params, compiled_coords(coords)


class PhysicalFastKernels(PhysicalKernels):
    """Picklable factory for ``System.numba_fast`` (physical coordinates): the functions of
    :class:`PhysicalKernels` as ``numba.njit`` functions, for
    :func:`roa.integration.compile_kernel`. ``kernels()`` returns ``(field, margin,
    params)``; ``kernels(coords=name)`` adds the map to ``name`` and the field fused with it."""

    def __call__(self, coords: str | None = None):
        if coords is None:
            return physical_field_njit, physical_margin_njit, self.params
        cmap, fused = FAST_COORDS[coords]
        return physical_field_njit, physical_margin_njit, self.params, cmap, fused


class AnalysisCoords:
    """``System.analysis_coords`` of the physical closed loop (roa/integration/_terminal.py).

    ``coords(name)`` is the numpy map physical -> ``name`` (inf outside |theta| < pi/2);
    ``systems`` maps the names of certified systems (``roa certify --json``) to their coordinates.
    Only declared without saturation: the flat closed loop (3.8) is the physical one only then.
    """

    names = ("flat", "hybrid")

    def __init__(self, default_gains: bool) -> None:
        # certificates carry the system name only: the built-in flat/hybrid systems have the
        # default gains, so they match only a closed loop with those gains
        self.systems = {"ipc_flat": "flat", "ipc_hybrid": "hybrid"} if default_gains else {}

    def system(self, name: str) -> System:
        """The closed loop in the coordinates ``name`` (what a certificate there is about)."""
        if name == "flat":
            from ipc_paper.system import transformed

            return transformed()
        if name == "hybrid":
            from ipc_paper.system.hybrid import hybrid

            return hybrid()
        raise KeyError(name)

    def __call__(self, name: str):
        if name == "flat":
            from ipc_paper.system.coordinates import physical_to_flat_or_inf

            return physical_to_flat_or_inf
        if name == "hybrid":
            from ipc_paper.system.hybrid import physical_to_hybrid_or_inf

            return physical_to_hybrid_or_inf
        raise KeyError(name)


class FlatKernels:
    """Picklable zero-argument factory for ``System.numba`` (flat coordinates)."""

    def __init__(self, h: Sequence[float]) -> None:
        self.params = np.array([1.0, *map(float, h), np.nan])

    def __call__(self):
        from roa.integration import no_margin

        return __getattr__("flat_field"), no_margin, self.params


class FlatFastKernels(FlatKernels):
    """Picklable factory for ``System.numba_fast`` (flat coordinates, njit functions)."""

    def __call__(self):
        return flat_field_njit, no_margin_njit, self.params
