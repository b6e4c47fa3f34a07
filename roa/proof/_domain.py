"""Proofs and refutations that a sublevel set lies inside a system's declared domain.

A certificate of ``{V <= c}`` says nothing about points where the model is not defined: a system
with a ``margin`` (positive inside its domain) is certified only where ``{V <= c}`` is proved to
lie inside ``{margin > 0}``. Three tools, each independent of any solver:

* :func:`check_domain_certificate`: the exact check of a Putinar (S-procedure) certificate::

      margin(d) - eps - lambda(d) (c - V(d)) = m0(d)' Q0 m0(d),   lambda = m1(d)' Q1 m1(d),

  ``d = x - x_eq``, ``eps > 0``, ``Q0`` and ``Q1`` positive definite in exact rationals. Then on
  ``{V <= c}``: ``margin >= eps + lambda (c - V) >= eps > 0``. A fresh candidate (float Gram
  matrices of :mod:`roa.search._sos_program`) is rounded and ``Q0`` projected onto the identity
  (Peyrl-Parrilo: :func:`roa.proof._putinar.check_identity`, the one exact check); a stored one is checked exactly as stored.
* :func:`interval_containment`: an interval branch and bound over a proved cover of the set
  (:func:`roa.proof.prove_cover`): every box has ``V > c`` or ``margin > 0`` (outward
  rounding), within a budget of boxes and seconds. It proves the claim for the equilibrium's
  component of the set when the cover is only proved for it.
* :func:`confirmed_outside`: a proposed point with ``V <= c`` and ``margin <= 0`` (found along
  rays from the equilibrium and moved by SLSQP to a local minimum of V on ``{margin <= 0}``,
  :func:`roa.search._outside.domain_witness`), believed only once re-checked at 50 digits and
  proved to lie in the equilibrium's component of ``{V <= V(x)}``. It refutes every level from
  ``V(x)`` up.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from roa.lyapunov import Lyapunov
from roa.model._backend import namespace
from roa.model._system import System
from roa.proof._interval import INTERVAL, Interval
from roa.proof._putinar import Certificate, check_identity
from roa.proof._sos_check import (
    NotPolynomial,
    QPoly,
    as_float,
    exact_fraction,
    matrix_digest,
    poly_lin,
)


def margin_poly(system: System, V: Lyapunov) -> QPoly:
    """The margin as an exact polynomial in ``d = x - x_eq`` (``x_eq = V.center``, floats taken
    as the exact rationals of the doubles); raises :class:`NotPolynomial` otherwise."""
    import sympy as sp

    from roa.model._sympy_eval import exact_rationals

    if system.margin is None:
        raise NotPolynomial("the system has no domain margin")
    n = int(V.n)
    xs = list(sp.symbols(f"x0:{n}", real=True))
    d = list(sp.symbols(f"d0:{n}", real=True))
    try:
        with sp.evaluate(False):
            m = system.margin(xs, namespace("sympy"))
        shift = {xs[i]: d[i] + sp.Rational(Fraction(float(c)).numerator,
                                           Fraction(float(c)).denominator)
                 for i, c in enumerate(V.center)}  # fmt: skip
        expr = exact_rationals(sp.sympify(m)).xreplace(shift)
        poly = sp.Poly(expr, *d, domain="QQ")
    except (TypeError, ValueError, AttributeError, NotImplementedError, sp.PolynomialError,
            sp.polys.polyerrors.CoercionFailed, sp.GeneratorsNeeded) as exc:  # fmt: skip
        raise NotPolynomial(f"the domain margin is not polynomial in the state ({exc})") from None
    return {tuple(int(k) for k in mono): exact_fraction(c) for mono, c in poly.terms() if c != 0}


def domain_target(margin: QPoly, eps: Fraction, n: int) -> QPoly:
    """``margin - eps``: the left-hand side of the identity before the multiplier's term."""
    return poly_lin((Fraction(1), margin), (-eps, {tuple([0] * n): Fraction(1)}))


@dataclass(frozen=True)
class DomainCheck:
    """Outcome of :func:`check_domain_certificate`: ``ok`` only if every exact check passed;
    ``certificate`` is the exact, storable form of what was proved."""

    ok: bool
    reason: str
    certificate: dict[str, Any] | None = None
    min_pivot: float | None = None


def check_domain_certificate(margin: QPoly, Vq: QPoly, n: int, level: Any, eps: Any,
                             cert: Certificate, *, stored: bool = False) -> DomainCheck:  # fmt: skip
    """Exact check of ``margin - eps - lambda (c - V) = m0' Q0 m0`` (module docstring): ``cert``
    holds ``(0, m0, Q0)`` and, unless ``lambda = 0``, ``(1, m1, Q1)``.

    ``stored=False``: float Gram matrices, rounded to dyadics, ``Q0`` projected onto the identity;
    ``stored=True``: rationals, checked exactly as given (no projection: the identity must hold
    coefficient by coefficient). ``ok`` only with ``eps``, ``level`` > 0 and ``Q0``, ``Q1``
    positive definite (exact LDL')."""
    c, e = Fraction(level), Fraction(eps)
    if not (c > 0 and e > 0):
        return DomainCheck(False, f"level and eps must be > 0 (got {as_float(c)}, {as_float(e)})")
    one: QPoly = {tuple([0] * n): Fraction(1)}
    if len(cert.blocks(0)) != 1 or len(cert.blocks(1)) > 1 or len(cert.grams) > 2:
        return DomainCheck(False, "the domain certificate needs one block Q0 and at most one Q1")
    res = check_identity(domain_target(margin, e, n),
                         [one, poly_lin((Fraction(-1), Vq), (c, one))], [], cert,
                         rounded=stored)  # fmt: skip
    if not res.ok or res.certificate is None:
        return DomainCheck(False, f"domain certificate: {res.reason}")
    (basis0, P), *_ = res.certificate.blocks(0)
    basis1, R1 = (res.certificate.blocks(1) or [([], [])])[0]
    stored_form = {"eps": str(e), "basis0": [list(b) for b in basis0],
            "basis1": [list(b) for b in basis1],
            "Q0": [[str(v) for v in row] for row in P],
            "Q1": [[str(v) for v in row] for row in R1],
            "digest": matrix_digest(P, R1)}  # fmt: skip
    return DomainCheck(
        True, "margin > 0 on the level set (Putinar certificate, exact)", stored_form, res.min_pivot
    )


# -- witnesses ---------------------------------------------------------------------------------------
def confirmed_outside(
    system: System, V: Lyapunov, x: np.ndarray
) -> tuple[float, dict[str, Any]] | None:
    """``(V(x), check)`` when the proposed point ``x`` refutes every level from ``V(x)`` up:
    ``V(x)`` finite and > 0, ``V(x) <= V(x) (1 + 1e-12)`` and ``margin(x) <= 0`` re-checked at
    50 digits (``check``), ``x`` proved to lie in the equilibrium's component of
    ``{V <= V(x) (1 + 1e-12)}``; else None. Where ``x`` comes from
    (:func:`roa.search._outside.domain_witness`) does not matter."""
    from roa.proof._witness import confirmed_point, recheck_domain_witness

    x = np.asarray(x, dtype=float)
    return confirmed_point(V, x, lambda top: recheck_domain_witness(system, V, x, top))


# -- interval containment ----------------------------------------------------------------------------
@dataclass(frozen=True)
class Containment:
    """Outcome of :func:`interval_containment`: ``status`` ``proved`` / ``inconclusive``."""

    status: str
    message: str
    boxes: int
    info: dict[str, Any] = field(default_factory=dict)


def interval_containment(
    system: System,
    V: Lyapunov,
    level: float,
    *,
    max_boxes: int = 200_000,
    time_limit: float = 60.0,
    cover_estimate: Any = None,
) -> Containment:
    """Prove ``{V <= level}`` inside ``{margin > 0}`` by interval branch and bound (module
    docstring); ``inconclusive`` with the reason when the budget is spent first.
    ``cover_estimate``: see :func:`roa.proof.prove_cover`."""
    from roa.proof._cover import bisect_widest, interval_value, prove_cover

    t0 = time.perf_counter()
    assert system.margin is not None
    box, info, why = prove_cover(V, level, None, budget=max_boxes, estimate=cover_estimate)
    if box is None:
        return Containment("inconclusive", f"no proved cover of the level set: {why}", 0, info)
    scope = "the equilibrium's component of " if info.get("component", True) else ""
    lo, hi = box[0][None, :], box[1][None, :]
    boxes = 0
    while len(lo):
        boxes += len(lo)
        if boxes > max_boxes or time.perf_counter() - t0 > time_limit:
            return Containment("inconclusive", f"the domain containment was not proved within "
                               f"{max_boxes} boxes and {time_limit:g} s ({len(lo)} boxes "
                               "undecided)", boxes, info)  # fmt: skip
        X = [Interval(lo[:, i], hi[:, i]) for i in range(V.n)]
        with np.errstate(all="ignore"):
            m = Interval.of(system.margin(X, INTERVAL))
            Vi = interval_value(V, lo, hi)
        m_lo = np.broadcast_to(np.asarray(m.lo, dtype=float), (len(lo),))
        und = ~((Vi.lo > level) | (m_lo > 0))
        lo, hi = lo[und], hi[und]
        if len(lo):
            lo, hi = bisect_widest(lo, hi)
    return Containment("proved", f"{scope}the level set lies inside the domain (interval branch "
                       f"and bound, {boxes} boxes)", boxes, info)  # fmt: skip
