"""Parity of the one interval validator with the quadratic-only loop it replaced, on the same V.

Run: ``python benchmarks/bench_validator_parity.py [--repeats 3]``.

**Baseline** (labelled ``base``): a verbatim copy, kept in this file below, of the quadratic-only
branch and bound that ``roa.proof.validate_level`` ran for a
:class:`~roa.lyapunov.QuadraticLyapunov` before the one loop (whitened frame ``x = c + M y``
from the Cholesky factor of ``P``, closed-form interval ``V = y' G y``, jets of
``V' = 2 (x - c)' P f``, an inner level ``eps`` proved by the Hessian of ``V'``, domain-witness
early exit); its degenerate-linearisation branch (lowest-order homogeneous part) is left out,
since none of the cases reaches it. It is the reference the ratios are taken against.

**One loop** (:func:`roa.proof.validate_level` today) on three spellings of the same V:

* ``quad``: the system's default ``QuadraticLyapunov`` (closed-form strategy for V,
  :class:`roa.proof.QuadraticForm`);
* ``poly``: the same V written as a degree-2 :class:`~roa.lyapunov.PolynomialLyapunov` from its
  Gram matrix ``P`` over the linear monomials (also the closed-form strategy);
* ``jets``: ``quad`` with the closed-form strategy switched off (V through interval jets), to
  measure what the strategy buys.

Cases: Van der Pol with its default V at 2.30 (certified) and 2.31 (refuted); the IPC paper's V in
flat coordinates (``ipc-flat``) at 2.28 (certified) and 2.29 (refuted). Boxes are the branch and
bound's box evaluations; ``cover`` is the one loop's extra boxes proving its box cover (0 with the
Gram cover of a quadratic V); the box ratio is one loop (B&B + cover) / baseline. Seconds are wall
time around each call, the minimum over the repeats (median printed too). Target (redesign issue):
the one loop within 1.5x of the baseline in time, same verdicts (exit 1 if a verdict differs).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

import roa
from roa.errors import RoaInputError
from roa.lyapunov import PolynomialLyapunov, QuadraticLyapunov
from roa.model._system import System
from roa.proof import _validate as one
from roa.proof._exact import exact_equilibrium
from roa.proof._interval import INTERVAL, Interval, box_offsets
from roa.proof._jet import Jet
from roa.proof._jet_net import JET
from roa.proof._local import hessian_negative_definite
from roa.proof._validate import validate_level
from roa.proof._validation import Validation
from roa.search._rays import ray_box
from roa.status import Verdict
from roa.systems.vanderpol import vanderpol

CASES = (
    ("vanderpol", vanderpol, (2.30, 2.31)),
    ("ipc-flat", lambda: roa.load_system("ipc-flat"), (2.28, 2.29)),
)


# == BASELINE: the quadratic-only loop as it was (copied from roa/proof/_validate.py) ==============
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
    """The mpmath namespace of :mod:`roa.model._backend` (every function, saturation included)."""
    from roa.model._backend import namespace

    return namespace("mpmath")


def _recheck_witness(
    system: System, lyap: QuadraticLyapunov, x: np.ndarray, level: float, *, digits: int = 50
) -> dict[str, Any]:
    """Evaluate ``V(x)`` and ``V'(x)`` at ``digits`` decimal digits (the float ``x`` taken exactly)."""
    import mpmath as mp

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


def _recheck_domain_witness(
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
def _local_proof(system: System, lyap: QuadraticLyapunov, eps: float) -> bool:
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


def _find_eps(
    system: System, lyap: QuadraticLyapunov, level: float, *, tries: int = 40
) -> float | None:
    """Largest ``eps = level / 2^k`` (k = 1..tries) with a successful :func:`local_proof`."""
    for k in range(1, tries + 1):
        eps = level / 2.0**k
        if _local_proof(system, lyap, eps):
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


def validate_quadratic_baseline(
    system: System,
    lyap: QuadraticLyapunov,
    level: float,
    *,
    max_boxes: int = 3_000_000,
    batch: int = 100_000,
    eps: float | None = None,
) -> Validation:
    """BASELINE: the quadratic-only loop of ``validate_level`` as it was before the one loop."""
    level = float(level)
    t0 = time.perf_counter()
    if eps is None:
        eps = _find_eps(system, lyap, level)
    elif not _local_proof(system, lyap, eps):
        eps = None
    local_info: dict[str, Any] = {"local_proof": "hessian"}  # (higher-order branch omitted)
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
                check = _recheck_domain_witness(system, lyap, w, level)
                if check["confirmed"]:
                    return Validation(
                        Verdict.INCONCLUSIVE,
                        level,
                        boxes,
                        time.perf_counter() - t0,
                        message="the level set reaches the domain boundary "
                        f"({system.domain_description}): V <= level at a point outside the "
                        "domain (float and 50 digits); no certificate for this level",
                        meta={"domain_witness": [float(v) for v in w], "domain_check": check},
                    )
        if len(lo):
            w = _try_witnesses(system, lyap, lyap.center + 0.5 * (lo + hi) @ fr.M.T, level)
            if w is not None:
                check = _recheck_witness(system, lyap, w, level)
                if check["confirmed"]:
                    return Validation(
                        Verdict.REFUTED,
                        level,
                        boxes,
                        time.perf_counter() - t0,
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
        message=f"V' < 0 proved on {proved} boxes of the shell; local proof on V <= {eps:.3g}",
        meta={"proved_boxes": proved, **local_info},
    )


# == the benchmark ===================================================================================
def as_polynomial(V: QuadraticLyapunov) -> PolynomialLyapunov:
    """``V = d' P d`` as a degree-2 polynomial: the Gram matrix ``P`` over the linear monomials."""
    basis = [tuple(int(i == j) for i in range(V.n)) for j in range(V.n)]
    return PolynomialLyapunov.from_gram(basis, V.P, V.center, name=f"{V.name} (polynomial)")


@contextmanager
def jets_for_v():
    """The one loop with its closed-form strategy for quadratic V switched off."""
    saved = one.QuadraticForm.of
    one.QuadraticForm.of = classmethod(lambda cls, lyap: None)  # type: ignore[assignment]
    try:
        yield
    finally:
        one.QuadraticForm.of = saved  # type: ignore[method-assign]


def timed(fn, repeats: int):
    """The last result and the wall times of ``repeats`` calls."""
    secs = []
    for _ in range(repeats):
        t = time.perf_counter()
        res = fn()
        secs.append(time.perf_counter() - t)
    return res, secs


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--repeats", type=int, default=3, help="calls per path and case (min taken)")
    args = ap.parse_args()
    validate_level(
        vanderpol(), roa.default_lyapunov(vanderpol()), 1.0, cover_estimate=ray_box
    )  # warm imports
    validate_quadratic_baseline(vanderpol(), roa.default_lyapunov(vanderpol()), 1.0)
    head = (
        f"{'case':<10} {'level':>5} {'path':<5} {'verdict base/one':<21} {'boxes b':>8} "
        f"{'boxes 1':>8} {'cover':>6} {'ratio':>6} {'s b min':>8} {'s 1 min':>8} "
        f"{'s b med':>8} {'s 1 med':>8} {'ratio':>6}"
    )
    print(head)
    differ = []
    for name, make, levels in CASES:
        system = make()
        V = roa.default_lyapunov(system)
        P = as_polynomial(V)
        for level in levels:
            b, sb = timed(lambda: validate_quadratic_baseline(system, V, level), args.repeats)  # noqa: B023
            for label, W, jets in (("quad", V, False), ("poly", P, False), ("jets", V, True)):
                with jets_for_v() if jets else _nothing():
                    g, sg = timed(
                        lambda: validate_level(system, W, level, cover_estimate=ray_box),  # noqa: B023
                        args.repeats,
                    )
                cover = int(g.meta.get("cover_boxes", 0))
                verdicts = f"{b.status.value}/{g.status.value}"
                if b.status != g.status:
                    differ.append(f"{name} {level} {label}: {verdicts}")
                print(
                    f"{name:<10} {level:>5.2f} {label:<5} {verdicts:<21} {b.boxes:>8} "
                    f"{g.boxes:>8} {cover:>6} {(g.boxes + cover) / b.boxes:>6.2f} "
                    f"{min(sb):>8.3f} {min(sg):>8.3f} {statistics.median(sb):>8.3f} "
                    f"{statistics.median(sg):>8.3f} {min(sg) / min(sb):>6.2f}"
                )
    if differ:
        print("verdicts differ: " + "; ".join(differ))
        sys.exit(1)


@contextmanager
def _nothing():
    yield


if __name__ == "__main__":
    main()
