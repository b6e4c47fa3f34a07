"""Rigorous validation of a level: V' < 0 on {V <= level} minus the equilibrium, by interval B&B.

One branch and bound for every candidate (quadratic, polynomial, any function ``V(x, xp)``),
independent of any optimisation solver. The claim proved is ``V' < 0`` on ``Omega \\ {x_eq}``
with ``Omega`` the sublevel set ``{V <= level}`` (all of it when a global cover is proved,
:func:`roa.proof.gram_cover`, e.g. for every quadratic V) or its connected component
holding the equilibrium (a box with ``V > level`` on its faces,
:func:`roa.proof._cover.prove_boundary`). ``Omega`` is then compact and positively invariant and
every trajectory from it converges to ``x_eq`` (LaSalle; after the contraction argument of step 2,
to the field's zero ``x*`` next to it). Steps, all in interval arithmetic with outward rounding:

1. **Cover** (:func:`roa.proof.prove_cover`): a box ``B`` around ``x_eq`` proved to hold
   ``Omega``; the face proofs share the caller's ``max_boxes`` as their budget.
2. **Near the equilibrium** (:func:`roa.proof.local_box`): the box
   ``x_eq + 2^-k (B - x_eq)`` (largest ``k`` passing) on which the Hessian of ``V'``
   (second-order jets of ``V' = grad V . f``) is negative definite (exact rational check), with
   ``f(x_eq) = 0`` exactly and ``grad V(x_eq) = 0``; else the lowest-order homogeneous part of a
   polynomial ``V'``; else, for a quadratic V, a contraction argument around an ``f(x_eq)``
   enclosed in a small interval holding 0 (a field written with rounded constants): ``V' < 0``
   on the box outside a set ``K = {V <= equilibrium_level}`` of roundoff size, in which the field
   contracts to its unique zero ``x*``. Trajectories then converge to ``x*``, proved within
   ``equilibrium_radius`` of ``x_eq`` (the meta; ``x* = x_eq`` when ``f(x_eq) = 0``).
3. **Branch and bound** over ``B``. For a quadratic V each box is first shrunk to a box holding
   every point of it with ``V <= level`` (:mod:`roa.proof._contract`; an emptied box is
   discarded). A box ``X`` is discarded when

   * the interval ``V > level`` (natural extension, centred form and second-order Taylor form
     ``V(m) + grad V(m) . d + d' [H_V](X) d / 2`` intersected, ``d = x - m``, ``m`` the centre;
     each holds by Taylor's theorem with ``[H_V](X)`` enclosing the Hessian on ``X``);
   * it lies in the local box of step 2;
   * it is inside the domain (the interval ``system.margin > 0``) and ``V' < 0`` on it (the same
     three forms for ``V'``);
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
   where it was tried).
4. **Witnesses** (a search; every candidate re-checked at 50 digits with mpmath,
   :mod:`roa.proof._witness`): undecided box centres inside the set, and at most
   :data:`WITNESS_RAYS` of them moved onto the level surface along their ray from the
   equilibrium. A point with ``V' >= 0`` refutes the level; so does a point of the set *outside
   the domain* (the level set leaves the domain: the ``domain`` precondition of
   :mod:`roa.proof._preconditions` fails). With a component cover, a point counts only once proved to lie
   in the equilibrium's component (:func:`roa.proof.connected_to_center`).

**Discrete time.** For a map ``x+ = F(x)`` (:attr:`roa.System.time`) ``V'`` is everywhere
the decrease ``Delta V = V(F(x)) - V(x)`` (:meth:`roa.System.decrease_expr`: the one hook through
which the boxes see the system), enclosed by the same jets (of the composition ``V(F(x))``) and
the same three forms; the local proof is the Hessian of ``Delta V`` (:mod:`roa.proof._local`).
The claim is then ``Delta V < 0`` on ``{V <= level} \\ {x_eq}``, and the set must be the whole
sublevel set (a global cover): ``F`` maps it into itself, it is invariant and every orbit in it
converges to ``x_eq`` (the ``invariant`` precondition of :mod:`roa.proof._preconditions`). A
cover of the equilibrium's component alone is refused (inconclusive) for a map.

**Coordinates.** When the Hessian of V at the equilibrium is definite and not diagonal, the
branch and bound runs on boxes in ``y`` with ``x = x_eq + M y`` (:mod:`roa.proof._whiten`); a
polynomial V (a quadratic one included) is then evaluated from exact expansions in ``y``.
Witnesses are reported in ``x``.

**Evaluation strategies for V.** A candidate whose exact terms are all of degree 2 in
``d = x - x_eq`` (every quadratic V, whitened or not) is evaluated in closed form
(:class:`QuadraticForm`: ``V = sum c_a d^a`` with the square of an interval tight, gradient
``2 G d``, constant Hessian ``2 G``; no jets of V); any other V through second-order interval
jets of its expression. Both are enclosures of the same function, so the test above is the
same.

Verdicts are values (:class:`Validation` with a :class:`roa.status.Verdict`): ``certified``
(boxes, time), ``refuted`` (witness), ``inconclusive`` (box budget exhausted, no proved cover, no
local proof, or the level set leaves the domain).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.model._system import System
from roa.proof._contract import contract
from roa.proof._cover import connected_to_center, prove_cover
from roa.proof._interval import INTERVAL, Interval, box_offsets
from roa.proof._jet import Jet, nonsmooth
from roa.proof._jet_net import JET
from roa.proof._local import local_box
from roa.proof._parallel_boxes import box_workers, evaluate_batch
from roa.proof._relax_vdot import has_network, relaxation_bounds
from roa.proof._validation import Reason, Validation
from roa.proof._whiten import Whitened, whitened_system, whitening_for
from roa.proof._witness import recheck_domain_witness, recheck_witness
from roa.status import Verdict


# -- evaluation on boxes ---------------------------------------------------------------------------
def _full(e: Any, m: int) -> Interval:
    return Interval(np.full(m, e)) if isinstance(e, float) else Interval.of(e)


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


@dataclass(frozen=True)
class Enclosure:
    """Value ``v``, gradient ``g`` and (upper triangle of the) Hessian ``h`` enclosed on boxes:
    each a float (exact) or an Interval (per box or scalar), as in a :class:`~roa.proof.Jet`."""

    v: Any
    g: list[Any]
    h: list[list[Any]] | None = None


class QuadraticForm:
    """Closed-form evaluation of a V whose exact terms are all of degree 2 in ``d = x - c``:
    ``V = sum_{i <= j} c_ij d_i d_j`` (each ``c_ij`` a double when it is exactly one, else its
    outward enclosure), so on a box ``V = sum c_ii [d_i]^2 + sum c_ij [d_i][d_j]`` (the square of
    an interval is tight), ``grad V = 2 G d`` and the Hessian is the constant ``2 G``
    (``G_ii = c_ii``, ``G_ij = c_ij / 2``). The same function as ``V.expr``, without jets."""

    def __init__(self, lyap: Lyapunov) -> None:
        self.n = lyap.n
        self.center = np.asarray(lyap.center, dtype=float)
        self.coef: dict[tuple[int, int], Any] = {}
        for a, q in (lyap.polynomial_view() or {}).items():
            idx = [i for i, k in enumerate(a) for _ in range(k)]
            f = float(q)
            exact = Fraction(f) == (q if isinstance(q, Fraction) else Fraction(f))
            self.coef[idx[0], idx[1]] = f if exact else Interval.of(q)

    @classmethod
    def of(cls, lyap: Lyapunov) -> QuadraticForm | None:
        """The closed form of ``lyap``, or None when its exact terms are not all of degree 2."""
        terms = lyap.polynomial_view()
        if not terms or any(sum(a) != 2 for a in terms):
            return None
        return cls(lyap)

    def _hessian(self) -> list[list[Any]]:
        n = self.n
        h: list[list[Any]] = [[0.0] * n for _ in range(n)]
        for (i, j), c in self.coef.items():
            h[i][j] = c * 2.0 if i == j else c  # 2 c is exact (or an enclosure of 2 q)
        return h

    def on(self, d: list[Interval], order: int) -> Enclosure:
        """Value and gradient (and the Hessian for ``order`` 2) on the offsets ``d = x - c``."""
        n = self.n
        v: Any = 0.0
        g: list[Any] = [0.0] * n
        for (i, j), c in self.coef.items():
            if i == j:
                v = d[i].square() * c + v
                g[i] = d[i] * (c * 2.0) + g[i]
            else:
                v = (d[i] * d[j]) * c + v
                g[i] = d[j] * c + g[i]
                g[j] = d[i] * c + g[j]
        return Enclosure(v, g, self._hessian() if order >= 2 else None)

    def boxes(self, lo: np.ndarray, hi: np.ndarray, mid: np.ndarray) -> tuple[Enclosure, Enclosure]:
        """``(on the boxes, at the points mid)``, offsets from the centre rounded outward."""
        c = np.broadcast_to(self.center, lo.shape)
        return self.on(box_offsets(lo, hi, c), 2), self.on(box_offsets(mid, mid, c), 1)


def _v_enclosures(lyap: Lyapunov, lo: np.ndarray, hi: np.ndarray, mid: np.ndarray):
    """V on the boxes (order 2) and at their centres (order 1): closed form or jets."""
    quad = QuadraticForm.of(lyap)
    if quad is not None:
        return quad.boxes(lo, hi, mid)
    kinked = nonsmooth(lambda: lyap.expr(Jet.variables(lo[:1], hi[:1]), JET))
    return (lyap.expr(Jet.variables(lo, hi, order=2, centred=kinked), JET),
            lyap.expr(Jet.variables(mid, mid, order=1, centred=kinked), JET))  # fmt: skip


def _pad(e: Any, k: int) -> Enclosure:
    """An enclosure of a function of the states as one of (states, ``k`` parameters): zero
    derivatives in the parameters (exact)."""
    g = list(e.g) + [0.0] * k
    h = None
    if e.h is not None:
        N = len(g)
        h = [list(row) + [0.0] * k for row in e.h] + [[0.0] * N for _ in range(k)]
    return Enclosure(e.v, g, h)


def evaluate_boxes(
    system: System, lyap: Lyapunov, lo: np.ndarray, hi: np.ndarray, level: float, k: int = 0,
    *, skip_outside: bool = False,
):  # fmt: skip
    """Enclosures on the boxes ``[lo, hi]`` (shape ``(m, n + k)``: the states, then ``k``
    uncertain parameters of a :func:`roa.model._parameters.over` system, which enter the jets as
    variables): ``V`` and ``V'`` (natural extension, centred and second-order Taylor forms
    intersected, over states and parameters), the upper bound of ``F = V' + lambda (level - V)``
    on the boxes that reach past the level surface (``inf`` elsewhere, step 3 of the module doc),
    the split scores (per column) and the domain margin (None without a domain). Returns
    ``(V, V', F_hi, score, margin)``. ``skip_outside``: on the boxes where ``V > level`` is
    proved, ``V'`` is not evaluated (the whole line, ``F_hi = inf``, score 0): the branch and
    bound discards them on ``V`` alone."""
    from roa.model._parameters import parameter_values

    n, m = lyap.n, len(lo)
    N, n_par = n + k, k
    mid = 0.5 * (lo + hi)
    delta = box_offsets(lo, hi, mid)
    enclosures = None  # (V, Vb, Vm) on the boxes, once
    if skip_outside:
        enclosures = _v_on_boxes(lyap, lo, hi, mid, delta, k)
        need = np.flatnonzero(~(enclosures[0].lo > level))
        if len(need) < m:
            return _evaluate_inside(system, lyap, lo, hi, level, k, enclosures[0], need)

    def vdot(X: list[Jet]) -> Any:
        with parameter_values(X[n:] if k else None):
            return lyap.vdot_expr(system, X[:n], JET)

    kinked = nonsmooth(lambda: vdot(Jet.variables(lo[:1], hi[:1])))
    # a network's layer jets take each unit's range from the centred form (roa.proof._jet_net):
    # through tanh layers several times tighter Hessians than the natural extension
    vd = vdot(Jet.variables(lo, hi, order=2, centred=kinked or has_network(system)))
    at = vdot(Jet.variables(mid, mid, order=1, centred=kinked))
    cen, tay = _forms(at.v, at.g, vd.g, vd.h, delta, m)
    vdot_box = _meet(_full(vd.v, m), cen, tay)
    V, Vb, Vm = enclosures or _v_on_boxes(lyap, lo, hi, mid, delta, k)
    score = np.zeros_like(lo)
    n = N  # every column from here: states and parameters
    for i in range(n):
        g = _full(vd.g[i], m)
        score[:, i] = np.maximum(np.abs(g.lo), np.abs(g.hi)) * (hi[:, i] - lo[:, i])
    F_hi = np.full(m, np.inf)
    idx = np.flatnonzero(~(V.lo > level) & ~(vdot_box.hi < 0) & (V.hi > level))
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
    # networks in the field: CROWN / linear-relaxation bounds where the forms above leave boxes
    vdot_box, F_hi = relaxation_bounds(system, lyap, lo, hi, level, V, vdot_box, F_hi, n_par)
    margin = None
    if system.margin is not None:
        X = [Interval(lo[:, i], hi[:, i]) for i in range(lyap.n)]
        margin = _full(system.margin(X, INTERVAL), m)
    return V, vdot_box, F_hi, score, margin


def _v_on_boxes(lyap: Lyapunov, lo: np.ndarray, hi: np.ndarray, mid: np.ndarray, delta: list,
                k: int) -> tuple[Interval, Any, Any]:  # fmt: skip
    """V on the boxes (three forms met), and its enclosures on the boxes and at the centres."""
    n, m = lyap.n, len(lo)
    Vb, Vm = _v_enclosures(lyap, lo[:, :n], hi[:, :n], mid[:, :n])
    if k:
        Vb, Vm = _pad(Vb, k), _pad(Vm, k)
    return _meet(_full(Vb.v, m), *_forms(Vm.v, Vm.g, Vb.g, Vb.h, delta, m)), Vb, Vm


def _evaluate_inside(system: System, lyap: Lyapunov, lo: np.ndarray, hi: np.ndarray,
                     level: float, k: int, V: Interval, need: np.ndarray):  # fmt: skip
    """:func:`evaluate_boxes` on the boxes ``need`` only, the others given ``V`` alone."""
    m = len(lo)
    vd_lo, vd_hi = np.full(m, -np.inf), np.full(m, np.inf)
    F_hi, score = np.full(m, np.inf), np.zeros_like(lo)
    margin = None
    if len(need):
        _, vd, F, sc, _ = evaluate_boxes(system, lyap, lo[need], hi[need], level, k)
        vd_lo[need], vd_hi[need] = vd.lo, vd.hi
        F_hi[need], score[need] = F, sc
    if system.margin is not None:
        X = [Interval(lo[:, i], hi[:, i]) for i in range(lyap.n)]
        margin = _full(system.margin(X, INTERVAL), m)
    return V, Interval(vd_lo, vd_hi), F_hi, score, margin


# -- witness search (floats; every candidate is re-checked) ---------------------------------------
#: Box centres moved onto the level surface along their ray per batch.
WITNESS_RAYS = 4096


def _on_level_set(lyap: Lyapunov, pts: np.ndarray, ray: np.ndarray, level: float) -> np.ndarray:
    """``pts`` inside ``{V <= level}`` and the moves of ``pts[ray]`` onto the level surface along
    their ray from the equilibrium (inward for those outside, outward for those inside: near a
    critical level ``V' >= 0`` first appears at the surface), just inside the set."""
    c = lyap.center
    with np.errstate(all="ignore"):
        Vp = lyap.value(pts)
        inner = pts[Vp <= level]
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
    return np.concatenate([inner, moved[t_lo > 0]])


def _witness(system: System, lyap: Lyapunov, pts: np.ndarray, level: float) -> np.ndarray | None:
    """A point of ``{V <= level}`` with V' >= 0 inside the domain among ``pts`` inside the set and
    the moves onto the level surface of the :data:`WITNESS_RAYS` of ``pts`` with the largest
    float V'."""
    c = lyap.center
    ray = np.flatnonzero(np.any(pts != c, axis=1))
    with np.errstate(all="ignore"):
        if len(ray) > WITNESS_RAYS:
            Vd_ray = np.nan_to_num(lyap.derivative(system, pts[ray]), nan=-np.inf)
            ray = ray[np.argsort(-Vd_ray, kind="stable")[:WITNESS_RAYS]]
        cand = _on_level_set(lyap, pts, ray, level)
        if not len(cand):
            return None
        Vd, Vc = lyap.derivative(system, cand), lyap.value(cand)
    bad = (Vd >= 0) & (Vc <= level) & np.isfinite(Vd) & np.any(cand != c, axis=1)
    if system.margin is not None:
        bad &= system.inside(cand)
    idx = np.flatnonzero(bad)
    return None if idx.size == 0 else cand[idx[np.argmax(Vd[idx])]]


def _domain_witness(
    system: System, lyap: Lyapunov, pts: np.ndarray, level: float
) -> np.ndarray | None:
    """A point of ``{V <= level}`` outside the domain among ``pts`` inside the set and the moves
    of (at most :data:`WITNESS_RAYS` of) ``pts`` onto the level surface."""
    ray = np.flatnonzero(np.any(pts != lyap.center, axis=1))[:WITNESS_RAYS]
    with np.errstate(all="ignore"):
        cand = _on_level_set(lyap, pts, ray, level)
        if not len(cand):
            return None
        bad = np.flatnonzero(~system.inside(cand) & (lyap.value(cand) <= level))
    return None if bad.size == 0 else cand[bad[0]]


# -- the branch and bound ---------------------------------------------------------------------------
def validate_level(
    system: System,
    lyap: Lyapunov,
    level: float,
    *,
    max_boxes: int = 3_000_000,
    batch: int = 100_000,
    bounding_box: Any = None,
    parameters: tuple[Any, Any] | None = None,
    time_limit: float | None = None,
    cover_estimate: Callable[[Lyapunov, float], np.ndarray | None] | None = None,
    workers: int = 1,
) -> Validation:
    """Decide ``V' < 0`` on ``{V <= level} \\ {x_eq}`` rigorously (see module docstring).

    Parameters
    ----------
    system : System
        Autonomous system whose field runs on the interval namespace.
    lyap : Lyapunov
        The candidate, centred at the equilibrium: quadratic, polynomial or any function.
    level : float
        The level > 0 to validate.
    max_boxes : int
        Budget of box evaluations (the cover's face proofs included); exhausted ->
        ``inconclusive``.
    batch : int
        Boxes evaluated per vectorised step.
    bounding_box : array, optional
        ``n`` half-widths around the equilibrium, or a ``(lo, hi)`` pair, of a box holding the
        level set (``V > level`` is proved on its faces; the run is then in ``x``). Default: a
        global bound from V's Gram matrix when there is one (every quadratic V), else a box
        grown from ``cover_estimate`` and proved.
    cover_estimate : callable, optional
        ``cover_estimate(V, level)``: half-widths of a box reached by the level set, a proposal
        (:func:`roa.search.ray_box`); without it, a V with no Gram matrix and no
        ``bounding_box`` has no cover (``inconclusive``).
    parameters : (lo, hi), optional
        For a system over a parameter box (:func:`roa.model._parameters.over`): the box's bounds. The
        branch and bound then runs over states and parameters (boxes of ``n + k`` columns, the
        parameters variables of the jets, split where that decides more) and proves ``V' < 0``
        for every parameter of the box; witnesses are at the system's float point.
    time_limit : float, optional
        Seconds of wall time; past them the verdict is ``inconclusive``.
    workers : int
        Processes evaluating each batch of boxes (forked: :mod:`roa.proof._parallel_boxes`); the
        verdict and the boxes are the same for every number.
    """
    level = float(level)
    if not (np.isfinite(level) and level > 0):
        raise RoaInputError(f"level must be a finite number > 0, got {level!r}")
    if system.time_varying:
        raise RoaInputError(f"system {system.name!r} is time-varying: no equilibrium to certify")
    if not np.allclose(system.x_eq, lyap.center):
        raise RoaInputError(f"V must be centred at the equilibrium {system.x_eq.tolist()}")
    if not (isinstance(workers, int) and workers >= 1):
        raise RoaInputError(f"workers must be an integer >= 1, got {workers!r}")
    # workers: box evaluations in forked processes (roa.proof._parallel_boxes; same result)
    with np.errstate(over="ignore"), box_workers(workers):  # an overflowing bound is +-inf: sound
        res = _branch_and_bound(system, lyap, level, max_boxes=max_boxes, batch=batch,
                                bounding_box=bounding_box, parameters=parameters,
                                deadline=None if time_limit is None
                                else time.perf_counter() + float(time_limit),
                                estimate=cover_estimate)  # fmt: skip
    if "M" not in res.meta:  # boxes in x: the frame (of the component box argument) is I
        meta = {**res.meta, "coordinates": "x", "M": np.eye(lyap.n).tolist()}
        res = dataclasses.replace(res, meta=meta)
    return res


def _branch_and_bound(
    system: System,
    lyap: Lyapunov,
    level: float,
    *,
    max_boxes: int,
    batch: int,
    bounding_box: Any = None,
    whiten: bool = True,
    parameters: tuple[Any, Any] | None = None,
    deadline: float | None = None,
    estimate: Callable[[Lyapunov, float], np.ndarray | None] | None = None,
) -> Validation:
    """The loop of the module doc. ``whiten``: run it on boxes in ``y`` with ``x = x_eq + M y``
    and ``M`` from the Hessian of V at the equilibrium (:mod:`roa.proof._whiten`; skipped when
    that Hessian is diagonal or not definite, or a ``bounding_box`` is given)."""
    t0 = time.perf_counter()
    if whiten and bounding_box is None and lyap.unwhitened() is None:
        M = whitening_for(lyap)
        if M is not None:
            W = Whitened(lyap, system, M)
            res = _branch_and_bound(whitened_system(system, W), W, level, max_boxes=max_boxes,
                                    batch=batch, whiten=False, parameters=parameters,
                                    deadline=deadline, estimate=estimate)  # fmt: skip
            return _in_x(res, system, lyap, W)

    def out(status: Verdict, boxes: int, message: str, **kw: Any) -> Validation:
        return Validation(status, level, boxes, time.perf_counter() - t0, message=message, **kw)

    box, info, why = prove_cover(lyap, level, bounding_box, budget=max_boxes, estimate=estimate)
    if box is None:
        return out(Verdict.INCONCLUSIVE, info.get("cover_boxes", 0),
                   f"no proved box cover of the level set: {why}", meta=info,
                   reason=Reason.NO_COVER)  # fmt: skip
    lo0, hi0 = box
    c = lyap.center
    n = lyap.n
    component = bool(info.get("component", True))  # unknown: the stricter reading
    if component and system.time == "discrete":  # module doc: invariance under a map
        return out(Verdict.INCONCLUSIVE, info.get("cover_boxes", 0),
                   "precondition 'invariant' not met: the cover holds only the equilibrium's "
                   "component of {V <= level}, and a map may jump out of it (prove the whole "
                   "sublevel set: a V with a positive definite Gram matrix, no bounding_box)",
                   meta={**info, "precondition": "invariant"},
                   reason=Reason.PRECONDITION)  # fmt: skip
    plo = phi = np.zeros(0)
    if parameters is not None:
        plo, phi = (np.asarray(a, dtype=float).ravel() for a in parameters)
    n_par = len(plo)
    found = local_box(system, lyap, lo0, hi0) if not n_par else _local_over(system, lyap, lo0, hi0,
                                                                        plo, phi)  # fmt: skip
    if (
        found is None
    ):  # not proved: only ends the search there (the verdict is at best inconclusive)
        loc_lo, loc_hi = c + 1e-6 * (lo0 - c), c + 1e-6 * (hi0 - c)
        local: dict[str, Any] = {"local_proof": "none"}
    else:
        loc_lo, loc_hi, local = found
    queue_lo = [np.concatenate([lo0, plo])[None, :]]
    queue_hi = [np.concatenate([hi0, phi])[None, :]]
    boxes = proved = proved_F = outside = 0
    progress = _Progress(np.concatenate([lo0, plo]), np.concatenate([hi0, phi]))
    quad = QuadraticForm.of(lyap)
    while queue_lo:
        lo, hi = np.concatenate(queue_lo), np.concatenate(queue_hi)
        queue_lo = [lo[batch:]] if len(lo) > batch else []
        queue_hi = [hi[batch:]] if len(hi) > batch else []
        lo, hi = lo[:batch], hi[:batch]
        boxes += len(lo)
        if quad is not None:  # each box shrunk to the part that can meet {V <= level}
            lo, hi, gone = contract(quad, lo, hi, level)
            lo, hi = lo[~gone], hi[~gone]
            if not len(lo):
                continue
        V, Vd, F_hi, score, margin = evaluate_batch(
            evaluate_boxes, system, lyap, lo, hi, level, n_par
        )
        inside = np.ones(len(lo), dtype=bool) if margin is None else margin.lo > 0
        in_local = np.all((lo[:, :n] >= loc_lo) & (hi[:, :n] <= loc_hi), axis=1)
        decreasing = ((Vd.hi < 0) | (F_hi < 0)) & inside
        undecided = ~((V.lo > level) | in_local | decreasing)
        proved += int(np.count_nonzero(decreasing))
        proved_F += int(np.count_nonzero(decreasing & ~(Vd.hi < 0)))
        progress.batch(lo, hi, undecided)
        lo, hi, score = lo[undecided], hi[undecided], score[undecided]
        not_in = ~inside[undecided]
        outside += int(np.count_nonzero(not_in))
        if len(lo) and not_in.any():
            w = _domain_witness(system, lyap, 0.5 * (lo[not_in, :n] + hi[not_in, :n]), level)
            if w is not None:
                check = recheck_domain_witness(system, lyap, w, level)
                if check["confirmed"] and (not component or connected_to_center(lyap, w, level)):
                    return out(Verdict.REFUTED, boxes,
                               "the level set leaves the domain "
                               f"({system.domain_description}): V <= level at a point outside "
                               "the domain (float and 50 digits); no certificate for this level",
                               meta={**info, **local, "domain_witness": [float(v) for v in w],
                                     "domain_check": check, "precondition": "domain",
                                     "domain_level": float(lyap.value(w[None])[0])},
                               reason=Reason.DOMAIN)  # fmt: skip
        if len(lo):
            w = _witness(system, lyap, 0.5 * (lo[:, :n] + hi[:, :n]), level)
            if w is not None:
                check = recheck_witness(system, lyap, w, level)
                if check["confirmed"] and component and not connected_to_center(lyap, w, level):
                    return out(Verdict.INCONCLUSIVE, boxes,
                               "V' >= 0 at a point of {V <= level} (float and 50 digits), but it "
                               "was not proved to lie in the equilibrium's component of the set",
                               witness=[float(v) for v in w], witness_check=check,
                               meta={**info, **local})  # fmt: skip
                if check["confirmed"]:
                    dv = "V(F(x)) - V(x)" if system.time == "discrete" else "V'"
                    return out(Verdict.REFUTED, boxes,
                               f"{dv} >= 0 at a point of the level set in the cover (float and 50 "
                               "digits)", witness=[float(v) for v in w], witness_check=check,
                               meta={**info, **local})  # fmt: skip
        if len(lo) and deadline is not None and time.perf_counter() > deadline:
            reach = progress.reach(lo, hi, queue_lo, queue_hi, boxes, timed=True)
            return out(Verdict.INCONCLUSIVE, boxes,
                       f"time limit reached with {len(lo)} boxes undecided ({boxes} evaluated); "
                       + reach.pop("message"),
                       meta={**info, **local, "time_limit": True, **reach})  # fmt: skip
        if len(lo) and boxes + 2 * len(lo) > max_boxes:
            reach = progress.reach(lo, hi, queue_lo, queue_hi, boxes)
            return out(Verdict.INCONCLUSIVE, boxes,
                       f"box budget {max_boxes} exhausted with {len(lo)} boxes undecided"
                       + (f" ({outside} box evaluations not provably inside the domain "
                          f"{system.domain_description}: the level set may reach its boundary)"
                          if outside else "") + "; " + reach.pop("message"),
                       meta={**info, **local, **reach})  # fmt: skip
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
    near = "local proof on a box around x_eq"
    if "equilibrium_radius" in local:
        near += (" (f(x_eq) enclosed, not proved 0: trajectories converge to the field's unique "
                 f"zero within {local['equilibrium_radius']:.3g} of x_eq)")  # fmt: skip
    extra: dict[str, Any] = {}
    what = "V' < 0"
    if system.time == "discrete":
        what = "V(F(x)) - V(x) < 0"
        extra["invariance"] = ("F maps {V <= level} into itself: V(F(x)) <= V(x) on the whole "
                               "sublevel set (global cover)")  # fmt: skip
    return out(Verdict.CERTIFIED, boxes, f"{what} proved on {proved} boxes of the cover; {near}",
               meta={"proved_boxes": proved, "proved_by_multiplier": proved_F, **info,
                     **local, **extra})  # fmt: skip


class _Progress:
    """How far a branch and bound got: the share of the cover's volume decided and an estimate
    of the boxes a full run needs.

    The estimate models the refinement as a branching process over depths (halvings of the
    cover's volume): a box evaluated at depth ``k`` stays undecided, and is split in two, with
    probability ``q_k``, read off the last :data:`DEPTHS` depths reached. When their mean ``q``
    is below 1/2, each pending box costs ``1 / (1 - 2 q)`` evaluations in expectation. Otherwise,
    when ``q_k`` falls with depth (a weighted linear fit), the pending boxes are carried forward
    depth by depth with the extrapolated ``q_k`` until none is left. When ``q_k >= 1/2`` and not
    falling there is no estimate. A guide, not a bound: it assumes the recent trend holds, so the
    message suggests twice the extrapolation (``boxes_estimate`` in the meta is the extrapolation
    itself)."""

    #: Depths the estimate reads (the deepest reached).
    DEPTHS = 8

    def __init__(self, lo: np.ndarray, hi: np.ndarray) -> None:
        width = hi - lo
        self.axes = width > 0  # degenerate axes (fixed parameters) carry no volume
        self.total = float(np.prod(width[self.axes]))
        # depths in log space: a cover near the float range (level 1e308) overflows the product
        with np.errstate(divide="ignore"):
            self.log_total = float(np.sum(np.log2(width[self.axes])))
        #: per depth: boxes evaluated, boxes undecided
        self.depths: dict[int, list[int]] = {}

    def batch(self, lo: np.ndarray, hi: np.ndarray, undecided: np.ndarray) -> None:
        if not self.total > 0 or not np.isfinite(self.log_total):
            return
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = self.log_total - np.sum(np.log2((hi - lo)[:, self.axes]), axis=1)
        k = np.clip(np.rint(np.nan_to_num(depth, nan=0.0, posinf=1e4)), 0, 10_000).astype(int)
        ev = np.bincount(k)
        un = np.bincount(k[undecided], minlength=len(ev))
        for d in np.flatnonzero(ev):
            row = self.depths.setdefault(int(d), [0, 0])
            row[0] += int(ev[d])
            row[1] += int(un[d])

    def volume(self, lo: np.ndarray, hi: np.ndarray) -> float:
        return float(np.sum(np.prod((hi - lo)[:, self.axes], axis=1))) if len(lo) else 0.0

    def estimate(self, pending: int) -> tuple[float | None, float]:
        """Expected evaluations of the ``pending`` boxes (None: no estimate) and the mean
        ``q`` of the last depths."""
        rows = sorted(self.depths.items())[-self.DEPTHS :]
        if not rows:
            return None, 1.0
        k = np.array([d for d, _ in rows], dtype=float)
        e = np.array([r[0] for _, r in rows], dtype=float)
        u = np.array([r[1] for _, r in rows], dtype=float)
        q = float(u.sum() / e.sum())
        if q < 0.5:
            return pending / (1 - 2 * q), q
        if len(rows) < 3:
            return None, q
        kbar = float(np.average(k, weights=e))
        slope = float(np.sum(e * (k - kbar) * (u / e - q)) / np.sum(e * (k - kbar) ** 2))
        if not slope < 0:
            return None, q
        need, n, depth = 0.0, float(pending), k[-1] + 1
        while n >= 1 and need < 1e12:
            need += n
            n *= 2 * min(1.0, max(0.0, q + slope * (depth - kbar)))
            depth += 1
        return (need, q) if need < 1e12 else (None, q)

    def reach(self, lo: np.ndarray, hi: np.ndarray, queue_lo: list[np.ndarray],
              queue_hi: list[np.ndarray], boxes: int, timed: bool = False) -> dict[str, Any]:  # fmt: skip
        """Message and meta of a search stopped with ``lo, hi`` undecided (not yet split) and
        the queue pending, after ``boxes`` evaluations (``timed``: by the time limit, else by
        the box budget)."""
        from roa.shares import share

        left = self.volume(lo, hi) + sum(
            self.volume(a, b) for a, b in zip(queue_lo, queue_hi, strict=True)
        )
        finite = 0 < self.total < math.inf and math.isfinite(left)
        decided = max(0.0, 1.0 - left / self.total) if finite else None
        pending = 2 * len(lo) + sum(len(a) for a in queue_lo)
        more, q = self.estimate(pending)
        meta: dict[str, Any] = {"volume_decided": decided, "undecided_per_box": q}
        text = (f"{share(decided)} of the cover's volume decided" if decided is not None else
                "the share of the cover's volume decided is not representable (the cover "
                "overflows double precision)")  # fmt: skip
        if more is not None:
            meta["boxes_estimate"] = int(math.ceil(boxes + more))
            need = 2 * (boxes + more)
            what = (f"~{int(_round_up(need))} boxes in all would likely finish it (raise "
                    "--time-limit)" if timed else
                    f"--max-boxes ~{int(_round_up(need))} would likely suffice")  # fmt: skip
            text += (f"; {what} (extrapolated from the share of boxes left undecided at the "
                     f"deepest levels, {q:.3g})")  # fmt: skip
        else:
            text += (f"; no estimate of the boxes needed: at the deepest levels {q:.3g} of the "
                     "boxes stay undecided, not falling; try a smaller level, another V "
                     "(--lyapunov, --degree) or --validator sos")  # fmt: skip
        meta["message"] = text
        return meta


def _round_up(x: float) -> float:
    """``x`` rounded up to two significant digits."""
    if x <= 0:
        return 0.0
    e = 10 ** (math.floor(math.log10(x)) - 1)
    return math.ceil(x / e) * e


#: Pieces of the parameter box at most for the local proof near the equilibrium.
LOCAL_PIECES = 64


def _local_over(
    system: System, lyap: Lyapunov, lo0: np.ndarray, hi0: np.ndarray, plo: np.ndarray,
    phi: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]] | None:  # fmt: skip
    """A box around the equilibrium on which ``V' < 0`` (minus the equilibrium) is proved for
    every parameter of ``[plo, phi]``: :func:`local_box` on pieces of the parameter box (the
    whole box first, then halves along the relatively widest parameter, at most
    :data:`LOCAL_PIECES`), each piece's parameters entering as its intervals; the intersection of
    the pieces' boxes (each holds the equilibrium) is proved for every piece, so for the box."""
    from roa.model._parameters import parameter_values
    from roa.proof._local import hessian_preconditions

    exact = hessian_preconditions(system, lyap)  # f(x_eq, p) = 0 in the parameter symbols
    width = np.where(phi > plo, phi - plo, 1.0)
    queue, boxes = [(plo, phi)], []
    while queue:
        a, b = queue.pop(0)
        with parameter_values([Interval(x, y) for x, y in zip(a, b, strict=True)]):
            found = local_box(system, lyap, lo0, hi0, exact=exact)
        if found is not None:
            boxes.append(found)
            continue
        if len(boxes) + len(queue) + 2 > LOCAL_PIECES:
            return None
        j = int(np.argmax((b - a) / width))
        m = 0.5 * a[j] + 0.5 * b[j]
        b1, a2 = b.copy(), a.copy()
        b1[j], a2[j] = m, m
        queue += [(a, b1), (a2, b)]
    lo = np.max([f[0] for f in boxes], axis=0)
    hi = np.min([f[1] for f in boxes], axis=0)
    kinds = sorted({str(f[2].get("local_proof")) for f in boxes})
    return lo, hi, {"local_proof": "+".join(kinds), "local_parameter_pieces": len(boxes)}


def _in_x(res: Validation, system: System, lyap: Lyapunov, W: Whitened) -> Validation:
    """A whitened validation reported in the system's coordinates (witnesses mapped and
    re-checked in ``x``; where the float ``x`` fails, the exact point ``x_eq + M y`` is the
    witness and the check in ``y`` is kept)."""
    meta = {**res.meta, "coordinates": "whitened: boxes in y, x = x_eq + M y", "M": W.M.tolist()}
    if "domain_witness" in meta:
        wy = list(meta["domain_witness"])
        wx = W.to_x(np.asarray(wy, dtype=float))
        check = recheck_domain_witness(system, lyap, wx, res.level)
        if not check["confirmed"]:
            check = {**check, "confirmed_in_y": meta["domain_check"], "y": wy}
        meta.update(domain_witness=[float(v) for v in wx], domain_check=check)
    if res.witness is None:
        return dataclasses.replace(res, meta=meta)
    wx = W.to_x(np.asarray(res.witness, dtype=float))
    check = recheck_witness(system, lyap, wx, res.level)
    if not check["confirmed"]:
        check = {**check, "confirmed_in_y": res.witness_check, "y": list(res.witness)}
    return dataclasses.replace(res, witness=[float(v) for v in wx], witness_check=check, meta=meta)
