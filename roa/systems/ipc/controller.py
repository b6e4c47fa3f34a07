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

from roa.backend import NP
from roa.systems.ipc.model import phi1, phi2, phi3


@dataclass(frozen=True)
class Gains:
    """Coefficients ``(h0, h1, h2, h3)`` of a monic Hurwitz quartic."""

    h: tuple[float, float, float, float]

    @classmethod
    def from_poles(cls, poles: Sequence[complex]) -> Gains:
        poles = [complex(p) for p in poles]
        if len(poles) != 4:
            raise ValueError(f"poles: need exactly 4 closed-loop poles, got {len(poles)}")
        coeffs = np.poly(poles)  # [1, h3, h2, h1, h0]
        if np.max(np.abs(coeffs.imag)) > 1e-9 * max(1.0, np.max(np.abs(coeffs.real))):
            raise ValueError(
                "poles: complex poles must come in conjugate pairs (real coefficients)"
            )
        return cls.from_coefficients(coeffs.real[::-1][:4].tolist())

    @classmethod
    def from_coefficients(cls, h: Sequence[float]) -> Gains:
        h = tuple(float(v) for v in h)
        if len(h) != 4:
            raise ValueError(f"coefficients: need (h0, h1, h2, h3), got {len(h)} values")
        if not all(np.isfinite(h)):
            raise ValueError("coefficients: h0..h3 must be finite")
        roots = np.roots([1.0, h[3], h[2], h[1], h[0]])
        if np.max(roots.real) >= 0:
            raise ValueError(
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


class ExpressionReference(Reference):
    """F*(t) given as an expression in ``t``; derivatives are exact (sympy), then compiled."""

    def __init__(self, expression: str) -> None:
        import sympy as sp

        t = sp.Symbol("t", real=True)
        try:
            expr = sp.sympify(expression, locals={"t": t})
        except (sp.SympifyError, SyntaxError, TypeError) as exc:
            raise ValueError(
                f"reference: cannot parse {expression!r} as an expression in t"
            ) from exc
        extra = expr.free_symbols - {t}
        if extra:
            raise ValueError(
                f"reference: {expression!r} uses unknown symbols {sorted(map(str, extra))}; only t is allowed"
            )
        derivs = [expr]
        for _ in range(4):
            derivs.append(sp.diff(derivs[-1], t))
        self.expression = expression
        self.description = expression
        self._funcs = [sp.lambdify(t, d, "numpy") for d in derivs]
        value = np.asarray(self._funcs[0](0.0), dtype=float)
        if not np.all(np.isfinite(value)):
            raise ValueError(f"reference: {expression!r} is not finite at t = 0")

    def derivatives(self, t: Any) -> tuple:
        tt = np.asarray(t, dtype=float)
        return tuple(np.broadcast_to(np.asarray(f(tt), dtype=float), tt.shape) for f in self._funcs)


def make_reference(spec: str | None) -> Reference:
    """Parse a reference: ``None``/``"0"`` -> zero; ``"sin:A,W"`` -> A sin(W t); else an expression."""
    if spec is None or str(spec).strip() in ("", "0", "zero"):
        return ZeroReference()
    spec = str(spec).strip()
    if spec.startswith("sin:"):
        parts = spec[4:].split(",")
        if len(parts) != 2:
            raise ValueError("reference: 'sin:A,W' needs an amplitude and a frequency")
        return SineReference(float(parts[0]), float(parts[1]))
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
