"""The flat-output law (3.3), its references F*(t), and the exact linearising feedback (2.5).

``v = F*^(4) - sum_i h_i (zeta_i - F*^(i))`` with ``zeta = (z1, z2, w1, w2)`` and
``p(s) = h0 + h1 s + h2 s^2 + h3 s^3 + s^4`` Hurwitz. The force realising ``w2' = v`` is the corrected
(2.5): ``u = (phi2(w1) + w2^2 phi3(w1) - v) / phi1(w1)`` (the paper prints ``+ v``: erratum E3).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ipc_paper.system.model import phi1, phi2, phi3
from roa.errors import RoaInputError
from roa.model import NP


@dataclass(frozen=True)
class Gains:
    """Coefficients ``(h0, h1, h2, h3)`` of a monic Hurwitz quartic."""

    h: tuple[float, float, float, float]

    @classmethod
    def from_poles(cls, poles: Sequence[complex]) -> Gains:
        poles = [complex(p) for p in poles]
        if len(poles) != 4:
            raise RoaInputError(f"poles: need exactly 4 closed-loop poles, got {len(poles)}")
        coeffs = np.poly(poles)  # [1, h3, h2, h1, h0]
        if np.max(np.abs(coeffs.imag)) > 1e-9 * max(1.0, np.max(np.abs(coeffs.real))):
            raise RoaInputError(
                "poles: complex poles must come in conjugate pairs (real coefficients)"
            )
        return cls.from_coefficients(coeffs.real[::-1][:4].tolist())

    @classmethod
    def from_coefficients(cls, h: Sequence[float]) -> Gains:
        h = tuple(float(v) for v in h)
        if len(h) != 4:
            raise RoaInputError(f"coefficients: need (h0, h1, h2, h3), got {len(h)} values")
        if not all(np.isfinite(h)):
            raise RoaInputError("coefficients: h0..h3 must be finite")
        roots = np.roots([1.0, h[3], h[2], h[1], h[0]])
        if np.max(roots.real) >= 0:
            raise RoaInputError(
                f"p(s) = s^4 + {h[3]:g} s^3 + {h[2]:g} s^2 + {h[1]:g} s + {h[0]:g} is not Hurwitz: "
                f"root {roots[np.argmax(roots.real)]:.4g} has real part >= 0; "
                "choose poles with negative real parts"
            )
        return cls(h)  # type: ignore[arg-type]

    @classmethod
    def default(cls) -> Gains:
        """p(s) = (s + 1)^4, the paper's (3.6)-(3.7): h = (1, 4, 6, 4)."""
        return cls.from_poles([-1, -1, -1, -1])

    @property
    def poles(self) -> np.ndarray:
        return np.roots([1.0, self.h[3], self.h[2], self.h[1], self.h[0]])


class Reference:
    """A flat-output reference F*(t) with its first four derivatives."""

    description = "reference"

    def derivatives(self, t: Any) -> tuple:
        """Return ``(F*, F*', F*'', F*''', F*'''')`` at time(s) ``t``."""
        raise NotImplementedError

    @property
    def is_zero(self) -> bool:
        return False


class ZeroReference(Reference):
    description = "0 (regulation)"

    def derivatives(self, t: Any) -> tuple:
        z = 0.0 * np.asarray(t, dtype=float)
        return (z, z, z, z, z)

    @property
    def is_zero(self) -> bool:
        return True


@dataclass(frozen=True)
class SineReference(Reference):
    """F*(t) = amplitude sin(omega t), derivatives in closed form."""

    amplitude: float
    omega: float

    @property
    def description(self) -> str:  # type: ignore[override]
        return f"{self.amplitude:g} sin({self.omega:g} t)"

    def derivatives(self, t: Any) -> tuple:
        a, w = self.amplitude, self.omega
        s, c = np.sin(w * np.asarray(t, dtype=float)), np.cos(w * np.asarray(t, dtype=float))
        return (a * s, a * w * c, -a * w**2 * s, -a * w**3 * c, a * w**4 * s)


#: Functions and constants a reference expression may use (nothing else: no attributes, no calls
#: of other names, no names beyond ``t``). ``abs`` is differentiated almost everywhere.
REFERENCE_FUNCTIONS = tuple("sin cos tan exp log sqrt atan sinh cosh tanh abs".split())
REFERENCE_CONSTANTS = ("pi", "E")
#: Bounds that keep parsing and exact arithmetic cheap.
MAX_REFERENCE_LENGTH = 1000
MAX_REFERENCE_DEPTH = 60
MAX_REFERENCE_EXPONENT = 100
REFERENCE_ALLOWED = (
    "allowed: numbers, t, + - * / ** (or ^), unary minus, parentheses, the functions "
    + ", ".join(REFERENCE_FUNCTIONS)
    + " of one argument and the constants "
    + ", ".join(REFERENCE_CONSTANTS)
)


def _reference_error(expression: str, detail: str) -> RoaInputError:
    return RoaInputError(f"reference: cannot use {expression!r}: {detail}; {REFERENCE_ALLOWED}")


def parse_reference_expression(expression: str) -> Any:
    """Parse ``expression`` safely; return ``(expr, t)``, a sympy expression of the real symbol ``t``.

    The text is parsed with :mod:`ast` and only a whitelist of node types is translated into sympy
    objects (numbers, ``t``, ``+ - * / **``, unary signs, :data:`REFERENCE_FUNCTIONS`,
    :data:`REFERENCE_CONSTANTS`); nothing is evaluated by Python and anything else raises
    :class:`roa.errors.RoaInputError` naming ``reference``.
    """
    import ast

    import sympy as sp

    text = str(expression)
    if len(text) > MAX_REFERENCE_LENGTH:
        raise _reference_error(
            text[:40] + "...", f"longer than {MAX_REFERENCE_LENGTH} characters ({len(text)})"
        )
    try:
        # ^ is a power, with the precedence of ** (as sympify's convert_xor)
        tree = ast.parse(text.strip().replace("^", "**"), mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError) as exc:
        detail = getattr(exc, "msg", None) or type(exc).__name__
        raise _reference_error(text, f"not an expression ({detail})") from None
    t = sp.Symbol("t", real=True)
    functions = {name: getattr(sp, name) for name in REFERENCE_FUNCTIONS if name != "abs"}
    functions["abs"] = sp.Abs
    constants = {"t": t, "pi": sp.pi, "E": sp.E}
    binops = {
        ast.Add: lambda a, b: a + b,
        ast.Sub: lambda a, b: a - b,
        ast.Mult: lambda a, b: a * b,
        ast.Div: lambda a, b: a / b,
    }

    def power(base: Any, exp: Any) -> Any:
        if exp.is_number:
            e = complex(sp.N(exp))
            if e.imag != 0 or abs(e.real) > MAX_REFERENCE_EXPONENT:
                raise _reference_error(
                    text,
                    f"a constant exponent must be real with |exponent| <= {MAX_REFERENCE_EXPONENT}",
                )
            if base.is_number:
                b = abs(complex(sp.N(base)))
                if b > 1 and abs(e.real) * float(np.log10(b)) > 300:
                    raise _reference_error(text, "a constant power above 1e300")
        return base**exp

    def build(node: ast.AST, depth: int) -> Any:
        if depth > MAX_REFERENCE_DEPTH:
            raise _reference_error(text, f"nested deeper than {MAX_REFERENCE_DEPTH} levels")
        if isinstance(node, ast.Constant):
            value = node.value
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise _reference_error(text, f"the constant {value!r} is not a real number")
            if isinstance(value, float):
                if not np.isfinite(value):
                    raise _reference_error(text, f"the number {value!r} is not finite")
                return sp.Float(value)
            return sp.Integer(value)
        if isinstance(node, ast.Name):
            if node.id in constants:
                return constants[node.id]
            if node.id in functions:
                raise _reference_error(text, f"{node.id} is a function: write {node.id}(...)")
            raise _reference_error(text, f"unknown symbols [{node.id!r}]; only t is allowed")
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            operand = build(node.operand, depth + 1)
            return -operand if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp):
            if isinstance(node.op, ast.Pow):
                return power(build(node.left, depth + 1), build(node.right, depth + 1))
            op = binops.get(type(node.op))
            if op is None:
                raise _reference_error(
                    text, f"the operator {type(node.op).__name__} is not allowed"
                )
            return op(build(node.left, depth + 1), build(node.right, depth + 1))
        if isinstance(node, ast.Call):
            name = node.func.id if isinstance(node.func, ast.Name) else None
            if name not in functions:
                shown = name if name is not None else ast.unparse(node.func)
                raise _reference_error(text, f"{shown}(...) is not an allowed function")
            if node.keywords or len(node.args) != 1:
                raise _reference_error(text, f"{name} takes exactly one argument")
            arg = node.args[0]
            if isinstance(arg, ast.Starred):
                raise _reference_error(text, f"{name} takes exactly one argument")
            return functions[name](build(arg, depth + 1))
        kind = type(node).__name__
        what = {"Attribute": "attribute access", "Subscript": "indexing", "Lambda": "lambda",
                "Compare": "comparisons", "BoolOp": "and/or", "IfExp": "if-else"}.get(kind, kind)  # fmt: skip
        raise _reference_error(text, f"{what} is not allowed")

    try:
        expr = build(tree.body, 0)
    except RoaInputError:
        raise
    except (TypeError, ValueError, ArithmeticError, RecursionError, MemoryError) as exc:
        raise _reference_error(text, f"cannot evaluate ({type(exc).__name__}: {exc})") from None
    if expr.has(sp.I) or expr.has(sp.zoo) or expr.has(sp.nan) or expr.has(sp.oo):
        raise _reference_error(text, "not a real, finite expression")
    return expr, t


class ExpressionReference(Reference):
    """F*(t) given as an expression in ``t``; derivatives are exact (sympy), then compiled.

    The expression is parsed by :func:`parse_reference_expression` (a whitelist, nothing executed).
    """

    def __init__(self, expression: str) -> None:
        import sympy as sp

        expr, t = parse_reference_expression(expression)
        derivs = [expr]
        for _ in range(4):
            # d/dt |.| has Dirac terms: the reference is used almost everywhere, where they vanish
            derivs.append(sp.diff(derivs[-1], t).replace(sp.DiracDelta, lambda *_: sp.Integer(0)))
        self.expression = expression
        self.description = expression
        self._funcs = [sp.lambdify(t, d, "numpy") for d in derivs]
        for order, f in enumerate(self._funcs):
            try:
                with np.errstate(all="ignore"):
                    value = np.asarray(f(np.float64(0.0)))
                ok = not np.iscomplexobj(value) and bool(np.all(np.isfinite(value)))
            except (TypeError, ValueError, NameError, ArithmeticError):
                ok = False
            if not ok:
                what = "its value" if order == 0 else f"its derivative of order {order}"
                raise RoaInputError(
                    f"reference: {expression!r}: {what} is not a finite real number at t = 0"
                )

    def derivatives(self, t: Any) -> tuple:
        tt = np.asarray(t, dtype=float)
        return tuple(np.broadcast_to(np.asarray(f(tt), dtype=float), tt.shape) for f in self._funcs)


def make_reference(spec: str | None) -> Reference:
    """Parse a reference: ``None``/``"0"`` -> zero; ``"sin:A,W"`` -> A sin(W t); else an expression.

    Expressions are parsed safely (:func:`parse_reference_expression`): nothing in ``spec`` is run.
    """
    if spec is None or str(spec).strip() in ("", "0", "zero"):
        return ZeroReference()
    spec = str(spec).strip()
    if spec.startswith("sin:"):
        parts = spec[4:].split(",")
        if len(parts) != 2:
            raise RoaInputError(
                f"reference: 'sin:A,W' needs an amplitude and a frequency, got {spec!r}"
            )
        try:
            amplitude, omega = float(parts[0]), float(parts[1])
        except ValueError:
            raise RoaInputError(
                f"reference: 'sin:A,W' needs two numbers A and W, got {spec!r}"
            ) from None
        if not (np.isfinite(amplitude) and np.isfinite(omega)):
            raise RoaInputError(f"reference: 'sin:A,W' needs finite A and W, got {spec!r}")
        return SineReference(amplitude, omega)
    return ExpressionReference(spec)


def virtual_input(t: Any, zeta: Sequence[Any], gains: Gains, reference: Reference) -> Any:
    """The flat-output law (3.3): v = F*'''' - sum h_i (zeta_i - F*^(i))."""
    if reference.is_zero:
        return -sum(h * zi for h, zi in zip(gains.h, zeta, strict=True))
    d = reference.derivatives(t)
    return d[4] - sum(h * (zi - di) for h, zi, di in zip(gains.h, zeta, d[:4], strict=True))


def force(v: Any, w1: Any, w2: Any, delta: float, xp: Any = NP) -> Any:
    """Corrected (2.5): the force u that makes w2' = v exactly."""
    return (phi2(w1, delta, xp) + w2 * w2 * phi3(w1, delta, xp) - v) / phi1(w1, delta, xp)
