"""Systems from sympy expressions: :meth:`roa.System.from_sympy`.

Users of Drake, LyZNet or SOSTOOLS write their dynamics as symbolic expressions. This module
compiles sympy expressions of the state symbols (and of parameter symbols) once into a small
program, :class:`SympyField`, that evaluates the field in every namespace roa uses: numpy
(simulation, sampling), CasADi (IPOPT search), sympy (SOS, linearisation), mpmath (50-digit witness
checks) and the interval and jet namespaces of :mod:`roa.proof` (certification).

Claims and assumptions:

* Supported: ``+ - * /``, integer powers, half-integer powers (through ``sqrt``), ``sin cos tan
  exp log atan asinh atanh Abs Min Max sqrt``, integers, rationals, floats, ``pi`` and ``E``.
  Anything else (``Piecewise``, ``sign``, ``acos``, ``x**(1/3)``, a symbol that is neither a state
  nor a parameter, ...) is refused when the system is built, with a message naming it.
* Integers and rationals stay exact where the namespace can hold them: in the interval and jet
  namespaces a rational is an enclosed constant (as for Lyapunov candidates,
  :mod:`roa.lyapunov._symbolic`), so a certificate is about the exact rational field. A sympy
  ``Float`` is taken as the double nearest to it (what ``0.1`` typed in Python is).
* ``pi`` and ``E`` are computed in the namespace as ``4 arctan(1)`` and ``exp(1)``: enclosed by
  intervals, exact in sympy, the nearest double in numpy.
* Common subexpressions are evaluated once. The evaluation order of a sum or product is sympy's
  (its canonical order), so a numpy value may differ from a hand-written field in the last bits.
* Refused with a :class:`roa.RoaInputError` naming the expression: what sympy cannot read as an
  expression (an arbitrary object, a malformed string), a constant beyond the double range
  (``|c| <= 1.797e308``: numpy evaluates the field in doubles), and an expression nested more
  than :data:`MAX_DEPTH` operations deep (sympy's and roa's tree walks recurse once per level).
* Bounded when built: integer (and half-integer) exponents up to ``MAX_POWER`` (100) in
  magnitude and at most :data:`MAX_NODES` distinct terms and operations; larger inputs are
  refused with a :class:`roa.RoaInputError` saying which bound (their certification would not
  end).
* The program holds no sympy object: pickling it (joblib, Dask workers) does not import sympy.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from roa.errors import RoaInputError
from roa.model._field_probe import MAX_POWER
from roa.model._sympy_eval import FUNCTIONS

#: What :func:`compile_exprs` accepts, for messages.
SUPPORTED = (
    "+, -, *, /, integer and half-integer powers, sqrt, " + ", ".join(FUNCTIONS) + ", Min, Max, "
    "integers, rationals, floats, pi, E"
)

Instruction = tuple[Any, ...]

#: Deepest nesting (operations from the root to a leaf) of an expression that is compiled: the
#: sympy and roa walks of an expression tree (printing, differentiation, CasADi, compilation)
#: recurse once or more per level, so deeper trees would exhaust Python's recursion limit.
MAX_DEPTH = 100

#: Most distinct operations and leaves of a compiled system (every component together): the
#: symbolic and interval routes walk every term, so larger inputs are refused when built.
MAX_NODES = 5000


@dataclass(frozen=True)
class SympyField:
    """A vector field compiled from sympy expressions; ``field(t, x, xp[, p])``.

    ``program`` is a sequence of instructions, each referring to earlier results by index;
    ``outputs`` are the indices of the n components. Built by :func:`compile_exprs`.
    """

    program: tuple[Instruction, ...]
    outputs: tuple[int, ...]
    text: tuple[str, ...]  # the expressions as sympy prints them (repr, messages)

    def __call__(self, t: Any, x: Any, xp: Any, p: Any = None) -> tuple[Any, ...]:
        vals: list[Any] = []
        for ins in self.program:
            vals.append(_run(ins, vals, x, xp, p))
        return tuple(vals[i] for i in self.outputs)

    def __repr__(self) -> str:
        return f"SympyField({', '.join(self.text)})"


def _run(ins: Instruction, vals: list[Any], x: Any, xp: Any, p: Any) -> Any:
    op = ins[0]
    if op == "x":
        return x[ins[1]]
    if op == "p":
        return p[ins[1]]
    if op == "rat":
        from roa.model._sympy_eval import exact_constant

        return exact_constant(ins[1], ins[2], xp)
    if op == "float":
        return ins[1]
    if op == "pi":
        return xp.arctan(x[0] ** 0) * 4  # x0**0: the namespace's exact 1
    if op == "e":
        return xp.exp(x[0] ** 0)
    if op == "add":
        out = vals[ins[1][0]]
        for i in ins[1][1:]:
            out = out + vals[i]
        return out
    if op == "mul":
        out = vals[ins[1][0]]
        for i in ins[1][1:]:
            out = out * vals[i]
        return out
    if op == "neg":
        return -vals[ins[1]]
    if op == "pow":
        k = ins[2]
        return vals[ins[1]] ** k if k > 0 else 1.0 / vals[ins[1]] ** (-k)
    if op == "sqrtpow":  # base ** (k / 2), k odd
        r = xp.sqrt(vals[ins[1]])
        k = ins[2]
        return r**k if k > 0 else 1.0 / r ** (-k)
    if op == "fn":
        return getattr(xp, ins[1])(vals[ins[2]])
    if op in ("min", "max"):
        fn = xp.minimum if op == "min" else xp.maximum
        out = vals[ins[1][0]]
        for i in ins[1][1:]:
            out = fn(out, vals[i])
        return out
    raise AssertionError(f"unknown instruction {op!r}")  # compile_exprs emits none other


def compile_exprs(exprs: Sequence[Any], states: Sequence[Any], params: Sequence[Any]) -> SympyField:
    """Compile sympy ``exprs`` of the symbols ``states`` (-> ``x[i]``) and ``params`` (-> ``p[name]``).

    Raises :class:`roa.RoaInputError` naming an unsupported function, power, constant or symbol.
    """
    import sympy as sp

    env: dict[Any, Instruction] = {s: ("x", i) for i, s in enumerate(states)}
    env.update({s: ("p", s.name) for s in params})
    program: list[Instruction] = []
    index: dict[Any, int] = {}
    known = ", ".join(str(s) for s in [*states, *params])

    def emit(ins: Instruction, key: Any) -> int:
        if key in index:
            return index[key]
        if len(program) >= MAX_NODES:
            raise RoaInputError(
                f"from_sympy: the expressions have more than {MAX_NODES} distinct terms and "
                f"operations (allowed: at most {MAX_NODES}); simplify them or split the system"
            )
        program.append(ins)
        index[key] = len(program) - 1
        return index[key]

    def visit(e: Any) -> int:
        if e in index:
            return index[e]
        if e.is_Symbol:
            if e not in env:
                raise RoaInputError(
                    f"from_sympy: symbol {e} is neither a state nor a parameter "
                    f"(declared: {known}); declare it in parameters= or params="
                )
            return emit(env[e], e)
        if e.is_Rational:
            p, q = int(e.p), int(e.q)
            try:
                p / q
            except OverflowError:
                raise RoaInputError(_out_of_range(e)) from None
            if q == 1 and abs(p) <= 2**53:
                return emit(("float", float(p)), e)
            return emit(("rat", p, q), e)
        if e.is_Float:
            if not math.isfinite(float(e)):
                raise RoaInputError(_out_of_range(e))
            return emit(("float", float(e)), e)
        if e is sp.pi:
            return emit(("pi",), e)
        if e is sp.E:
            return emit(("e",), e)
        if e.is_Add:
            return emit(("add", tuple(visit(a) for a in e.args)), e)
        if e.is_Mul:
            coeff, rest = e.as_coeff_Mul()
            if coeff == -1 and rest != 1:
                return emit(("neg", visit(rest)), e)
            return emit(("mul", tuple(visit(a) for a in e.args)), e)
        if e.is_Pow:
            base, k = e.args
            if base is sp.E:
                return emit(("fn", "exp", visit(k)), e)
            if k.is_Integer:
                if abs(k) > MAX_POWER:
                    shown = str(k) if len(str(k)) <= 30 else f"of {len(str(k))} digits"
                    raise RoaInputError(
                        f"from_sympy: the power {str(base)[:40]}**(...) has exponent {shown} (allowed: "
                        f"integer exponents up to {MAX_POWER} in magnitude)"
                    )
                return emit(("pow", visit(base), int(k)), e)
            if k.is_Rational and int(k.q) == 2 and abs(k) <= MAX_POWER:
                return emit(("sqrtpow", visit(base), int(k.p)), e)
            raise RoaInputError(
                f"from_sympy: unsupported power {e} (integer and half-integer exponents only; "
                f"supported: {SUPPORTED})"
            )
        if isinstance(e, sp.Function):
            name = type(e).__name__
            if name in FUNCTIONS and len(e.args) == 1:
                return emit(("fn", FUNCTIONS[name], visit(e.args[0])), e)
            if name in ("Min", "Max"):
                return emit((name.lower(), tuple(visit(a) for a in e.args)), e)
            raise RoaInputError(
                f"from_sympy: unsupported function {name} in {e} (supported: {SUPPORTED})"
            )
        raise RoaInputError(
            f"from_sympy: unsupported expression {type(e).__name__} {e} (supported: {SUPPORTED})"
        )

    exprs = [as_expression(e, i) for i, e in enumerate(exprs)]
    outputs = tuple(visit(e) for e in exprs)
    return SympyField(tuple(program), outputs, tuple(str(e) for e in exprs))


def _out_of_range(e: Any) -> str:
    text = str(e)
    text = text if len(text) <= 60 else f"{text[:25]}...{text[-25:]} ({len(text)} characters)"
    return (f"from_sympy: the constant {text} is outside the double range (|c| <= "
            f"{sys.float_info.max:.4g}, the field is evaluated in doubles); rescale the equations")  # fmt: skip


def _describe(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else f"{text[:77]}..."


def as_expression(value: Any, i: int) -> Any:
    """Expression ``i`` as a sympy expression of depth at most :data:`MAX_DEPTH`, else a
    :class:`roa.RoaInputError` naming it (``sympify`` of what is not sympy: strings are parsed)."""
    import sympy as sp

    try:
        e = sp.sympify(value)
    except Exception as exc:  # noqa: BLE001 - SympifyError, a string's SyntaxError, RecursionError...
        raise RoaInputError(
            f"from_sympy: expression {i} ({type(value).__name__} {_describe(value)}) is not a "
            f"sympy expression ({type(exc).__name__}); give sympy expressions of the state "
            "symbols"
        ) from None
    if not isinstance(e, sp.Expr):
        raise RoaInputError(
            f"from_sympy: expression {i} ({type(e).__name__} {_describe(value)}) is not a sympy "
            "expression (a number-valued Expr is needed)"
        )
    level, depth = [e], 0  # the nodes at each distance from the root (a DAG: at most every
    while level:  # node per level, so at most MAX_DEPTH + 1 passes over the distinct nodes)
        nxt = list({id(a): a for node in level for a in node.args}.values())
        level = nxt
        depth += bool(nxt)
        if depth > MAX_DEPTH:
            raise RoaInputError(
                f"from_sympy: expression {i} is nested more than {MAX_DEPTH} operations deep "
                f"(allowed: at most {MAX_DEPTH}); introduce intermediate states or simplify it"
            )
    return e


def _symbols(items: Any, what: str) -> list[Any]:
    import sympy as sp

    out = []
    for s in items:
        sym = sp.Symbol(s) if isinstance(s, str) else s
        if not isinstance(sym, sp.Symbol) or not sym.name.isidentifier():
            raise RoaInputError(f"from_sympy: {what} must be sympy Symbols or names, got {s!r}")
        out.append(sym)
    if len({s.name for s in out}) != len(out):
        raise RoaInputError(f"from_sympy: {what} have repeated names: {[s.name for s in out]}")
    return out


def system_from_sympy(
    system_cls: Any,
    exprs: Any,
    states: Sequence[Any],
    *,
    equilibrium: Sequence[float] | None = None,
    parameters: Mapping[Any, Sequence[float]] | None = None,
    params: Mapping[Any, float] | None = None,
    name: str = "sympy-system",
    state_units: Sequence[str] = (),
    **system_kwargs: Any,
) -> Any:
    """The :class:`roa.System` of ``x' = exprs(x)``; see :meth:`roa.System.from_sympy`."""
    import sympy as sp

    exprs = list(sp.Matrix(exprs)) if isinstance(exprs, sp.MatrixBase) else list(exprs)
    state_syms = _symbols(states, "states")
    if len(exprs) != len(state_syms):
        raise RoaInputError(
            f"from_sympy: {len(exprs)} expressions for {len(state_syms)} states "
            f"({', '.join(s.name for s in state_syms)}); give one per state"
        )
    uncertain = {s.name: tuple(v) for s, v in zip(_symbols(parameters or {}, "parameters"),
                                                  (parameters or {}).values(), strict=True)}  # fmt: skip
    fixed = {s.name: v for s, v in zip(_symbols(params or {}, "params"),
                                       (params or {}).values(), strict=True)}  # fmt: skip
    clash = sorted(set(uncertain) & set(fixed) | set(uncertain) & {s.name for s in state_syms}
                   | set(fixed) & {s.name for s in state_syms})  # fmt: skip
    if clash:
        raise RoaInputError(
            f"from_sympy: {clash[0]!r} is declared twice (states, params, parameters)"
        )
    param_syms = [sp.Symbol(n) for n in [*fixed, *uncertain]]
    # symbols with assumptions (real=True, ...) are matched by name
    by_name = {s.name: s for s in [*state_syms, *param_syms]}
    exprs = [as_expression(e, i) for i, e in enumerate(exprs)]
    renamed = []
    for e in exprs:
        sub = {
            s: by_name[s.name] for s in e.free_symbols if s.name in by_name and s != by_name[s.name]
        }
        renamed.append(e.xreplace(sub) if sub else e)
    field = compile_exprs(renamed, state_syms, param_syms)
    n = len(state_syms)
    eq = tuple(float(v) for v in equilibrium) if equilibrium is not None else (0.0,) * n
    return system_cls(
        name=name,
        field=field,
        equilibrium=eq,
        state_names=tuple(s.name for s in state_syms),
        state_units=tuple(state_units),
        params=fixed or None,
        parameters=uncertain or None,
        **system_kwargs,
    )
