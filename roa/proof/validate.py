"""Rigorous validation of a level: V' < 0 on {V <= rho} minus the equilibrium, by interval B&B.

Two proofs, both independent of any optimisation solver:

1. **Near the equilibrium** (:func:`local_proof`): on the bounding box ``B`` of ``{V <= eps}``,
   ``V'(x) = d' H~ d`` with ``d = x - x_eq`` and ``H~`` in the convex hull of ``{H(xi)/2 : xi in B}``
   (Taylor with integral remainder, since ``V'(x_eq) = 0`` and ``grad V'(x_eq) = 0``, both checked in
   interval arithmetic). The interval Hessian ``[H]`` comes from second-order interval jets; every
   matrix in it is negative definite if ``-H_mid - t I`` is positive definite with
   ``t >= ||rad H||_F``, checked exactly in rational arithmetic. So ``V' < 0`` on ``B \\ {x_eq}``.
2. **On the shell** ``{eps <= V <= rho}``: branch and bound over boxes. A box is discarded when its
   interval ``V > rho``, or ``V < eps`` or the interval ``V' < 0`` (natural extension
   intersected with the centred form ``V'(c) + [grad V'] (X - c)``) *and*, for a system with a
   domain, the interval ``system.margin > 0`` on the box; else it is split along the coordinate
   with the largest ``|grad| * width``. A point of ``{V <= rho}`` outside the domain (confirmed at
   50 digits) ends the run ``inconclusive``: the level set reaches the domain boundary. Box
   centres of undecided boxes, scaled radially to the level surface, are tried as
   counterexamples; a witness is re-checked at 50 digits with mpmath.

Verdicts are values (:class:`Validation` with a :class:`roa.status.Verdict`): ``certified`` (boxes, time), ``refuted`` (witness),
``inconclusive`` (box budget exhausted, or the level set leaves the domain).

A candidate that is not a :class:`~roa.lyapunov.QuadraticLyapunov` (a polynomial or any function
``V(x, xp)``) is validated by :func:`roa.proof.validate_general.validate_general`: a proved box
cover of the level set, the same Hessian (or lowest-order) proof near the equilibrium, the same
branch and bound with interval jets of ``V' = grad V . f``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov, QuadraticLyapunov
from roa.proof.exact import exact_equilibrium, interval_negative_definite
from roa.proof.interval import INTERVAL, Interval, _down, _up
from roa.proof.jet import JET, Jet
from roa.status import Verdict
from roa.system import System


@dataclass(frozen=True)
class Validation:
    """Outcome of an interval validation of ``V' < 0`` on ``{V <= level} \\ {x_eq}``."""

    status: Verdict
    level: float
    boxes: int
    seconds: float
    eps: float | None = None
    witness: list[float] | None = None
    witness_check: dict[str, Any] | None = None
    message: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        out = {
            "status": self.status.value,
            "level": self.level,
            "method": "interval",
            "boxes": self.boxes,
            "seconds": round(self.seconds, 3),
            "eps": self.eps,
            "message": self.message,
            **self.meta,
        }
        if self.witness is not None:
            out["witness"] = self.witness
            out["witness_check"] = self.witness_check
        return out


# -- evaluation of V and V' ---------------------------------------------------------------------------
def _vdot(system: System, lyap: QuadraticLyapunov, x: list, xp: Any) -> Any:
    """V' = 2 (x - c)' P f(x), written once for floats, intervals, jets and mpmath numbers."""
    n = lyap.n
    d = [x[i] - float(lyap.center[i]) for i in range(n)]
    f = system.field(0.0, x, xp)
    out = 0.0
    for i in range(n):
        pd = 0.0
        for j in range(n):
            if lyap.P[i, j] != 0.0:
                pd = d[j] * float(lyap.P[i, j]) + pd
        out = pd * f[i] + out
    return out * 2.0


def _mp_namespace() -> Any:
    """The mpmath namespace of :mod:`roa.backend` (every function, saturation included)."""
    from roa.backend import namespace

    return namespace("mpmath")


def recheck_witness(
    system: System, lyap: Lyapunov, x: np.ndarray, level: float, *, digits: int = 50
) -> dict[str, Any]:
    """Evaluate ``V(x)`` and ``V'(x)`` at ``digits`` decimal digits (the float ``x`` taken exactly)."""
    import mpmath as mp

    quad = lyap.as_quadratic()
    if quad is None:
        from roa.proof.validate_general import recheck_general

        return recheck_general(system, lyap, x, level, digits=digits)
    lyap = quad

    with mp.workdps(digits):
        xs = [mp.mpf(float(v)) for v in x]
        d = [xs[i] - mp.mpf(float(lyap.center[i])) for i in range(lyap.n)]
        V = mp.fsum(
            d[i] * mp.mpf(float(lyap.P[i, j])) * d[j] for i in range(lyap.n) for j in range(lyap.n)
        )
        Vd = _vdot(system, lyap, xs, _mp_namespace())
        nonzero = any(v != 0 for v in d)
        inside = system.margin is None or system.margin(xs, _mp_namespace()) > 0
        return {
            "digits": digits,
            "V": mp.nstr(V, 20),
            "Vdot": mp.nstr(Vd, 20),
            "confirmed": bool(nonzero and inside and V <= mp.mpf(float(level)) and Vd >= 0),
        }


def recheck_domain_witness(
    system: System, lyap: QuadraticLyapunov, x: np.ndarray, level: float, *, digits: int = 50
) -> dict[str, Any]:
    """Confirm at ``digits`` digits that ``x`` has ``V(x) <= level`` and ``margin(x) <= 0``."""
    import mpmath as mp

    if system.margin is None:
        raise RoaInputError(f"system {system.name!r} has no domain margin")
    with mp.workdps(digits):
        xs = [mp.mpf(float(v)) for v in x]
        d = [xs[i] - mp.mpf(float(lyap.center[i])) for i in range(lyap.n)]
        V = mp.fsum(
            d[i] * mp.mpf(float(lyap.P[i, j])) * d[j] for i in range(lyap.n) for j in range(lyap.n)
        )
        m = system.margin(xs, _mp_namespace())
        return {
            "digits": digits,
            "V": mp.nstr(V, 20),
            "margin": mp.nstr(m, 20),
            "confirmed": bool(V <= mp.mpf(float(level)) and m <= 0),
        }


# -- proof near the equilibrium -------------------------------------------------------------------------
def local_proof(system: System, lyap: QuadraticLyapunov, eps: float) -> bool:
    """Prove ``V' < 0`` on ``{V <= eps}`` minus the equilibrium (see module doc).

    Works in the whitening frame ``x = c + M y`` of :func:`_frame`: the cube ``|y_i| <= r`` covers
    ``{V <= eps}``, and the Taylor argument is applied to ``V'(c + M y)`` as a function of ``y``.
    """
    n = lyap.n
    if not exact_equilibrium(system, lyap.center):
        return False
    fr = _frame(lyap, eps)
    r = np.full((1, n), fr.radius)
    vd = _vdot(system, lyap, _to_x(lyap, fr, Jet.variables(-r, r, order=2)), JET)
    return hessian_negative_definite(vd, n)


def hessian_negative_definite(vd: Jet, n: int) -> bool:
    """Every matrix in the interval Hessian of the second-order jet ``vd`` (one box) is negative
    definite (exact rationals)."""
    h = vd.h
    assert h is not None, "a second-order jet is needed"

    def bound(e: Any, side: str) -> float:
        return float(np.atleast_1d(getattr(Interval.of(e), side))[0])

    H_lo = np.array([[bound(h[min(i, j)][max(i, j)], "lo") for j in range(n)] for i in range(n)])
    H_hi = np.array([[bound(h[min(i, j)][max(i, j)], "hi") for j in range(n)] for i in range(n)])
    return interval_negative_definite(H_lo, H_hi)


def find_eps(
    system: System, lyap: QuadraticLyapunov, level: float, *, tries: int = 40
) -> float | None:
    """Largest ``eps = level / 2^k`` (k = 1..tries) with a successful :func:`local_proof`."""
    for k in range(1, tries + 1):
        eps = level / 2.0**k
        if local_proof(system, lyap, eps):
            return eps
    return None


# -- branch and bound ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Frame:
    """Whitening coordinates ``x = c + M y`` with ``V = y' G y``, ``G = M' P M ~ I`` enclosed."""

    M: np.ndarray
    G: list  # G[i][j] Interval scalars (rigorous enclosure of M' P M)
    radius: float  # |y_i| <= radius covers {V <= level}


def _frame(lyap: QuadraticLyapunov, level: float) -> _Frame:
    L = np.linalg.cholesky(lyap.P)
    M = np.linalg.inv(L.T)
    n = lyap.n
    PM = [
        [sum((Interval(lyap.P[i, k]) * M[k, j] for k in range(n)), Interval(0.0)) for j in range(n)]
        for i in range(n)
    ]
    G = [
        [sum((PM[k][j] * M[k, i] for k in range(n)), Interval(0.0)) for j in range(n)]
        for i in range(n)
    ]
    # Gershgorin: lambda_min(G) >= min_i (G_ii - sum_j |G_ij|) for every G in the enclosure.
    lam = min(
        float(G[i][i].lo)
        - sum(float(max(abs(G[i][j].lo), abs(G[i][j].hi))) for j in range(n) if j != i)
        for i in range(n)
    )
    if lam <= 0.5:
        raise RoaInputError(
            "whitening failed: P is too ill-conditioned for the interval validation"
        )
    return _Frame(M, G, float(np.sqrt(level / lam)) * (1 + 1e-9))


def _full(e: Any, m: int) -> Interval:
    return Interval(np.full(m, e)) if isinstance(e, float) else Interval.of(e)


def _to_x(lyap: QuadraticLyapunov, fr: _Frame, y: list) -> list:
    n = lyap.n
    return [
        sum((y[j] * float(fr.M[i, j]) for j in range(n) if fr.M[i, j] != 0.0), 0.0)
        + float(lyap.center[i])
        for i in range(n)
    ]


def box_offsets(lo: np.ndarray, hi: np.ndarray, mid: np.ndarray) -> list[Interval]:
    """Intervals enclosing ``x - mid`` for ``x`` in the boxes ``[lo, hi]``, one per coordinate.

    ``lo - mid`` and ``hi - mid`` are rounded outward (at least one ulp), so the centred and
    Taylor forms built on them are strict enclosures even when rounding to nearest would move
    them inward. (Their coefficients, the jet gradients and Hessians, are enclosures too.)

    Parameters
    ----------
    lo, hi : numpy.ndarray
        Box corners, shape ``(m, n)``.
    mid : numpy.ndarray
        Expansion points (any floats inside the boxes), shape ``(m, n)``.
    """
    return [
        Interval(_down(lo[:, i] - mid[:, i]), _up(hi[:, i] - mid[:, i])) for i in range(lo.shape[1])
    ]


def _evaluate(system: System, lyap: QuadraticLyapunov, fr: _Frame, lo: np.ndarray, hi: np.ndarray):
    """Interval V, interval V' (natural ∩ centred form), |grad V'| * width and the interval
    domain margin (``None`` without a domain) on boxes in y."""
    n = lyap.n

    def to_x(y: list) -> list:
        return _to_x(lyap, fr, y)

    vd = _vdot(system, lyap, to_x(Jet.variables(lo, hi, order=2)), JET)
    mid = 0.5 * (lo + hi)
    at = _vdot(system, lyap, to_x(Jet.variables(mid, mid, order=1)), JET)
    delta = box_offsets(lo, hi, mid)
    vc = Interval.of(at.v)
    cen, tay = vc, vc  # first-order centred form and second-order Taylor form
    score = np.zeros_like(lo)
    for i in range(n):
        g = _full(vd.g[i], len(lo))
        cen = cen + g * delta[i]
        tay = tay + _full(at.g[i], len(lo)) * delta[i]
        for j in range(i, n):
            hij = _full(vd.h[i][j], len(lo))
            tay = tay + (hij * 0.5 * delta[i].square() if j == i else hij * (delta[i] * delta[j]))
        score[:, i] = np.maximum(np.abs(g.lo), np.abs(g.hi)) * (hi[:, i] - lo[:, i])
    nat = Interval.of(vd.v)
    lo_b = np.maximum(np.maximum(nat.lo, cen.lo), tay.lo)
    hi_b = np.minimum(np.minimum(nat.hi, cen.hi), tay.hi)
    vdot = Interval(lo_b, hi_b)
    Y = [Interval(lo[:, i], hi[:, i]) for i in range(n)]
    V: Any = 0.0
    for i in range(n):
        V = Y[i].square() * fr.G[i][i] + V
        for j in range(i + 1, n):
            V = (Y[i] * Y[j]) * (fr.G[i][j] * 2.0) + V
    margin = None
    if system.margin is not None:
        margin = _full(system.margin(to_x(Y), INTERVAL), len(lo))
    return V, vdot, score, margin


def _try_witnesses(system, lyap, pts, level):
    """Float check of candidate points scaled to just inside the level surface; first violator."""
    V = lyap.value(pts)
    ok = V > 0
    if not np.any(ok):
        return None
    d = pts[ok] - lyap.center
    cand = np.concatenate([pts[ok], lyap.center + d * np.sqrt(level / V[ok])[:, None] * (1 - 1e-9)])
    with np.errstate(all="ignore"):
        Vd = lyap.derivative(system, cand)
        Vc = lyap.value(cand)
    bad = (Vd >= 0) & (Vc <= level) & np.isfinite(Vd)
    if system.margin is not None:
        bad &= system.inside(cand)
    bad = np.flatnonzero(bad)
    return None if bad.size == 0 else cand[bad[np.argmax(Vd[bad])]]


def _try_domain_witness(system, lyap, pts, level):
    """A candidate point (or its scaling to the level surface) with V <= level outside the domain."""
    V = lyap.value(pts)
    ok = V > 0
    d = pts[ok] - lyap.center
    cand = np.concatenate([pts, lyap.center + d * np.sqrt(level / V[ok])[:, None] * (1 - 1e-9)])
    with np.errstate(all="ignore"):
        bad = np.flatnonzero(~system.inside(cand) & (lyap.value(cand) <= level))
    return None if bad.size == 0 else cand[bad[0]]


def validate_level(
    system: System,
    lyap: Lyapunov,
    level: float,
    *,
    max_boxes: int = 3_000_000,
    batch: int = 100_000,
    eps: float | None = None,
    bounding_box: Any = None,
) -> Validation:
    """Decide ``V' < 0`` on ``{V <= level} \\ {x_eq}`` rigorously (see module docstring).

    Parameters
    ----------
    system : System
        Autonomous system whose field runs on the interval namespace.
    lyap : Lyapunov
        The candidate, centred at the equilibrium: a ``QuadraticLyapunov`` (whitened boxes), or
        any other candidate (:func:`roa.proof.validate_general.validate_general`).
    level : float
        The level rho > 0 to validate.
    max_boxes : int
        Budget of box evaluations; exhausted -> ``inconclusive``.
    batch : int
        Boxes evaluated per vectorised step.
    eps : float, optional
        Inner level covered by :func:`local_proof`; found automatically by default (quadratic V).
    bounding_box : array, optional
        A non-quadratic V only: ``n`` half-widths around the equilibrium, or a ``(lo, hi)`` pair,
        of a box holding the level set (``V > level`` is proved on its faces). Default: a global
        bound from V's Gram matrix when there is one, else a box found along rays and proved.
    """
    level = float(level)
    if not (np.isfinite(level) and level > 0):
        raise RoaInputError(f"level must be a finite number > 0, got {level!r}")
    if system.time_varying:
        raise RoaInputError(f"system {system.name!r} is time-varying: no equilibrium to certify")
    quad = lyap.as_quadratic()
    if quad is None:
        from roa.proof.validate_general import validate_general

        return validate_general(
            system, lyap, level, max_boxes=max_boxes, batch=batch, bounding_box=bounding_box
        )
    lyap = quad
    if bounding_box is not None:
        raise RoaInputError("bounding_box applies to non-quadratic V only (V' box is whitened)")
    t0 = time.perf_counter()
    if eps is None:
        eps = find_eps(system, lyap, level)
    elif not local_proof(system, lyap, eps):
        eps = None
    local_info: dict[str, Any] = {"local_proof": "hessian"}
    if eps is None:  # degenerate linearisation: the lowest-order homogeneous part of V' decides
        from roa.proof.local import higher_order_eps

        found = higher_order_eps(system, lyap)
        if found is not None:
            eps, info = min(found[0], level / 2), found[1]
            local_info = {"local_proof": "lowest-order homogeneous part", **info}
    no_local = eps is None
    if eps is None:
        # no local proof: the shell is still searched for a counterexample (a refutation needs
        # none), but the verdict can be at best inconclusive
        eps = level * 1e-6
        local_info = {"local_proof": "none"}
    fr = _frame(lyap, level)
    queue_lo = [np.full((1, lyap.n), -fr.radius)]
    queue_hi = [np.full((1, lyap.n), fr.radius)]
    boxes = proved = outside = 0
    while queue_lo:
        lo, hi = np.concatenate(queue_lo), np.concatenate(queue_hi)
        queue_lo, queue_hi = (
            [lo[batch:]] if len(lo) > batch else [],
            [hi[batch:]] if len(hi) > batch else [],
        )
        lo, hi = lo[:batch], hi[:batch]
        boxes += len(lo)
        V, Vd, score, margin = _evaluate(system, lyap, fr, lo, hi)
        inside = np.ones(len(lo), dtype=bool) if margin is None else margin.lo > 0
        undecided = ~((V.lo > level) | (((V.hi < eps) | (Vd.hi < 0)) & inside))
        proved += int(np.count_nonzero((Vd.hi < 0) & inside))
        lo, hi, score = lo[undecided], hi[undecided], score[undecided]
        outside += int(np.count_nonzero(~inside[undecided]))
        if len(lo) and margin is not None and not np.all(inside[undecided]):
            pts = lyap.center + 0.5 * (lo + hi) @ fr.M.T
            w = _try_domain_witness(system, lyap, pts, level)
            if w is not None:
                check = recheck_domain_witness(system, lyap, w, level)
                if check["confirmed"]:
                    return Validation(
                        Verdict.INCONCLUSIVE,
                        level,
                        boxes,
                        time.perf_counter() - t0,
                        eps,
                        message="the level set reaches the domain boundary "
                        f"({system.domain_description}): V <= level at a point outside the "
                        "domain (float and 50 digits); no certificate for this level",
                        meta={"domain_witness": [float(v) for v in w], "domain_check": check},
                    )
        if len(lo):
            w = _try_witnesses(system, lyap, lyap.center + 0.5 * (lo + hi) @ fr.M.T, level)
            if w is not None:
                check = recheck_witness(system, lyap, w, level)
                if check["confirmed"]:
                    return Validation(
                        Verdict.REFUTED,
                        level,
                        boxes,
                        time.perf_counter() - t0,
                        eps,
                        witness=[float(v) for v in w],
                        witness_check=check,
                        message="V' >= 0 at a point of the level set (float and 50 digits)",
                    )
        if boxes + 2 * len(lo) > max_boxes and len(lo):
            return Validation(
                Verdict.INCONCLUSIVE,
                level,
                boxes,
                time.perf_counter() - t0,
                eps,
                message=f"box budget {max_boxes} exhausted with {len(lo)} boxes undecided"
                + (
                    f" ({outside} box evaluations not provably inside the domain "
                    f"{system.domain_description}: the level set may reach its boundary)"
                    if outside
                    else ""
                ),
            )
        if len(lo):
            k = np.argmax(score * (hi - lo > 0), axis=1)
            rows = np.arange(len(lo))
            m = 0.5 * (lo[rows, k] + hi[rows, k])
            lo2, hi1 = lo.copy(), hi.copy()
            hi1[rows, k] = m
            lo2[rows, k] = m
            queue_lo = [lo, lo2, *queue_lo]
            queue_hi = [hi1, hi, *queue_hi]
    if no_local:
        return Validation(
            Verdict.INCONCLUSIVE,
            level,
            boxes,
            time.perf_counter() - t0,
            None,
            message=f"V' < 0 proved on the shell {eps:.3g} <= V <= {level:g} ({proved} boxes), "
            "but not near the equilibrium: neither the Hessian of V' (negative definite) nor "
            "its lowest-order homogeneous part (polynomial V') proves V' < 0 there",
            meta=local_info,
        )
    return Validation(
        Verdict.CERTIFIED,
        level,
        boxes,
        time.perf_counter() - t0,
        eps,
        message=f"V' < 0 proved on {proved} boxes of the shell; local proof on V <= {eps:.3g}",
        meta={"proved_boxes": proved, **local_info},
    )
