"""A positive definite Gram matrix for a searched polynomial V (proposes only).

The exact SOS route proves ``{V <= c}`` bounded from ``V >= mu |d|^2``, which
:func:`roa.proof.gram_cover` reads from a Gram matrix of ``V`` over a basis holding the
linear monomials, reproduced exactly and proved positive definite in rationals. A V found by the
V-s iteration comes as coefficients only; :func:`attach_gram` finds such a matrix by one small
program of :class:`roa.search._sdp.Program` (``V = m' Q m`` coefficient by coefficient,
``Q >= t s I`` with ``s`` V's largest coefficient and ``t <= 1`` maximised, ``m`` the monomials
of degree ``1..deg V / 2``) and attaches it as ``V.gram``. Only the exact cover decides; a V
without a positive definite Gram matrix keeps none.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.search._sdp import Program, monomials, solve


def attach_gram(V: Any, solver_options: dict[str, Any] | None = None) -> bool:
    """Attach a positive definite Gram matrix to the polynomial ``V`` (``V.gram``) when the
    program finds one that the exact cover (:func:`roa.proof.gram_cover`) proves positive
    definite; whether it did."""
    poly = V.polynomial_view() or {}
    terms = {tuple(int(k) for k in m): float(c) for m, c in poly.items() if c}
    if not terms or V.gram_view() is not None:
        return V.gram_view() is not None
    n = int(V.n)
    deg = max(sum(m) for m in terms)
    if deg % 2 or min(sum(m) for m in terms) < 2:
        return False
    basis = monomials(n, deg // 2, 1)
    prog = Program(n)
    prog.const({m: -c for m, c in terms.items()})
    t = prog.scalar()
    Q = prog.gram(basis, None, sign=1.0, margin=t * max(abs(c) for c in terms.values()))
    res = solve(prog.problem(t, extra=[t <= 1]), options=solver_options)
    if not res.usable or t.value is None or not float(t.value) > 0 or Q.value is None:
        return False
    from roa.proof._cover import gram_cover

    V.with_gram((basis, 0.5 * (np.asarray(Q.value) + np.asarray(Q.value).T)))
    if gram_cover(V, 1.0) is None:  # not proved positive definite exactly: none attached
        V.with_gram(None)
        return False
    return True
