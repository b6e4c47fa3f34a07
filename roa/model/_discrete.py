"""Discrete-time systems from continuous ones: the Euler or RK4 step of a field with sample time h.

:func:`discretise` turns ``x' = f(x)`` into the map ``x+ = F(x)`` of one explicit step of size
``h`` (a plant with a controller sampled and held over the step when the controller is part of
``f`` and evaluated at the step's stages; for a zero-order hold write the map yourself with
:meth:`roa.System.discrete`). The step is written with arithmetic only, against the same array
namespace as the field, so it runs in every namespace the field does (numpy, CasADi, sympy,
mpmath, intervals and jets): every analysis of a discrete-time system applies to it.

**What is certified is the map itself**, with its constants the doubles ``h``, ``h / 2`` and
``h / 6`` as written (they are exact in the interval arithmetic): it is the system the Monte Carlo
runs iterate, not the flow it approximates.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from roa.errors import RoaInputError
from roa.model._system import BoundField, System

#: The explicit one-step methods of :func:`discretise`.
METHODS = ("euler", "rk4")


@dataclass(frozen=True)
class Step:
    """One explicit step of size ``h`` of the field ``func`` (picklable): ``(t, x, xp[, p])``."""

    func: Callable[..., Sequence[Any]]
    h: float
    method: str
    with_params: bool

    def __call__(self, t: Any, x: Any, xp: Any, p: Any = None) -> list[Any]:
        def f(s: Any, y: list[Any]) -> list[Any]:
            return list(self.func(s, y, xp, p) if self.with_params else self.func(s, y, xp))

        x = [x[i] for i in range(len(x))]
        h = self.h
        if self.method == "euler":
            k1 = f(t, x)
            return [x[i] + k1[i] * h for i in range(len(x))]
        h2, h6 = h / 2.0, h / 6.0
        k1 = f(t, x)
        k2 = f(t + h2, [x[i] + k1[i] * h2 for i in range(len(x))])
        k3 = f(t + h2, [x[i] + k2[i] * h2 for i in range(len(x))])
        k4 = f(t + h, [x[i] + k3[i] * h for i in range(len(x))])
        return [x[i] + (k1[i] + (k2[i] + k3[i]) * 2.0 + k4[i]) * h6 for i in range(len(x))]


def discretise(system: System, h: float, method: str = "rk4", *, name: str | None = None) -> System:
    """The discrete-time system ``x+ = F(x)``, ``F`` one ``method`` step of size ``h`` of
    ``system``'s field (``"euler"``: ``x + h f(x)``; ``"rk4"``: the classical Runge-Kutta step).

    The result keeps the equilibrium (a zero of ``f`` is a fixed point of either step, exactly),
    the domain, the state names and units, the norm and the parameters (fixed ones and ranges:
    :meth:`roa.System.with_params` and :meth:`roa.System.at` work on it); its ``sample_time`` is
    ``h``. A ``lyapunov`` matrix of the flow is not kept (the default candidate of a map solves
    ``A'PA - P = -I``).

    Examples
    --------
    >>> from roa.systems.vanderpol import vanderpol
    >>> d = discretise(vanderpol(), 0.05)
    >>> d.time, d.sample_time, d.name
    ('discrete', 0.05, 'vanderpol-rk4-h0.05')
    """
    if system.time != "continuous":
        raise RoaInputError(f"system {system.name!r} is already discrete-time")
    if system.time_varying:
        raise RoaInputError(f"system {system.name!r} is time-varying: discretise an autonomous one")
    if method not in METHODS:
        raise RoaInputError(f"method must be one of {METHODS}, got {method!r}")
    if isinstance(h, bool) or not isinstance(h, int | float) or not (0 < float(h) < float("inf")):
        raise RoaInputError(f"h (the sample time) must be a finite number > 0, got {h!r}")
    field = system.field
    func = field.func if isinstance(field, BoundField) else field
    step = Step(func, float(h), method, system.params is not None)
    params = None
    if system.params is not None:
        params = {k: v for k, v in system.params.items() if k not in system.uncertain}
    parameters = None if not system.parameters else {k: tuple(r) for k, r in
                                                     system.parameters.items()}  # fmt: skip
    return System.discrete(
        step,
        name=name or f"{system.name}-{method}-h{float(h):g}",
        equilibrium=system.equilibrium,
        state_names=system.state_names,
        state_units=system.state_units,
        margin=system.margin,
        domain_description=system.domain_description,
        norm=system.norm,
        params=params,
        parameters=parameters,
        sample_time=float(h),
        meta={**system.meta, "discretised": {"from": system.name, "method": method, "h": h}},
    )
