"""Python source of a numba module for a traced field: the batch kernel compiled for it.

:func:`kernel_source` turns a :class:`roa.integration._trace.Trace` into the text of a module with

* ``field(t, x, p, out)`` and ``margin(x, p) -> float``: ``numba.njit`` functions of the
  signatures of :mod:`roa.integration._integrator` (``FIELD_SIGNATURE``, ``MARGIN_SIGNATURE``),
  common subexpressions computed once (``sympy.cse``);
* ``run(params, X0, x_eq, ...)``: the integrator's batch Dormand-Prince kernel
  (:func:`roa.integration._integrator.batch_kernel`, the step of :mod:`roa.integration._dopri`)
  compiled for them (the fast path's :class:`~roa.integration._integrator.Inlined` functions: LLVM
  inlines the field, no call through a pointer) with the number of states a compile-time
  constant (``batch_kernel(STATES)``: LLVM unrolls the loops over the states). No integrator
  source is copied: the same code, so the same trajectories bit for bit as the integrator's own
  kernels on the same field.

Every function is ``cache=True``: numba caches the compiled code next to the module's file, keyed
by that file, whose name holds the SHA-256 of the text (:mod:`roa.integration._kernel_cache`). The
text holds :func:`roa.integration._kernel_cache.kernel_stamp` (a hash of the integrator's sources),
so a change of the integrator's code gives another text, another file, and a new compilation.

Arithmetic: each sympy node becomes one floating-point operation in sympy's order of the
arguments (``a / b`` a division, a rational coefficient ``p/q`` a product by ``p`` and a
division by ``q``, an integer power repeated multiplication); constants are the nearest doubles.
A field so compiled agrees with its numpy evaluation to rounding (a few units in the last place
per operation), not bit for bit: the order of a sum or product is sympy's, not the field's.
Compiled: ``+ - * /``, powers, ``sqrt sin cos tan exp log atan asinh atanh sinh cosh tanh asin
acos atan2 Abs Min Max``; any other node raises :class:`roa.integration._trace.Untraceable` naming
it.
"""

from __future__ import annotations

from typing import Any

from roa.integration._trace import Trace, Untraceable

#: sympy function name -> the numba-compiled scalar function (numpy names).
FUNCTIONS = {
    "sin": "np.sin",
    "cos": "np.cos",
    "tan": "np.tan",
    "exp": "np.exp",
    "log": "np.log",
    "atan": "np.arctan",
    "asinh": "np.arcsinh",
    "atanh": "np.arctanh",
    "sinh": "np.sinh",
    "cosh": "np.cosh",
    "tanh": "np.tanh",
    "asin": "np.arcsin",
    "acos": "np.arccos",
    "Abs": "abs",
}
#: Largest generated module (characters): a bigger field is not compiled (numba would take long).
MAX_SOURCE = 2_000_000


def _number(v: float) -> str:
    if v != v:
        return "np.nan"
    if v in (float("inf"), float("-inf")):
        return "np.inf" if v > 0 else "(-np.inf)"
    r = repr(float(v))
    return f"({r})" if r.startswith("-") else r


class _Printer:
    """One expression -> Python source (fully parenthesised: evaluation order is explicit)."""

    def __init__(self, names: dict[Any, str], where: str) -> None:
        self.names = names
        self.where = where

    def __call__(self, e: Any) -> str:
        import sympy as sp

        if e in self.names:
            return self.names[e]
        if e.is_Rational:
            return _number(int(e.p) / int(e.q))
        if e.is_Number or isinstance(e, sp.NumberSymbol):  # Float, pi, E, ...
            if e.is_real is False or e.has(sp.zoo, sp.nan):
                raise Untraceable(f"{self.where}: the constant {e} is not a real number")
            return _number(float(e))
        if e.is_Add:
            return "(" + " + ".join(self(a) for a in e.args) + ")"
        if e.is_Mul:
            return self._mul(e)
        if e.is_Pow:
            return self._pow(*e.args)
        if isinstance(e, sp.Min | sp.Max):  # lattice operations, not sympy Functions
            fn = "np.minimum" if isinstance(e, sp.Min) else "np.maximum"
            out = self(e.args[0])
            for a in e.args[1:]:
                out = f"{fn}({out}, {self(a)})"
            return out
        if isinstance(e, sp.Function):
            name = type(e).__name__
            if name in FUNCTIONS and len(e.args) == 1:
                return f"{FUNCTIONS[name]}({self(e.args[0])})"
            if name == "atan2" and len(e.args) == 2:
                return f"np.arctan2({self(e.args[0])}, {self(e.args[1])})"
            if name in ("Min", "Max"):
                fn = "np.minimum" if name == "Min" else "np.maximum"
                out = self(e.args[0])
                for a in e.args[1:]:
                    out = f"{fn}({out}, {self(a)})"
                return out
            raise Untraceable(f"{self.where}: the function {name} in {e} has no compiled form "
                              f"(compiled: {', '.join(sorted(FUNCTIONS))}, atan2, Min, Max)")  # fmt: skip
        raise Untraceable(f"{self.where}: the term {type(e).__name__} {e} has no compiled form")

    def _mul(self, e: Any) -> str:
        coeff, rest = e.as_coeff_Mul()
        num: list[str] = []
        den: list[str] = []
        if coeff.is_Rational and int(coeff.q) != 1:
            if int(coeff.p) != 1:
                num.append(_number(float(int(coeff.p))))
            den.append(_number(float(int(coeff.q))))
            factors = list(rest.args) if rest.is_Mul else [rest]
        elif coeff == -1 and rest != 1:
            return f"(-{self(rest)})"
        else:
            factors = list(e.args)
        for a in factors:
            if a.is_Pow and a.args[1].is_Rational and a.args[1] < 0:
                den.append(self._pow(a.args[0], -a.args[1]))
            else:
                num.append(self(a))
        top = " * ".join(num) if num else "1.0"
        if not den:
            return f"({top})"
        bottom = den[0] if len(den) == 1 else "(" + " * ".join(den) + ")"
        return f"({top} / {bottom})"

    def _pow(self, base: Any, k: Any) -> str:
        import sympy as sp

        if base is sp.E:
            return f"np.exp({self(k)})"
        b = self(base)
        if k.is_Integer:
            m = int(k)
            if m == 0:
                return "1.0"
            mag = b if abs(m) == 1 else (f"({b} * {b})" if abs(m) == 2 else f"({b} ** {abs(m)})")
            return mag if m > 0 else f"(1.0 / {mag})"
        if k.is_Rational and int(k.q) == 2:
            m = int(k.p)
            r = f"np.sqrt({b})"
            mag = r if abs(m) == 1 else f"({r} ** {abs(m)})"
            return mag if m > 0 else f"(1.0 / {mag})"
        return f"({b} ** {self(k)})"


def _body(exprs: list[Any], names: dict[Any, str], where: str, indent: str) -> tuple[list[str],
                                                                                     list[str]]:  # fmt: skip
    """Lines computing the common subexpressions and the printed outputs."""
    import sympy as sp

    subs, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("c_"), order="none")
    local = dict(names)
    lines = []
    printer = _Printer(local, where)
    for sym, value in subs:
        lines.append(f"{indent}{sym.name} = {printer(value)}")
        local[sym] = sym.name
    return lines, [printer(e) for e in reduced]


def kernel_source(trace: Trace, *, system_name: str, stamp: str) -> str:
    """The module text for ``trace`` (see the module docstring); :class:`Untraceable` names a
    term without a compiled form."""
    n = len(trace.xs)
    names: dict[Any, str] = {x: f"x{i}" for i, x in enumerate(trace.xs)}
    names.update({p: f"p{i}" for i, p in enumerate(trace.ps)})
    names[trace.t] = "t"
    ind = "    "
    loads = [f"{ind}x{i} = x[{i}]" for i in range(n)]
    loads += [f"{ind}p{i} = p[{i}]" for i in range(len(trace.ps))]
    lines, outs = _body(list(trace.field), names, "the field", ind)
    field = loads + lines + [f"{ind}out[{i}] = {o}" for i, o in enumerate(outs)]
    if trace.margin is None:
        margin = [f"{ind}return np.inf"]
    else:
        mlines, mouts = _body([trace.margin], names, "the margin", ind)
        margin = [f"{ind}x{i} = x[{i}]" for i in range(n)] + mlines + [f"{ind}return {mouts[0]}"]
    params = ", ".join(f"{k}={v!r}" for k, v in trace.values)
    header = [
        f'"""Generated by roa (roa/integration/_codegen.py) for the system {system_name!r}: its',
        "field traced with sympy and compiled with the batch kernel. Do not edit: the file name",
        'is the SHA-256 of this text."""',
        "",
        "import numba",
        "import numpy as np",
        "",
        "from roa.integration._integrator import Inlined, batch_kernel, identity_coords_njit",
        "",
        f"KERNEL_STAMP = {stamp!r}  # roa.integration._kernel_cache.kernel_stamp()",
        f"STATES = {n}",
        f"PARAMETERS = {trace.names!r}  # p0, p1, ...: the kernel's params argument",
        f"BAKED = {{{params}}}  # parameter values compiled in",
        "",
        "",
        '@numba.njit(cache=True, error_model="numpy")',
        "def field(t, x, p, out):",
        *field,
        "",
        "",
        '@numba.njit(cache=True, error_model="numpy")',
        "def margin(x, p):",
        *margin,
        "",
        "",
        "_F, _M, _C = Inlined(field), Inlined(margin), Inlined(identity_coords_njit)",
        "_ROWS = batch_kernel(STATES)  # the integrator's batch kernel, n a compile-time constant",
        "",
        "",
        '@numba.njit(cache=True, error_model="numpy")',
        "def run(params, X0, x_eq, tol, bound, margin_tol, t_final, rtol, atol, T, code, t_end,",
        "        x_end, steps):",
        "    _ROWS(_F, _M, params, X0, x_eq, tol, bound, margin_tol, t_final, rtol, atol, T, _C,",
        "          code, t_end, x_end, steps, None)",
        "",
    ]
    text = "\n".join(header)
    if len(text) > MAX_SOURCE:
        raise Untraceable(f"the traced field is too large to compile ({len(text)} characters of "
                          f"code, at most {MAX_SOURCE})")  # fmt: skip
    return text
