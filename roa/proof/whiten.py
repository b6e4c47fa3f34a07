"""Validation in whitened coordinates: boxes in ``y`` with ``x = x_eq + M y`` (``V ~ |y|^2``).

A candidate whose Hessian at the equilibrium is badly conditioned (the IPC's flat V: condition
number ~ 10^3) makes axis-aligned boxes in ``x`` a poor fit for its level sets. The branch and bound
of :mod:`roa.proof.validate_general` then runs on boxes in ``y`` instead: :class:`Whitened` is the
candidate ``W(y) = V(x_eq + M y)`` and :func:`whitened_system` the system seen through the same
map. ``x(y)`` is evaluated in the namespace at hand (interval, jet, mpmath), so every enclosure is
of the exact composition, and the derivative proved negative is ``V'(x(y)) = grad V(x) . f(x)`` at
``x = x(y)``, the same number in both coordinates (the map is linear and one-to-one: ``{W <= c}``
is the image of ``{V <= c}``). Nothing depends on ``M`` being accurate: any invertible ``M`` gives
a valid proof, a good one only fewer boxes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.lyapunov import Lyapunov
from roa.system import System


class Whitened(Lyapunov):
    """``W(y) = V(c + M y)`` with ``W' = grad V . f`` evaluated at ``x = c + M y``."""

    def __init__(self, base: Lyapunov, system: System, M: np.ndarray) -> None:
        self.base, self.system = base, system
        self.M = np.asarray(M, dtype=float)
        self.c = np.asarray(base.center, dtype=float)
        self.center = np.zeros(base.n)
        self.name = f"{base.name} (whitened)"

    def x_of(self, y: Any) -> list[Any]:
        """``x = c + M y`` in the namespace of ``y`` (exact products where ``M`` has zeros)."""
        n = self.base.n
        out = []
        for i in range(n):
            acc: Any = None
            for j in range(n):
                m = float(self.M[i, j])
                if m != 0.0:
                    t = y[j] * m if m != 1.0 else y[j]
                    acc = t if acc is None else acc + t
            acc = 0.0 * y[0] if acc is None else acc
            out.append(acc + float(self.c[i]) if self.c[i] != 0.0 else acc)
        return out

    def expr(self, y: Any, xp: Any) -> Any:
        return self.base.expr(self.x_of(y), xp)

    def gradient_expr(self, y: Any, xp: Any) -> list[Any]:
        g = self.base.gradient_expr(self.x_of(y), xp)
        n = self.base.n
        out = []
        for j in range(n):
            acc: Any = 0.0
            for i in range(n):
                m = float(self.M[i, j])
                if m != 0.0:
                    acc = g[i] * m + acc
            out.append(acc)
        return out

    def vdot_expr(self, system: System, y: Any, xp: Any) -> Any:  # noqa: ARG002 - see class doc
        return self.base.vdot_expr(self.system, self.x_of(y), xp)

    def derivative(self, system: System, y: np.ndarray) -> np.ndarray:  # noqa: ARG002
        return self.base.derivative(self.system, self.to_x(y))

    def to_x(self, y: np.ndarray) -> np.ndarray:
        return self.c + np.asarray(y, dtype=float) @ self.M.T

    def hessian_at_center(self) -> np.ndarray:
        return self.M.T @ self.base.hessian_at_center() @ self.M


def whitened_system(system: System, W: Whitened) -> System:
    """The system in ``y``: ``y' = M^-1 f(c + M y)`` (float ``M^-1``: used for the equilibrium and
    domain tests only; the proved ``W'`` never uses it), its margin composed with ``x(y)``."""
    Minv = np.linalg.inv(W.M)

    def field(t: Any, y: Any, xp: Any) -> list[Any]:
        f = system.field(t, W.x_of(y), xp)
        n = len(f)
        out = []
        for i in range(n):
            acc: Any = 0.0
            for j in range(n):
                if Minv[i, j] != 0.0:
                    acc = f[j] * float(Minv[i, j]) + acc
            out.append(acc)
        return out

    margin = None
    if system.margin is not None:
        base_margin = system.margin

        def margin(y: Any, xp: Any) -> Any:
            return base_margin(W.x_of(y), xp)

    return System(
        name=f"{system.name} (whitened)",
        field=field,
        equilibrium=tuple(0.0 for _ in range(system.n)),
        state_names=tuple(f"y{i}" for i in range(system.n)),
        margin=margin,
        domain_description=system.domain_description,
    )


def whitening_for(lyap: Lyapunov) -> np.ndarray | None:
    """``M`` from the Hessian of V at the centre, or None when it is not positive definite or
    already diagonal (nothing to gain)."""
    H = lyap.hessian_at_center()
    if not np.all(np.isfinite(H)) or np.linalg.eigvalsh(0.5 * (H + H.T))[0] <= 0:
        return None
    if np.count_nonzero(H - np.diag(np.diag(H))) == 0:
        return None
    return lyap.whitening()
