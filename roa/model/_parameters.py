"""Boxes of uncertain parameters: their sample points, their pieces, and a field over a piece.

A system with uncertain parameters (``System(parameters={"mu": (low, nominal, high)})``) stands
for a family of fields. Here:

* :func:`sample_points`: parameter values where a search looks for the worst case (the nominal
  value, the vertices of the box, and a few points along each axis). They only *propose*: a
  property found at all of them is not proved between them.
* :class:`ParameterBox`: the box, its midpoint and vertices.
* :class:`RangeField` and :func:`over`: one system whose field, on the proof namespaces, sees the
  *whole* piece: every uncertain parameter is the interval ``[low, high]`` under the interval and
  jet namespaces (so an enclosure of ``V'`` on a state box holds for every parameter of the
  piece), a real sympy symbol under the sympy namespace (so an exact identity such as
  ``f(x_eq) = 0`` holds for every parameter value), and the piece's midpoint under the float
  namespaces (numpy, mpmath, CasADi), where searches look for witnesses. A witness found there is
  a witness for the parameter value :attr:`RangeField.point`, which lies in the piece.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import itertools
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.model._system import Params, System

#: Namespaces of enclosures: they see every uncertain parameter as its interval.
PROOF_NAMESPACES = ("interval", "interval-jet")
#: Float namespaces: they see the uncertain parameters at the piece's point (searches only, and
#: the probe of :mod:`roa.model._field_probe`).
POINT_NAMESPACES = ("numpy", "mpmath", "casadi", "probe")

#: At most this many vertices are sampled (2^4: all vertices up to 4 uncertain parameters).
MAX_VERTICES = 16


@dataclass(frozen=True)
class ParameterBox:
    """A box of parameter values: ``names[i]`` ranges over ``[lo[i], hi[i]]``."""

    names: tuple[str, ...]
    lo: tuple[float, ...]
    hi: tuple[float, ...]

    @classmethod
    def of(cls, system: System) -> ParameterBox:
        """The box of ``system``'s uncertain parameters (an error when it declares none)."""
        if not system.parameters:
            raise RoaInputError(f"system {system.name!r} declares no uncertain parameters")
        box = system.parameters
        return cls(tuple(box), tuple(r.low for r in box.values()),
                   tuple(r.high for r in box.values()))  # fmt: skip

    @property
    def midpoint(self) -> dict[str, float]:
        return {k: 0.5 * a + 0.5 * b for k, a, b in zip(self.names, self.lo, self.hi, strict=True)}

    def vertices(self) -> list[dict[str, float]]:
        """Every vertex (at most :data:`MAX_VERTICES`; beyond, the two ends of each axis through
        the midpoint)."""
        k = len(self.names)
        if 2**k <= MAX_VERTICES:
            return [dict(zip(self.names, v, strict=True))
                    for v in itertools.product(*zip(self.lo, self.hi, strict=True))]  # fmt: skip
        mid = self.midpoint
        out = []
        for i, name in enumerate(self.names):
            out += [{**mid, name: self.lo[i]}, {**mid, name: self.hi[i]}]
        return out

    def describe(self) -> str:
        return ", ".join(f"{k} in [{a:.6g}, {b:.6g}]"
                         for k, a, b in zip(self.names, self.lo, self.hi, strict=True))  # fmt: skip


def sample_points(system: System, per_axis: int = 0) -> list[dict[str, float]]:
    """Parameter values to search at: the nominal values, the box's vertices, and ``per_axis``
    interior points along each axis through the nominal point (no duplicates)."""
    box = ParameterBox.of(system)
    nominal = {k: r.nominal for k, r in system.parameters.items()}
    pts = [nominal, *box.vertices()]
    for i, name in enumerate(box.names):
        for t in np.linspace(0.0, 1.0, per_axis + 2)[1:-1]:
            pts.append({**nominal, name: float(box.lo[i] + t * (box.hi[i] - box.lo[i]))})
    seen, out = set(), []
    for p in pts:
        key = tuple(sorted(p.items()))
        if key not in seen:
            seen.add(key)
            out.append(p)
    return out


def describe_point(values: Mapping[str, float]) -> str:
    return ", ".join(f"{k} = {v:.10g}" for k, v in values.items())


#: Enclosures of the uncertain parameters set by a branch and bound over states *and* parameters
#: (jets whose variables include the parameters, or Intervals per box), read by RangeField.
_VALUES: contextvars.ContextVar[Sequence[Any] | None] = contextvars.ContextVar(
    "roa_parameter_values", default=None
)


@contextlib.contextmanager
def parameter_values(values: Sequence[Any] | None) -> Iterator[None]:
    """Within the block, a :class:`RangeField` gives the proof namespaces ``values`` (one per
    uncertain parameter, in the box's order: jets or Intervals, each enclosing the parameter on
    the boxes evaluated) instead of its box's intervals. The caller vouches that each holds the
    parameter's values on the boxes it evaluates; nothing outlives the block."""
    token = _VALUES.set(values)
    try:
        yield
    finally:
        _VALUES.reset(token)


@dataclass(frozen=True)
class RangeField:
    """A parametric field over a parameter box (see the module doc): ``fixed`` holds the values of
    the fixed parameters, ``box`` the ranges of the uncertain ones, ``point`` their float values
    for the float namespaces (a point of the box)."""

    func: Callable[..., Sequence[Any]]
    fixed: Params
    box: ParameterBox
    point: Params

    def params_for(self, xp: Any) -> Params:
        """The parameters seen by namespace ``xp``: the piece's intervals for the interval and
        jet namespaces, real symbols for sympy, the point for the float namespaces; any other
        namespace is refused (a proof must never see a point where it needs the box)."""
        name = getattr(xp, "name", None)
        if name in PROOF_NAMESPACES:
            Interval = xp.interval  # noqa: N806 - the proof namespaces' interval type
            given = _VALUES.get()
            if given is not None:
                if len(given) != len(self.box.names):
                    raise RoaInputError(
                        f"{len(given)} parameter enclosures for {len(self.box.names)} parameters"
                    )
                vals = list(given)
                if name == "interval":  # the value enclosure of a jet
                    vals = [v if isinstance(v, Interval) else v.v for v in vals]
                return Params({**self.fixed, **dict(zip(self.box.names, vals, strict=True))})
            ranges = {k: Interval(a, b) for k, a, b in zip(self.box.names, self.box.lo,
                                                            self.box.hi, strict=True)}  # fmt: skip
            return Params({**self.fixed, **ranges})
        if name == "sympy":
            import sympy as sp

            return Params({**self.fixed, **{k: sp.Symbol(k, real=True) for k in self.box.names}})
        if name in POINT_NAMESPACES:
            return Params({**self.fixed, **self.point})
        raise RoaInputError(
            f"a field over a parameter box cannot be evaluated in namespace {name!r} (known: "
            f"{', '.join(PROOF_NAMESPACES + POINT_NAMESPACES)}, sympy)"
        )

    def __call__(self, t: Any, x: Any, xp: Any) -> Sequence[Any]:
        return self.func(t, x, xp, self.params_for(xp))


def over(system: System, box: ParameterBox | None = None, point: Mapping[str, float] | None = None
         ) -> System:  # fmt: skip
    """``system`` with its uncertain parameters ranging over ``box`` (default: all of their box)
    on the proof namespaces and fixed at ``point`` (default: the box's midpoint) on the float
    ones. The result declares no parameters: every analysis reads it as one field."""
    box = ParameterBox.of(system) if box is None else box
    point = box.midpoint if point is None else dict(point)
    func = getattr(system.dynamics, "func", None)
    if func is None:
        raise RoaInputError(f"system {system.name!r}: its field takes no parameters")
    fixed = Params({k: v for k, v in system.params.items() if k not in box.names})
    field = RangeField(func, fixed, box, Params(point))
    slot: dict[str, Any] = {"field" if system.time == "continuous" else "map": field}
    return dataclasses.replace(system, **slot, params=None, parameters=None,  # a map: its box
                               numba=None, numba_fast=None)  # fmt: skip
