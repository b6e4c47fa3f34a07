"""Interval validation of a level for any Lyapunov candidate (not only quadratic V).

The claim proved is ``V' < 0`` on ``Omega \\ {x_eq}`` with ``Omega`` the sublevel set
``{V <= level}`` (all of it when a global cover is proved, :func:`roa.proof.cover.gram_cover`) or
its connected component holding the equilibrium (a box with ``V > level`` on its faces,
:func:`roa.proof.cover.prove_boundary`). ``Omega`` is then compact and positively invariant and
every trajectory from it converges to ``x_eq`` (LaSalle). Steps, all in interval arithmetic with
outward rounding:

1. **Cover**: a box ``B`` around ``x_eq`` proved to hold ``Omega``.
2. **Near the equilibrium**: the box ``x_eq + r (B - x_eq)`` (largest ``r = 2^-k``) on which the
   Hessian of ``V'`` (second-order jets of ``V' = grad V . f``) is negative definite (exact
   rational check), with ``f(x_eq) = 0`` exactly and ``grad V(x_eq) = 0`` in interval arithmetic;
   else the lowest-order homogeneous part of a polynomial ``V'`` (:mod:`roa.proof.local`).
3. **Branch and bound** over ``B``: a box is discarded when the interval ``V > level``, when it
   lies in the local box, or when ``V' < 0`` (natural extension, centred and second-order Taylor
   forms intersected) and it is inside the domain. Undecided box centres (moved onto ``V <= level``
   along their ray) are tried as counterexamples, re-checked at 50 digits with mpmath.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.proof.cover import _interval_V, gram_cover, prove_boundary, ray_box
from roa.proof.interval import INTERVAL, Interval
from roa.proof.jet import JET, Jet
from roa.proof.whiten import Whitened, whitened_system, whitening_for
from roa.status import Verdict
from roa.system import System


def recheck_general(
    system: System, lyap: Lyapunov, x: np.ndarray, level: float, *, digits: int = 50
) -> dict[str, Any]:
    """``V(x)`` and ``V'(x)`` at ``digits`` digits (``x`` taken exactly) for any candidate."""
    import mpmath as mp

    from roa.backend import namespace

    ns = namespace("mpmath")  # every function of roa.backend, also minimum, maximum, clip
    with mp.workdps(digits):
        xs = [mp.mpf(float(v)) for v in x]
        V = lyap.expr(xs, ns)
        Vd = lyap.vdot_expr(system, xs, ns)
        nonzero = any(xs[i] != mp.mpf(float(lyap.center[i])) for i in range(lyap.n))
        inside = system.margin is None or system.margin(xs, ns) > 0
        return {
            "digits": digits,
            "V": mp.nstr(V, 20),
            "Vdot": mp.nstr(Vd, 20),
            "confirmed": bool(nonzero and inside and V <= mp.mpf(float(level)) and Vd >= 0),
        }


def _full(e: Any, m: int) -> Interval:
    return Interval(np.full(m, e)) if isinstance(e, float) else Interval.of(e)


def gradient_vanishes(lyap: Lyapunov) -> bool:
    """``grad V(x_eq) = 0`` exactly (sympy, the float centre and constants as exact rationals)."""
    cached = getattr(lyap, "_gradient_vanishes", None)
    if cached is not None:
        return bool(cached)
    import sympy as sp

    from roa.backend import namespace
    from roa.lyapunov_general import PolynomialLyapunov, _exact

    if isinstance(lyap, PolynomialLyapunov):
        ok = True  # every term has degree >= 2 in d = x - x_eq
    else:
        x = [sp.Rational(float(c)) for c in lyap.center]
        try:
            g = lyap.gradient_expr(x, namespace("sympy"))
            ok = all(sp.simplify(_exact(sp.sympify(gi))) == 0 for gi in g)
        except (TypeError, ValueError, RoaInputError):
            ok = False
    try:
        object.__setattr__(lyap, "_gradient_vanishes", ok)
    except AttributeError:
        pass
    return ok


def local_box_proof(system: System, lyap: Lyapunov, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Prove ``V' < 0`` on the box ``[lo, hi]`` (holding ``x_eq``) minus the equilibrium."""
    from roa.proof.validate import exact_equilibrium, hessian_negative_definite

    if not gradient_vanishes(lyap) or not exact_equilibrium(system, lyap.center):
        return False
    vd = lyap.vdot_expr(system, Jet.variables(lo[None, :], hi[None, :], order=2), JET)
    return hessian_negative_definite(vd, lyap.n)


def _evaluate(system: System, lyap: Lyapunov, lo: np.ndarray, hi: np.ndarray):
    from roa.proof.validate import box_offsets

    n, m = lyap.n, len(lo)
    vd = lyap.vdot_expr(system, Jet.variables(lo, hi, order=2), JET)
    mid = 0.5 * (lo + hi)
    at = lyap.vdot_expr(system, Jet.variables(mid, mid, order=1), JET)
    delta = box_offsets(lo, hi, mid)
    vc = _full(at.v, m)
    cen, tay = vc, vc
    score = np.zeros_like(lo)
    for i in range(n):
        g = _full(vd.g[i], m)
        cen = cen + g * delta[i]
        tay = tay + _full(at.g[i], m) * delta[i]
        for j in range(i, n):
            hij = _full(vd.h[i][j], m)
            tay = tay + (hij * 0.5 * delta[i].square() if j == i else hij * (delta[i] * delta[j]))
        score[:, i] = np.maximum(np.abs(g.lo), np.abs(g.hi)) * (hi[:, i] - lo[:, i])
    nat = _full(vd.v, m)
    vdot = Interval(
        np.maximum(np.maximum(nat.lo, cen.lo), tay.lo),
        np.minimum(np.minimum(nat.hi, cen.hi), tay.hi),
    )
    V = _interval_V(lyap, lo, hi)
    margin = None
    if system.margin is not None:
        X = [Interval(lo[:, i], hi[:, i]) for i in range(n)]
        margin = _full(system.margin(X, INTERVAL), m)
    return V, vdot, score, margin


def connected_to_center(lyap: Lyapunov, w: np.ndarray, level: float, *, rounds: int = 40) -> bool:
    """Prove that the segment from the equilibrium to ``w`` lies in ``{V <= level}`` (so ``w`` is
    in the connected component of the equilibrium): interval enclosures of V on boxes covering
    pieces of the segment, pieces split until proved (False if not proved)."""
    c = np.asarray(lyap.center, dtype=float)
    w = np.asarray(w, dtype=float)
    t = np.linspace(0.0, 1.0, 65)
    t0, t1 = t[:-1], t[1:]
    for _ in range(rounds):
        a = c + t0[:, None] * (w - c)
        b = c + t1[:, None] * (w - c)
        V = _interval_V(lyap, np.minimum(a, b), np.maximum(a, b))
        if np.any(V.lo > level):
            return False  # the segment leaves the set: no proof along it
        todo = ~(V.hi <= level)
        if not todo.any():
            return True
        mid = 0.5 * (t0[todo] + t1[todo])
        t0 = np.concatenate([t0[todo], mid])
        t1 = np.concatenate([mid, t1[todo]])
        if len(t0) > 100_000:
            return False
    return False


def _witness(system: System, lyap: Lyapunov, pts: np.ndarray, level: float) -> np.ndarray | None:
    """A point of ``{V <= level}`` with V' >= 0 among ``pts`` and their moves onto the level set."""
    c = lyap.center
    with np.errstate(all="ignore"):
        Vp = lyap.value(pts)
        t_lo, t_hi = np.zeros(len(pts)), np.ones(len(pts))
        for _ in range(45):  # along each ray: the last t with V <= level before 1
            mid = 0.5 * (t_lo + t_hi)
            ok = lyap.value(c + mid[:, None] * (pts - c)) <= level
            t_lo, t_hi = np.where(ok, mid, t_lo), np.where(ok, t_hi, mid)
        # just inside the level set (1 - 1e-6 of the way): a witness there is provably in the
        # equilibrium's component with short interval pieces (connected_to_center)
        moved = c + (t_lo * (1 - 1e-6))[:, None] * (pts - c)
        cand = np.concatenate([pts[Vp <= level], moved[t_lo > 0]])
        if not len(cand):
            return None
        Vd, Vc = lyap.derivative(system, cand), lyap.value(cand)
    bad = (Vd >= 0) & (Vc <= level) & np.isfinite(Vd) & np.any(cand != c, axis=1)
    if system.margin is not None:
        bad &= system.inside(cand)
    idx = np.flatnonzero(bad)
    return None if idx.size == 0 else cand[idx[np.argmax(Vd[idx])]]


def _cover(lyap: Lyapunov, level: float, bounding_box: Any) -> tuple[Any, dict[str, Any], str]:
    """(lo, hi) of a proved cover, its description, or (None, info, why not)."""
    c = lyap.center
    found = gram_cover(lyap, level)
    if found is not None:
        return (c - found[0], c + found[0]), found[1], ""
    if bounding_box is not None:
        b = np.asarray(bounding_box, dtype=float)
        if b.shape == (lyap.n,):
            lo, hi = c - b, c + b
        elif b.shape == (2, lyap.n):
            lo, hi = b[0], b[1]
        else:
            raise RoaInputError(
                f"bounding_box must be {lyap.n} half-widths or a (lo, hi) pair of {lyap.n}-vectors"
            )
        if not (np.all(np.isfinite(b)) and np.all(lo < c) and np.all(c < hi)):
            raise RoaInputError("bounding_box must be finite and hold the equilibrium inside")
        ok, nb = prove_boundary(lyap, lo, hi, level)
        info = {"cover": "given box, V > level on its faces (component of x_eq)", "cover_boxes": nb}
        return ((lo, hi), info, "") if ok else (None, info, "V > level not proved on its faces")
    w = ray_box(lyap, level)
    if w is None:
        return None, {}, "V stays below the level along some ray: the sublevel set is unbounded"
    total = 0
    for k in range(6):
        half = w * 1.05 * 1.3**k + 1e-12 * (1 + np.abs(c))
        ok, nb = prove_boundary(lyap, c - half, c + half, level)
        total += nb
        if ok:
            info = {"cover": "box from rays, V > level on its faces (component of x_eq)",
                    "cover_boxes": total}  # fmt: skip
            return (c - half, c + half), info, ""
    return None, {"cover_boxes": total}, "V > level could not be proved on the faces of a box"


def validate_general(
    system: System,
    lyap: Lyapunov,
    level: float,
    *,
    max_boxes: int = 3_000_000,
    batch: int = 100_000,
    bounding_box: Any = None,
    whiten: bool = True,
) -> Any:
    """Decide ``V' < 0`` on ``{V <= level} \\ {x_eq}`` for any candidate (see module docstring).

    ``whiten``: run the branch and bound on boxes in ``y`` with ``x = x_eq + M y`` and ``M`` from
    the Hessian of V at the equilibrium (:mod:`roa.proof.whiten`; skipped when that Hessian is
    diagonal or not definite, or a ``bounding_box`` is given). The witness is reported in ``x``.
    """
    from roa.proof.validate import Validation

    t0 = time.perf_counter()
    if not np.allclose(system.x_eq, lyap.center):
        raise RoaInputError(f"V must be centred at the equilibrium {system.x_eq.tolist()}")
    if whiten and bounding_box is None and not isinstance(lyap, Whitened):
        M = whitening_for(lyap)
        if M is not None:
            W = Whitened(lyap, system, M)
            res = validate_general(whitened_system(system, W), W, level, max_boxes=max_boxes,
                                   batch=batch, whiten=False)  # fmt: skip
            return _in_x(res, system, lyap, W)

    def out(status: Verdict, boxes: int, message: str, **kw: Any) -> Validation:
        return Validation(status, level, boxes, time.perf_counter() - t0, message=message, **kw)

    box, info, why = _cover(lyap, level, bounding_box)
    if box is None:
        return out(Verdict.INCONCLUSIVE, info.get("cover_boxes", 0),
                   f"no proved box cover of the level set: {why}", meta=info)  # fmt: skip
    lo0, hi0 = box
    c = lyap.center
    local: dict[str, Any] = {"local_proof": "none"}
    loc_lo, loc_hi = c + 1e-6 * (lo0 - c), c + 1e-6 * (hi0 - c)  # not proved: only ends the search
    for k in range(1, 41):
        a, b = c + (lo0 - c) / 2.0**k, c + (hi0 - c) / 2.0**k
        if local_box_proof(system, lyap, a, b):
            loc_lo, loc_hi, local = a, b, {"local_proof": "hessian", "local_scale": 2.0**-k}
            break
    else:
        from roa.proof.local import higher_order_cube

        found = higher_order_cube(system, lyap)
        if found is not None:
            rho = found[0]
            loc_lo, loc_hi = c - rho, c + rho
            local = {"local_proof": "lowest-order homogeneous part", **found[1]}
    queue_lo, queue_hi = [lo0[None, :]], [hi0[None, :]]
    boxes = proved = 0
    while queue_lo:
        lo, hi = np.concatenate(queue_lo), np.concatenate(queue_hi)
        queue_lo = [lo[batch:]] if len(lo) > batch else []
        queue_hi = [hi[batch:]] if len(hi) > batch else []
        lo, hi = lo[:batch], hi[:batch]
        boxes += len(lo)
        V, Vd, score, margin = _evaluate(system, lyap, lo, hi)
        inside = np.ones(len(lo), dtype=bool) if margin is None else margin.lo > 0
        in_local = np.all((lo >= loc_lo) & (hi <= loc_hi), axis=1)
        undecided = ~((V.lo > level) | in_local | ((Vd.hi < 0) & inside))
        proved += int(np.count_nonzero((Vd.hi < 0) & inside))
        lo, hi, score = lo[undecided], hi[undecided], score[undecided]
        if len(lo):
            w = _witness(system, lyap, 0.5 * (lo + hi), level)
            if w is not None:
                check = recheck_general(system, lyap, w, level)
                component = "component" in str(info.get("cover", ""))
                if check["confirmed"] and component and not connected_to_center(lyap, w, level):
                    return out(Verdict.INCONCLUSIVE, boxes,
                               "V' >= 0 at a point of {V <= level} (float and 50 digits), but it "
                               "was not proved to lie in the equilibrium's component of the set",
                               witness=[float(v) for v in w], witness_check=check,
                               meta={**info, **local})  # fmt: skip
                if check["confirmed"]:
                    return out(Verdict.REFUTED, boxes,
                               "V' >= 0 at a point of the level set in the cover (float and 50 "
                               "digits)", witness=[float(v) for v in w], witness_check=check,
                               meta={**info, **local})  # fmt: skip
        if len(lo) and boxes + 2 * len(lo) > max_boxes:
            outside = int(np.count_nonzero(~inside[undecided]))
            return out(Verdict.INCONCLUSIVE, boxes,
                       f"box budget {max_boxes} exhausted with {len(lo)} boxes undecided"
                       + (f" ({outside} not provably inside the domain)" if outside else ""),
                       meta={**info, **local})  # fmt: skip
        if len(lo):
            width = hi - lo
            sc = np.where(np.isnan(score), np.inf, score) * (width > 0)
            k = np.argmax(sc, axis=1)
            unbounded = np.isinf(sc).any(axis=1)  # no finite gradient bound: split the widest side
            k[unbounded] = np.argmax(
                np.where(np.isinf(sc[unbounded]), width[unbounded], -1.0), axis=1
            )
            rows = np.arange(len(lo))
            mid = 0.5 * (lo[rows, k] + hi[rows, k])
            lo2, hi1 = lo.copy(), hi.copy()
            hi1[rows, k] = mid
            lo2[rows, k] = mid
            queue_lo = [lo, lo2, *queue_lo]
            queue_hi = [hi1, hi, *queue_hi]
    if local["local_proof"] == "none":
        return out(Verdict.INCONCLUSIVE, boxes,
                   "V' < 0 proved away from the equilibrium but not near it (neither the Hessian "
                   "of V' nor its lowest-order homogeneous part proves it)", meta={**info, **local})  # fmt: skip
    return out(Verdict.CERTIFIED, boxes,
               f"V' < 0 proved on {proved} boxes of the cover; local proof on a box around x_eq",
               meta={"proved_boxes": proved, **info, **local})  # fmt: skip


def _in_x(res: Any, system: System, lyap: Lyapunov, W: Whitened) -> Any:
    """A whitened validation reported in the system's coordinates (witness mapped and re-checked)."""
    meta = {**res.meta, "coordinates": "whitened: boxes in y, x = x_eq + M y", "M": W.M.tolist()}
    if res.witness is None:
        return dataclasses.replace(res, meta=meta)
    wx = W.to_x(np.asarray(res.witness, dtype=float))
    check = recheck_general(system, lyap, wx, res.level)
    if not check["confirmed"]:  # the exact point x_eq + M y is the witness; its float x is not
        check = {**check, "confirmed_in_y": res.witness_check, "y": list(res.witness)}
    return dataclasses.replace(res, witness=[float(v) for v in wx], witness_check=check, meta=meta)
