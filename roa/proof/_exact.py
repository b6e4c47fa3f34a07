"""Exact rational checks that proofs end on: definiteness of rational matrices, exact equilibria.

Matrices are handled by python-flint (``fmpq_mat``: exact rationals, fast determinants). A
symmetric matrix is positive definite iff all its leading principal minors are positive
(Sylvester); the pivots of its LDL' factorisation are the ratios of consecutive minors.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import flint
import numpy as np

from roa.model._system import System


def _fmpq(x: Any) -> flint.fmpq:
    q = x if isinstance(x, Fraction) else Fraction(x)
    return flint.fmpq(q.numerator, q.denominator)


def exact_positive_definite(A: Any) -> tuple[bool, list[Fraction]]:
    """Whether the symmetric rational matrix ``A`` (rows of Fractions, ints or floats, taken
    exactly) is positive definite, and the LDL' pivots up to the first that is not positive.

    One fraction-free elimination (Bareiss, ``fmpz_mat.fflu``) of ``A`` scaled to integers by the
    common denominator ``c`` (a positive scale: same signs) gives every leading minor ``c^k d_k``
    as the ``k``-th diagonal entry of ``U``, in O(n^3) operations on integers no longer than a
    minor (each leading minor computed on its own, as before, was O(n^4)). A row exchange in the
    elimination means the next leading minor is zero: that pivot is 0 and ``A`` is not definite.
    """
    rows = [[_fmpq(v) for v in row] for row in A]
    n = len(rows)
    if any(len(r) != n for r in rows) or any(
        rows[i][j] != rows[j][i] for i in range(n) for j in range(i + 1, n)
    ):
        return False, []  # Sylvester's criterion holds for symmetric matrices only
    if n == 0:
        return True, []
    den = flint.fmpz(1)
    for r in rows:
        for v in r:
            den = den.lcm(v.q)
    M = flint.fmpz_mat(n, n, [v.p * (den // v.q) for r in rows for v in r])
    P, _, _, U = M.fflu()
    perm = P.tolist()
    pivots: list[Fraction] = []
    prev = flint.fmpz(1)
    for k in range(n):
        if perm[k][k] != 1:  # a row exchange: the leading minor of order k + 1 is zero
            pivots.append(Fraction(0))
            return False, pivots
        minor = U[k, k]
        pivots.append(Fraction(int(minor), int(prev)) / int(den))
        if minor <= 0:
            return False, pivots
        prev = minor
    return True, pivots


def interval_negative_definite(lo: np.ndarray, hi: np.ndarray) -> bool:
    """Every symmetric matrix with entries in ``[lo, hi]`` is negative definite (exact rationals).

    With ``mid`` the symmetrised centre and ``t`` a rational bound on the Frobenius radius of the
    interval matrix, every member is ``mid + E`` with ``|E|_2 <= t``, so ``-mid - t I`` positive
    definite proves the claim. Returns False (unproved) for non-finite or overflowing bounds.
    """
    n = lo.shape[0]
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        return False
    Lo = [[Fraction(float(lo[i, j])) for j in range(n)] for i in range(n)]
    Hi = [[Fraction(float(hi[i, j])) for j in range(n)] for i in range(n)]
    mid = [[(Lo[i][j] + Hi[i][j] + Lo[j][i] + Hi[j][i]) / 4 for j in range(n)] for i in range(n)]
    frob2 = sum(
        max(Hi[i][j] - mid[i][j], mid[i][j] - Lo[i][j]) ** 2 for i in range(n) for j in range(n)
    )
    try:
        root = float(np.sqrt(float(frob2)))
    except OverflowError:
        return False
    if not np.isfinite(root):
        return False
    t = Fraction(root) * Fraction(1000001, 1000000) + Fraction(1, 10**300)
    if t * t < frob2:
        return False
    A = [[-mid[i][j] - (t if i == j else 0) for j in range(n)] for i in range(n)]
    return exact_positive_definite(A)[0]


def exact_equilibrium(system: System, center: np.ndarray) -> bool:
    """``f(center) == 0`` exactly (``F(center) == center`` for a map, the residual
    :meth:`roa.System.residual_expr`): written unevaluated in sympy, its floats and the centre
    taken as the exact rationals of the doubles, then evaluated."""
    import sympy as sp

    from roa.model._backend import namespace

    flow = _stepped_flow(system)
    if flow is not None:
        return exact_equilibrium(flow, center)
    xs = list(sp.symbols(f"x0:{len(center)}", real=True))
    with sp.evaluate(False):  # no float is rounded against a rational before it is made exact
        f = system.residual_expr(xs, namespace("sympy"))
    at = {xs[i]: sp.Rational(float(c)) for i, c in enumerate(center)}
    # one substitution of the floats and the symbols at once: every node is rebuilt on exact
    # rational arguments (a network's nested Max of numbers evaluates at once; made exact with
    # the symbols still free, it was simplified symbolically)
    return all(sp.simplify(_exact_at(sp.sympify(fi), at)) == 0 for fi in f)


def _exact_at(expr: Any, at: dict[Any, Any]) -> Any:
    """``expr`` with every float replaced by the exact rational of the double and the symbols
    by the values ``at``, in one pass."""
    import sympy as sp

    return expr.xreplace({**{f: sp.Rational(f) for f in expr.atoms(sp.Float)}, **at})


def _stepped_flow(system: System) -> System | None:
    """For a map that is one explicit step of a field (:class:`roa.model._discrete.Step`), the system of
    that field (its parameters, fixed or ranging, kept), else None.

    ``F(x_eq) = x_eq`` exactly whenever ``f(x_eq) = 0`` exactly: each stage point is ``x_eq``
    plus a combination of the earlier stages, all exactly 0, so every stage is ``f(x_eq) = 0``
    and ``F(x_eq) = x_eq + 0``. The check is then that of the field (a far smaller expression
    than the composed step)."""
    import dataclasses

    from roa.model._discrete import Step
    from roa.model._system import BoundField

    dyn = system.dynamics
    inner = dyn if isinstance(dyn, Step) else getattr(dyn, "func", None)  # bound: unwrapped
    if system.time != "discrete" or not isinstance(inner, Step):
        return None
    common: dict[str, Any] = {"name": system.name, "equilibrium": system.equilibrium,
              "state_names": system.state_names}  # fmt: skip
    if isinstance(dyn, BoundField):
        return System(field=inner.func, params=dict(dyn.params), **common)
    field = inner.func if inner is dyn else dataclasses.replace(dyn, func=inner.func)  # type: ignore[type-var]
    return System(field=field, **common)
