"""Exact containment of one centred ellipsoid in another (rational arithmetic, no solver).

``{x : x'Qx <= a}`` lies inside ``{x : x'Px <= b}`` (same centre, ``Q`` positive definite) iff
``max_{x'Qx <= a} x'Px = a lambda_max(Q^{-1} P) <= b``, i.e. iff ``b Q - a P`` is positive
semidefinite. :func:`ellipsoid_contains` decides this with every float input taken as the exact
rational it represents and a symmetric Gaussian elimination (LDL') in :class:`fractions.Fraction`:
a *strictly* positive definite ``b Q - a P`` (all pivots > 0) proves the containment with room to
spare. The float ratio ``a lambda_max / b`` is reported for information only.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.proof._exact import exact_positive_definite


def _exact(x: Any) -> Fraction:
    if isinstance(x, Fraction):
        return x
    if isinstance(x, int | np.integer):
        return Fraction(int(x))
    v = float(x)
    if not np.isfinite(v):
        raise RoaInputError(f"ellipsoid data must be finite, got {x!r}")
    return Fraction(v)


def ellipsoid_contains(P: np.ndarray, b: Any, Q: np.ndarray, a: Any) -> dict[str, Any]:
    """Decide ``{x'Qx <= a} subset {x'Px <= b}`` exactly (see the module docstring).

    Parameters
    ----------
    P, b : ndarray, float or Fraction
        The outer ellipsoid ``x'Px <= b`` (``P`` symmetric; the float entries are taken exactly).
    Q, a : ndarray, float or Fraction
        The inner ellipsoid ``x'Qx <= a`` (``Q`` positive definite, ``a > 0``; e.g.
        ``a = Fraction(489, 100)`` for a decimal level stated in a paper).

    Returns
    -------
    dict
        ``status`` ("proved" when ``b Q - a P`` is positive definite in exact arithmetic,
        "not proved" otherwise), ``ratio`` = float ``a lambda_max(Q^-1 P) / b`` (containment iff
        <= 1), ``min_pivot`` (exact smallest LDL' pivot, as float) and ``method``.
    """
    P = np.asarray(P)
    Q = np.asarray(Q)
    n = P.shape[0]
    if P.shape != (n, n) or Q.shape != (n, n):
        raise RoaInputError(f"P and Q must be square of the same size, got {P.shape} and {Q.shape}")
    a, b = _exact(a), _exact(b)
    if a <= 0 or b <= 0:
        raise RoaInputError(f"levels must be > 0, got a = {float(a)}, b = {float(b)}")
    Pf = [[_exact(P[i, j]) for j in range(n)] for i in range(n)]
    Qf = [[_exact(Q[i, j]) for j in range(n)] for i in range(n)]
    if any(Pf[i][j] != Pf[j][i] or Qf[i][j] != Qf[j][i] for i in range(n) for j in range(n)):
        raise RoaInputError("P and Q must be exactly symmetric")
    if not exact_positive_definite(Qf)[0]:
        raise RoaInputError(
            "Q must be positive definite (the inner set must be a bounded ellipsoid)"
        )
    A = [[b * Qf[i][j] - a * Pf[i][j] for j in range(n)] for i in range(n)]
    ok, pivots = exact_positive_definite(A)
    Pn, Qn = np.asarray(P, dtype=float), np.asarray(Q, dtype=float)
    Li = np.linalg.inv(np.linalg.cholesky(Qn))
    lam = float(np.linalg.eigvalsh(Li @ Pn @ Li.T)[-1])
    return {
        "status": "proved" if ok else "not proved",
        "ratio": float(a) * lam / float(b),
        "max_inner": float(a) * lam,
        "min_pivot": float(min(pivots)),
        "method": "exact rational LDL' of b Q - a P (all pivots > 0)",
    }
