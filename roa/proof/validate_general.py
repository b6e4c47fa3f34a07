"""Interval validation of a level for any Lyapunov candidate (not only quadratic V).

The claim proved is ``V' < 0`` on ``Omega \\ {x_eq}`` with ``Omega`` the sublevel set
``{V <= level}`` (all of it when a global cover is proved, :func:`roa.proof.cover.gram_cover`) or
its connected component holding the equilibrium (a box with ``V > level`` on its faces,
:func:`roa.proof.cover.prove_boundary`). ``Omega`` is then compact and positively invariant and
every trajectory from it converges to ``x_eq`` (LaSalle). Steps, all in interval arithmetic with
outward rounding:

1. **Cover**: a box ``B`` around ``x_eq`` proved to hold ``Omega``; the face proofs share the
   caller's ``max_boxes`` as their budget (over every box tried).
2. **Near the equilibrium**: the box ``x_eq + r (B - x_eq)`` (largest ``r = 2^-k``) on which the
   Hessian of ``V'`` (second-order jets of ``V' = grad V . f``) is negative definite (exact
   rational check), with ``f(x_eq) = 0`` exactly and ``grad V(x_eq) = 0`` in interval arithmetic;
   else the lowest-order homogeneous part of a polynomial ``V'`` (:mod:`roa.proof.local`).
3. **Branch and bound** over ``B``. A box ``X`` is discarded when

   * the interval ``V > level`` (natural extension, centred form and second-order Taylor form
     ``V(m) + grad V(m) . d + d' [H_V](X) d / 2`` intersected, ``d = x - m``, ``m`` the centre;
     each holds by Taylor's theorem with ``[H_V](X)`` enclosing the Hessian on ``X``);
   * it lies in the local box of step 2;
   * it is inside the domain and ``V' < 0`` on it (the same three forms for ``V'``);
   * it is inside the domain and, on a box reaching past the level surface, the **multiplier
     test** holds: ``F = V' + lambda (level - V) < 0`` on ``X`` for a number ``lambda >= 0``
     (the three forms of ``F``, whose jets are those of ``V'`` and ``V`` combined in interval
     arithmetic). Then every ``x`` of ``X`` with ``V(x) <= level`` has
     ``V'(x) <= V'(x) + lambda (level - V(x)) = F(x) < 0``, whatever ``lambda >= 0`` is; the
     float ``lambda = max(0, grad V' . grad V / |grad V|^2)`` at ``m`` (the Lagrange multiplier of
     ``max V'`` on the level surface, where the two gradients are parallel) only makes ``F`` flat
     there. Near the point where ``V' = 0`` first touches a level surface, ``V'`` changes sign
     just outside the set, so ``V' < 0`` on whole boxes needs boxes as thin as the margin to the
     optimal level; ``F`` has a strict maximum there instead.

   Else the box is split along the coordinate with the largest ``|grad| * width`` (of ``F``
   where it was tried). Undecided box centres inside the set, and at most
   :data:`WITNESS_RAYS` of them (inside or outside) moved onto the level surface along their ray,
   are tried as counterexamples, re-checked at 50 digits with mpmath.

In the whitened frame (:mod:`roa.proof.whiten`) a polynomial ``V`` is evaluated from exact
expansions in ``y`` (the same functions, tighter enclosures).
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
    from roa.lyapunov import exact_rationals

    if lyap.terms is not None:
        ok = True  # every term has degree >= 2 in d = x - x_eq
    else:
        x = [sp.Rational(float(c)) for c in lyap.center]
        try:
            g = lyap.gradient_expr(x, namespace("sympy"))
            ok = all(sp.simplify(exact_rationals(sp.sympify(gi))) == 0 for gi in g)
        except (TypeError, ValueError, RoaInputError):
            ok = False
    try:
        object.__setattr__(lyap, "_gradient_vanishes", ok)
    except AttributeError:
        pass
    return ok


def local_box_proof(system: System, lyap: Lyapunov, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Prove ``V' < 0`` on the box ``[lo, hi]`` (holding ``x_eq``) minus the equilibrium."""
    from roa.proof.exact import exact_equilibrium
    from roa.proof.validate import hessian_negative_definite

    if not gradient_vanishes(lyap) or not exact_equilibrium(system, lyap.center):
        return False
    vd = lyap.vdot_expr(system, Jet.variables(lo[None, :], hi[None, :], order=2), JET)
    return hessian_negative_definite(vd, lyap.n)


def _rows(e: Any, idx: np.ndarray) -> Any:
    """The boxes ``idx`` of a jet coefficient (an exact float, or an Interval per box or scalar)."""
    if type(e) is float:
        return e
    iv = Interval.of(e)
    return iv if iv.lo.ndim == 0 else Interval(iv.lo[idx], iv.hi[idx])


def _forms(v_mid: Any, g_mid: list, g_box: list, h_box: list, delta: list, m: int):
    """Centred form ``f(mid) + sum_i [g_i](box) d_i`` and second-order Taylor form
    ``f(mid) + sum_i g_i(mid) d_i + 1/2 sum_ij [h_ij](box) d_i d_j`` (``d = x - mid``)."""
    n = len(delta)
    cen = tay = _full(v_mid, m)
    for i in range(n):
        cen = cen + _full(g_box[i], m) * delta[i]
        tay = tay + _full(g_mid[i], m) * delta[i]
        for j in range(i, n):
            hij = _full(h_box[i][j], m)
            tay = tay + (hij * 0.5 * delta[i].square() if j == i else hij * (delta[i] * delta[j]))
    return cen, tay


def _meet(*ivs: Interval) -> Interval:
    """The intersection of enclosures of the same values (one per box)."""
    m = max(np.shape(iv.lo)[0] if np.ndim(iv.lo) else 1 for iv in ivs)
    lo = np.maximum.reduce([np.broadcast_to(iv.lo, (m,)) for iv in ivs])
    hi = np.minimum.reduce([np.broadcast_to(iv.hi, (m,)) for iv in ivs])
    return Interval(lo, hi)


def _midpoints(e: Any, m: int) -> np.ndarray:
    if type(e) is float:
        return np.full(m, e)
    iv = Interval.of(e)
    return np.broadcast_to(0.5 * iv.lo + 0.5 * iv.hi, (m,))


def _evaluate(system: System, lyap: Lyapunov, lo: np.ndarray, hi: np.ndarray, level: float):
    """Enclosures on the boxes: ``V`` and ``V'`` (natural extension, centred and second-order
    Taylor forms intersected), the upper bound of ``F = V' + lambda (level - V)`` on the boxes
    that reach past the level surface (``inf`` elsewhere, step 3 of the module doc), the split
    scores and the domain margin (None without a domain)."""
    from roa.proof.validate import box_offsets

    n, m = lyap.n, len(lo)
    mid = 0.5 * (lo + hi)
    delta = box_offsets(lo, hi, mid)
    vd = lyap.vdot_expr(system, Jet.variables(lo, hi, order=2), JET)
    at = lyap.vdot_expr(system, Jet.variables(mid, mid, order=1), JET)
    cen, tay = _forms(at.v, at.g, vd.g, vd.h, delta, m)
    vdot = _meet(_full(vd.v, m), cen, tay)
    Vb = lyap.expr(Jet.variables(lo, hi, order=2), JET)
    Vm = lyap.expr(Jet.variables(mid, mid, order=1), JET)
    V = _meet(_full(Vb.v, m), *_forms(Vm.v, Vm.g, Vb.g, Vb.h, delta, m))
    score = np.zeros_like(lo)
    for i in range(n):
        g = _full(vd.g[i], m)
        score[:, i] = np.maximum(np.abs(g.lo), np.abs(g.hi)) * (hi[:, i] - lo[:, i])
    F_hi = np.full(m, np.inf)
    idx = np.flatnonzero(~(V.lo > level) & ~(vdot.hi < 0) & (V.hi > level))
    if len(idx):
        k = len(idx)
        gd = np.stack([_midpoints(_rows(at.g[i], idx), k) for i in range(n)], axis=1)
        gv = np.stack([_midpoints(_rows(Vm.g[i], idx), k) for i in range(n)], axis=1)
        with np.errstate(all="ignore"):
            lam = np.sum(gd * gv, axis=1) / np.sum(gv * gv, axis=1)
        lam = Interval(np.where(np.isfinite(lam) & (lam > 0), lam, 0.0))  # any lambda >= 0
        rest = Interval(level) - _full(_rows(Vm.v, idx), k)

        def comb(a: Any, b: Any) -> Interval:  # a - lambda b
            return _full(_rows(a, idx), k) - lam * _full(_rows(b, idx), k)

        f_mid = _full(_rows(at.v, idx), k) + lam * rest
        f_nat = _full(_rows(vd.v, idx), k) + lam * (Interval(level) - _full(_rows(Vb.v, idx), k))
        g_mid = [comb(at.g[i], Vm.g[i]) for i in range(n)]
        g_box = [comb(vd.g[i], Vb.g[i]) for i in range(n)]
        h_box = [[comb(vd.h[i][j], Vb.h[i][j]) if j >= i else 0.0 for j in range(n)]
                 for i in range(n)]  # fmt: skip
        d_idx = [Interval(d.lo[idx], d.hi[idx]) for d in delta]
        f_cen, f_tay = _forms(f_mid, g_mid, g_box, h_box, d_idx, k)
        F_hi[idx] = np.minimum(np.minimum(f_nat.hi, f_cen.hi), f_tay.hi)
        w = hi[idx] - lo[idx]
        score[idx] = np.stack(
            [np.maximum(np.abs(g_box[i].lo), np.abs(g_box[i].hi)) * w[:, i] for i in range(n)],
            axis=1,
        )
    margin = None
    if system.margin is not None:
        X = [Interval(lo[:, i], hi[:, i]) for i in range(n)]
        margin = _full(system.margin(X, INTERVAL), m)
    return V, vdot, F_hi, score, margin


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


#: Box centres moved onto the level surface along their ray per batch (those with the largest
#: float V').
WITNESS_RAYS = 4096


def _witness(system: System, lyap: Lyapunov, pts: np.ndarray, level: float) -> np.ndarray | None:
    """A point of ``{V <= level}`` with V' >= 0 among ``pts`` inside the set and the moves onto
    the level surface, along their ray from the equilibrium, of at most :data:`WITNESS_RAYS` of
    ``pts`` (inward for those outside, outward for those inside: near a critical level ``V' >= 0``
    first appears at the surface). A search: every candidate is re-checked."""
    c = lyap.center
    with np.errstate(all="ignore"):
        Vp = lyap.value(pts)
        inner = pts[Vp <= level]
        ray = np.flatnonzero(np.any(pts != c, axis=1))
        if len(ray) > WITNESS_RAYS:
            Vd_ray = np.nan_to_num(lyap.derivative(system, pts[ray]), nan=-np.inf)
            ray = ray[np.argsort(-Vd_ray, kind="stable")[:WITNESS_RAYS]]
        pts, t_hi = pts[ray], np.ones(len(ray))
        t_lo = np.where(Vp[ray] <= level, 1.0, 0.0)
        for _ in range(60):  # inside: double t until V > level (bounded sets; else dropped)
            grow = (t_lo == t_hi) & (t_hi < 2.0**59)
            if not grow.any():
                break
            t_hi[grow] *= 2.0
            ok = lyap.value(c + t_hi[grow, None] * (pts[grow] - c)) <= level
            t_lo[np.flatnonzero(grow)[ok]] = t_hi[grow][ok]
        keep = t_lo < t_hi
        pts, t_lo, t_hi = pts[keep], t_lo[keep], t_hi[keep]
        for _ in range(45):  # along each ray: a t with V <= level, V > level a little further
            mid = 0.5 * (t_lo + t_hi)
            ok = lyap.value(c + mid[:, None] * (pts - c)) <= level
            t_lo, t_hi = np.where(ok, mid, t_lo), np.where(ok, t_hi, mid)
        # just inside the level set (1 - 1e-6 of the way): a witness there is provably in the
        # equilibrium's component with short interval pieces (connected_to_center)
        moved = c + (t_lo * (1 - 1e-6))[:, None] * (pts - c)
        cand = np.concatenate([inner, moved[t_lo > 0]])
        if not len(cand):
            return None
        Vd, Vc = lyap.derivative(system, cand), lyap.value(cand)
    bad = (Vd >= 0) & (Vc <= level) & np.isfinite(Vd) & np.any(cand != c, axis=1)
    if system.margin is not None:
        bad &= system.inside(cand)
    idx = np.flatnonzero(bad)
    return None if idx.size == 0 else cand[idx[np.argmax(Vd[idx])]]


def _cover(
    lyap: Lyapunov, level: float, bounding_box: Any, budget: int = 400_000
) -> tuple[Any, dict[str, Any], str]:
    """(lo, hi) of a proved cover, its description, or (None, info, why not); ``budget``: boxes
    of the face proofs (:func:`roa.proof.cover.prove_boundary`) over all the boxes tried."""
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
        ok, nb = prove_boundary(lyap, lo, hi, level, budget=budget)
        info = {"cover": "given box, V > level on its faces (component of x_eq)", "cover_boxes": nb}
        return ((lo, hi), info, "") if ok else (None, info, "V > level not proved on its faces")
    w = ray_box(lyap, level)
    if w is None:
        return None, {}, "V stays below the level along some ray: the sublevel set is unbounded"
    total = 0
    for k in range(6):
        half = w * 1.05 * 1.3**k + 1e-12 * (1 + np.abs(c))
        ok, nb = prove_boundary(lyap, c - half, c + half, level, budget=budget - total)
        total += nb
        if ok:
            info = {"cover": "box from rays, V > level on its faces (component of x_eq)",
                    "cover_boxes": total}  # fmt: skip
            return (c - half, c + half), info, ""
        if total >= budget:
            break
    return None, {"cover_boxes": total}, (f"V > level could not be proved on the faces of a box "
                                          f"({total} boxes, budget {budget})")  # fmt: skip


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

    box, info, why = _cover(lyap, level, bounding_box, budget=max_boxes)
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
    boxes = proved = proved_F = 0
    while queue_lo:
        lo, hi = np.concatenate(queue_lo), np.concatenate(queue_hi)
        queue_lo = [lo[batch:]] if len(lo) > batch else []
        queue_hi = [hi[batch:]] if len(hi) > batch else []
        lo, hi = lo[:batch], hi[:batch]
        boxes += len(lo)
        V, Vd, F_hi, score, margin = _evaluate(system, lyap, lo, hi, level)
        inside = np.ones(len(lo), dtype=bool) if margin is None else margin.lo > 0
        in_local = np.all((lo >= loc_lo) & (hi <= loc_hi), axis=1)
        decreasing = ((Vd.hi < 0) | (F_hi < 0)) & inside
        undecided = ~((V.lo > level) | in_local | decreasing)
        proved += int(np.count_nonzero(decreasing))
        proved_F += int(np.count_nonzero(decreasing & ~(Vd.hi < 0)))
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
               meta={"proved_boxes": proved, "proved_by_multiplier": proved_F, **info,
                     **local})  # fmt: skip


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
