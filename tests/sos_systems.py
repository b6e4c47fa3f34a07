"""Small polynomial systems shared by the SOS tests (not collected: no ``test_`` prefix)."""

from __future__ import annotations

import roa


def poly3d_block(x, o):
    """The 3-state polynomial field of ``poly3d`` on the states ``o, o + 1, o + 2``."""
    return (-x[o] + x[o + 1] * x[o + 2], -x[o + 1] + x[o] * x[o + 2], -x[o + 2] + x[o] * x[o + 1])


def ring(n: int) -> roa.System:
    """``x_i' = -x_i + 0.5 x_{i+1} + x_i^3`` (indices mod n) with the default V."""
    return roa.System(f"ring-{n}", lambda t, x, xp: tuple(-x[i] + 0.5 * x[(i + 1) % n] + x[i] ** 3
                                                          for i in range(n)),
                      (0.0,) * n, tuple(f"x{i}" for i in range(n)))  # fmt: skip
