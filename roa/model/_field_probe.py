"""A field evaluated once on probe values: the numpy functions it calls and the size it has.

roa evaluates a field in several namespaces (numpy, CasADi, sympy, mpmath, intervals). A numpy
function called on a state (``np.arctan2(x[0], x[1])``, ``np.hypot``, ``np.tanh``) computes in
numpy only: sympy and the interval namespaces have no such function, and CasADi silently
differentiates numpy's own, so the proof routes fail late or compute what the other namespaces
do not. :func:`probe` evaluates the field once at the equilibrium on :class:`Probe` values, which
record every numpy function applied to them and every integer power, and count the operations.

Claims and assumptions:

* Every numpy ufunc or array function that receives a state-dependent value on the evaluated code
  path is recorded by name (``np.<name>``), except numpy's operator ufuncs (``+``, ``*``, ``**``,
  comparisons, ``abs``), which every namespace provides. Code paths not taken at the equilibrium
  are not seen (a branch on the state's value); what is seen is named.
* An integer power ``v ** k`` of a state-dependent value with ``|k| > MAX_POWER``, or more than
  :data:`MAX_OPS` operations, stops the probe: such a field is refused where it is loaded
  (:func:`roa.model.check_system`), since its symbolic and interval routes would not end.
* The probe computes with floats; any other failure of the field on probe values is ignored here
  (the numpy checks and the namespaces that need the field report it).
"""

from __future__ import annotations

import math
import operator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from roa.errors import SystemDefinitionError

if TYPE_CHECKING:
    from roa.model._system import System

#: Largest integer exponent of a state-dependent power in a field (the documented bound of
#: every front door: a user's field, from_sympy, from_control).
MAX_POWER = 100
#: Most arithmetic operations on state-dependent values in one evaluation of a field.
MAX_OPS = 20_000

#: numpy ufuncs that every namespace provides as Python operators or builtins.
_OPERATORS = frozenset({
    "add", "subtract", "multiply", "true_divide", "divide", "power", "negative", "positive",
    "absolute", "less", "less_equal", "greater", "greater_equal", "equal", "not_equal",
})  # fmt: skip


class TooLarge(Exception):
    """The field's degree or operation count exceeds the bound (the message says which)."""


class NumpyCall(Exception):
    """A numpy function received a state (strict probes only; the message names it)."""


@dataclass
class Log:
    """What a probe saw: numpy functions by name, the largest power, the operation count."""

    strict: bool = False
    numpy: list[str] = field(default_factory=list)
    ops: int = 0
    refused: bool = False  # a TooLarge or (strict) NumpyCall was raised

    def too_large(self, message: str) -> TooLarge:
        self.refused = True
        return TooLarge(message)

    def op(self) -> None:
        self.ops += 1
        if self.ops > MAX_OPS:
            raise self.too_large(f"more than {MAX_OPS} operations on the states in one evaluation "
                           f"(allowed: at most {MAX_OPS})")  # fmt: skip

    def numpy_call(self, name: str) -> None:
        if name not in self.numpy:
            self.numpy.append(name)
        if self.strict:
            self.refused = True
            raise NumpyCall(
                f"np.{name} is numpy's function, called on a state: the proof routes evaluate the "
                "field with sympy, intervals and CasADi, which numpy's functions do not know; "
                "use the namespace's xp.sin, xp.cos, ... (available: "
                f"{', '.join(_available())})"
            )


def _available() -> tuple[str, ...]:
    from roa.model._backend import FUNCTIONS, PIECEWISE

    return FUNCTIONS + PIECEWISE


def _v(a: Any) -> Any:
    return a.v if isinstance(a, Probe) else a


class Probe:
    """A float that records what is done to it (see the module's claims)."""

    __slots__ = ("log", "v")

    def __init__(self, v: float, log: Log) -> None:
        self.v = float(v)
        self.log = log

    def _wrap(self, value: Any) -> Any:
        if isinstance(value, int | float | np.floating | np.integer) and not isinstance(
            value, bool | np.bool_
        ):
            return Probe(float(value), self.log)
        return value

    def _binary(self, other: Any, fn: Any, reflected: bool = False) -> Any:
        if not isinstance(other, Probe | int | float | np.floating | np.integer):
            return NotImplemented
        self.log.op()
        a, b = (_v(other), self.v) if reflected else (self.v, _v(other))
        try:
            return self._wrap(fn(a, b))
        except (ZeroDivisionError, OverflowError, ValueError):
            return Probe(math.nan, self.log)

    def __add__(self, o: Any) -> Any:
        return self._binary(o, operator.add)

    def __radd__(self, o: Any) -> Any:
        return self._binary(o, operator.add, True)

    def __sub__(self, o: Any) -> Any:
        return self._binary(o, operator.sub)

    def __rsub__(self, o: Any) -> Any:
        return self._binary(o, operator.sub, True)

    def __mul__(self, o: Any) -> Any:
        return self._binary(o, operator.mul)

    def __rmul__(self, o: Any) -> Any:
        return self._binary(o, operator.mul, True)

    def __truediv__(self, o: Any) -> Any:
        return self._binary(o, operator.truediv)

    def __rtruediv__(self, o: Any) -> Any:
        return self._binary(o, operator.truediv, True)

    def __pow__(self, k: Any) -> Any:
        kv = _v(k)
        big = False
        if isinstance(kv, int | np.integer) and not isinstance(kv, bool):
            big = abs(int(kv)) > MAX_POWER
        elif isinstance(kv, float | np.floating):
            fk = float(kv)
            big = math.isfinite(fk) and fk.is_integer() and abs(fk) > MAX_POWER
        if big:
            bits = int(abs(kv)).bit_length()
            text = str(int(kv)) if bits < 100 else f"of about {bits * 0.30103:.0f} digits"
            raise self.log.too_large(f"a state-dependent power with exponent {text} (allowed: "
                                     f"integer exponents up to {MAX_POWER} in magnitude)")  # fmt: skip
        return self._binary(k, lambda a, b: float(a) ** b)

    def __rpow__(self, o: Any) -> Any:
        return self._binary(o, lambda a, b: float(a) ** b, True)

    def __neg__(self) -> Any:
        return Probe(-self.v, self.log)

    def __pos__(self) -> Any:
        return self

    def __abs__(self) -> Any:
        return Probe(abs(self.v), self.log)

    def __float__(self) -> float:
        return self.v

    def __lt__(self, o: Any) -> bool:
        return bool(self.v < _v(o))

    def __le__(self, o: Any) -> bool:
        return bool(self.v <= _v(o))

    def __gt__(self, o: Any) -> bool:
        return bool(self.v > _v(o))

    def __ge__(self, o: Any) -> bool:
        return bool(self.v >= _v(o))

    def __eq__(self, o: object) -> bool:
        return bool(self.v == _v(o))

    def __ne__(self, o: object) -> bool:
        return bool(self.v != _v(o))

    __hash__ = None  # type: ignore[assignment]

    def __array_ufunc__(self, ufunc: Any, method: str, *inputs: Any, **kwargs: Any) -> Any:
        name = getattr(ufunc, "__name__", str(ufunc))
        if name not in _OPERATORS or method != "__call__":
            self.log.numpy_call(name if method == "__call__" else f"{name}.{method}")
        self.log.op()
        out = getattr(ufunc, method)(*(_v(a) for a in inputs), **kwargs)
        return self._wrap(out)

    def __array_function__(self, func: Any, types: Any, args: Any, kwargs: Any) -> Any:
        self.log.numpy_call(getattr(func, "__name__", str(func)))

        def plain(a: Any) -> Any:
            if isinstance(a, list | tuple):
                return type(a)(plain(b) for b in a)
            return _v(a)

        return self._wrap(func(*plain(args), **{k: plain(v) for k, v in kwargs.items()}))

    def __getattr__(self, name: str) -> Any:  # numpy's loops over object arrays call methods
        if name.startswith("_"):
            raise AttributeError(name)
        fn = getattr(np, name, None)
        if not callable(fn):
            raise AttributeError(name)
        self.log.numpy_call(name)
        return lambda *args: self._wrap(fn(self.v, *(_v(a) for a in args)))


def namespace() -> Any:
    """The namespace of a probe: every :mod:`roa.model._backend` function, on probe values."""
    from types import SimpleNamespace

    from roa.model._backend import NP

    def lift(name: str) -> Any:
        fn = getattr(NP, name)

        def call(*args: Any) -> Any:
            logs = [a.log for a in args if isinstance(a, Probe)]
            with np.errstate(all="ignore"):
                out = fn(*(_v(a) for a in args))
            if not logs:
                return out
            logs[0].op()
            return Probe(float(out), logs[0])

        return call

    ns = {name: lift(name) for name in _available()}
    ns["name"] = "probe"
    return SimpleNamespace(**ns)


def probe(system: Any, log: Log) -> None:
    """Evaluate ``system``'s field (or map) once at its equilibrium on probe values recording into ``log``.

    Raises :class:`TooLarge` (and, with ``log.strict``, :class:`NumpyCall` at the first numpy
    function on a state), then with ``log.refused`` set, as the exception itself or as what the
    field's wrapper makes of it (:class:`roa.errors.SystemDefinitionError` naming the file and
    line of a user's field); any other exception is the field's own."""
    x = [Probe(v, log) for v in np.asarray(system.x_eq, dtype=float)]
    with np.errstate(all="ignore"):
        system.dynamics(0.0, x, namespace())


def check_functions(system: System, *, strict: bool = True) -> None:
    """The field's size and, with ``strict``, the numpy functions it applies to the states
    (:func:`probe`, at the equilibrium): a :class:`SystemDefinitionError` names the
    function or the bound (and the file and line of a user's field)."""
    log = Log(strict=strict)
    try:
        probe(system, log)
    except SystemDefinitionError:  # a user's field: its wrapper names the file and the line
        if log.refused:
            raise
    except Exception as exc:  # noqa: BLE001 - the field's own failures are reported elsewhere
        if log.refused:
            raise SystemDefinitionError(f"system {system.name!r}: {exc}") from None
