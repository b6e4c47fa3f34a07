"""A system's field and margin traced once into sympy expressions (for compiled kernels).

:func:`trace_system` evaluates ``system.field(t, x, xp)`` and ``system.margin(x, xp)`` with the
sympy namespace of :mod:`roa.model._backend` on symbols ``x0 .. x{n-1}`` (real), so a field written
against ``xp`` becomes one expression per component. Parameters (``System.params``, the nominal
values of uncertain ones included) are traced as symbols ``p0 ..``, which the compiled kernel takes
as an argument, so other parameter values (``System.at``, ``with_params``) reuse the same kernel;
a field that cannot take symbolic parameters (it compares one with a number, say) is traced again
with the values themselves, and the kernel then holds them.

Claims and assumptions:

* The trace is what the field computes for real states with this code path: a field that branches
  on the namespace (``xp.name``) or on types could compute something else in numpy; the caller
  compares the compiled field with the numpy one on sample states
  (:func:`roa.integration._kernel_cache.check_against_numpy`).
* Whatever cannot be traced raises :class:`Untraceable` with the reason, naming the term: an
  exception of the field under sympy (a numpy function applied to a symbol, ``float(x[0])``, an
  ``if`` on a state), a component that is not an expression, or a symbol that is not a state or
  a parameter. :mod:`roa.integration._codegen` names the functions it cannot compile.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from roa.model._system import BoundField, Params, System


class Untraceable(Exception):
    """The field (or margin) of a system cannot be compiled; ``str()`` says which term and why."""


@dataclass(frozen=True)
class Trace:
    """The sympy expressions of a system's field and margin.

    ``field`` holds one expression per state in the symbols ``xs`` (states), ``ps`` (the
    parameters ``names``, kernel arguments) and ``t``; ``margin`` is None for the whole space.
    ``values`` are the parameter values baked into the expressions (empty when ``names`` are
    symbols)."""

    field: tuple[Any, ...]
    margin: Any
    xs: tuple[Any, ...]
    ps: tuple[Any, ...]
    t: Any
    names: tuple[str, ...]
    values: tuple[tuple[str, float], ...] = ()


def _evaluate(fn: Any, what: str, *args: Any) -> Any:
    try:
        return fn(*args)
    except Exception as exc:  # noqa: BLE001 - any failure of user code under sympy: no trace
        raise Untraceable(
            f"{what} cannot be evaluated on sympy symbols ({type(exc).__name__}: {exc})"
        ) from None


def _as_expr(value: Any, what: str, allowed: set[Any]) -> Any:
    import sympy as sp

    try:
        expr = sp.sympify(value)
    except (sp.SympifyError, TypeError, ValueError) as exc:
        raise Untraceable(f"{what} is {type(value).__name__} {value!r}, not an expression "
                          f"({exc})") from None  # fmt: skip
    if not isinstance(expr, sp.Expr):
        raise Untraceable(f"{what} is {type(expr).__name__} {expr}, not an expression")
    extra = sorted(str(s) for s in expr.free_symbols - allowed)
    if extra:
        raise Untraceable(f"{what} holds symbols {', '.join(extra)} that are not states or "
                          "parameters")  # fmt: skip
    return expr


def trace_system(system: System, *, symbolic_params: bool = True) -> Trace:
    """The expressions of ``system.field`` (and ``system.margin``); :class:`Untraceable` if not.

    With ``symbolic_params`` the parameters are symbols (kernel arguments); otherwise their values
    are taken as constants."""
    import sympy as sp

    from roa.model._backend import namespace

    SP = namespace("sympy")
    n = system.n
    xs = tuple(sp.Symbol(f"x{i}", real=True) for i in range(n))
    t = sp.Symbol("t", real=True)
    field = system.field
    params = dict(system.params or {})
    names: tuple[str, ...] = ()
    ps: tuple[Any, ...] = ()
    values: tuple[tuple[str, float], ...] = ()
    if isinstance(field, BoundField):
        if symbolic_params:
            names = tuple(params)
            ps = tuple(sp.Symbol(f"p{i}", real=True) for i in range(len(names)))
            out = _evaluate(field.func, "the field", t, list(xs), SP,
                            Params(dict(zip(names, ps, strict=True))))  # fmt: skip
        else:
            values = tuple((k, float(v)) for k, v in params.items())
            out = _evaluate(field, "the field", t, list(xs), SP)
    else:
        out = _evaluate(field, "the field", t, list(xs), SP)
    try:
        comps = list(out)
    except TypeError:
        raise Untraceable(f"the field returned {type(out).__name__}, not a sequence") from None
    if len(comps) != n:
        raise Untraceable(f"the field returned {len(comps)} components for {n} states")
    allowed = {*xs, *ps, t}
    exprs = tuple(_as_expr(c, f"component {i} ({system.state_names[i]}')", allowed)
                  for i, c in enumerate(comps))  # fmt: skip
    margin = None
    if system.margin is not None:
        m = _evaluate(system.margin, "the margin (domain)", list(xs), SP)
        margin = _as_expr(m, "the margin (domain)", set(xs))
    return Trace(exprs, margin, xs, ps, t, names, values)
