"""Vectorised numpy version of the batch DP5(4) integrator (any system, through ``system.f``).

Same semantics as the numba kernel of :mod:`roa.montecarlo.integrator`: per-row step sizes,
scipy's RK45 step control, events located by bisection on the dense output. Rows are dropped from
the active set as soon as they stop.
"""

from __future__ import annotations

import numpy as np

from roa.montecarlo import budget
from roa.montecarlo import dopri as I  # noqa: N812
from roa.montecarlo.terminal import ENTERED, BoundTerminal
from roa.status import StopRules
from roa.system import System


def _rms(v: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(v * v, axis=-1))


def _events(system: System, x: np.ndarray, rules: StopRules, margin_tol: float) -> np.ndarray:
    g = np.empty(x.shape[:-1] + (3,))
    with np.errstate(all="ignore"):
        g[..., 0] = np.linalg.norm(x - system.x_eq, axis=-1) - rules.converge_tol
        if system.margin is None:
            g[..., 1] = np.inf
        else:
            g[..., 1] = system.margin([x[..., i] for i in range(system.n)], _np()) - margin_tol
        g[..., 2] = rules.diverge_bound - np.linalg.norm(x, axis=-1)
    return g


def _np():
    from roa.backend import NP

    return NP


def integrate_numpy(
    system: System,
    x0: np.ndarray,
    *,
    rules: StopRules,
    rtol: float,
    atol: float,
    margin_tol: float,
    terminal: BoundTerminal | None = None,
    deadline: float | None = None,
) -> I.BatchResult:
    """See :func:`roa.montecarlo.integrator.integrate_batch` (``backend="numpy"``).

    Runs that enter ``terminal`` get the internal code :data:`roa.montecarlo.terminal.ENTERED`.
    Past ``deadline`` (absolute wall-clock time) the next field evaluation raises
    :class:`roa.montecarlo.budget.BudgetExhausted`.
    """
    m, n = x0.shape
    code = np.full(m, -1, np.int8)
    t_end = np.zeros(m)
    x_end = x0.copy()
    steps = np.zeros(m, np.int64)
    g0 = _events(system, x0, rules, margin_tol)
    finite = np.isfinite(x0).all(axis=1)
    code[~finite] = I.DIVERGED
    for e, c in ((0, I.CONVERGED), (1, I.LEFT_DOMAIN), (2, I.DIVERGED)):
        code[(code < 0) & (g0[:, e] <= 0)] = c
    if terminal is not None:
        free = np.flatnonzero(code < 0)
        code[free[terminal.inside(x0[free])]] = ENTERED
    idx = np.flatnonzero(code < 0)
    if idx.size == 0:
        return I.BatchResult(code, t_end, x_end, steps)

    def f(t: np.ndarray, y: np.ndarray) -> np.ndarray:
        budget.check(deadline)
        with np.errstate(all="ignore"):
            return system.f(y, t)

    y = x0[idx].copy()
    t = np.zeros(idx.size)
    g_old = g0[idx]
    K0 = f(t, y)
    # scipy's select_initial_step, row by row
    scale = atol + np.abs(y) * rtol
    d0, d1 = _rms(y / scale), _rms(K0 / scale)
    h0 = np.where((d0 < 1e-5) | (d1 < 1e-5), 1e-6, 0.01 * d0 / np.where(d1 > 0, d1, 1.0))
    h0 = np.minimum(h0, rules.t_final)
    f1 = f(t + h0, y + h0[:, None] * K0)
    d2 = _rms((f1 - K0) / scale) / h0
    with np.errstate(divide="ignore"):
        h1 = np.where(
            (d1 <= 1e-15) & (d2 <= 1e-15),
            np.maximum(1e-6, h0 * 1e-3),
            (0.01 / np.maximum(d1, d2)) ** 0.2,
        )
    h_abs = np.minimum(np.minimum(100 * h0, h1), rules.t_final)
    fresh = np.ones(idx.size, bool)
    rejected = np.zeros(idx.size, bool)
    nsteps = np.zeros(idx.size, np.int64)
    ntiny = np.zeros(idx.size, np.int64)
    tiny_step = I.TINY_STEP_FRACTION * rules.t_final

    def finish(sel: np.ndarray, c: np.ndarray | int, tt: np.ndarray, xx: np.ndarray) -> None:
        rows = idx[sel]
        code[rows], t_end[rows], x_end[rows], steps[rows] = c, tt, xx, nsteps[sel]

    while idx.size:
        min_step = 10 * np.abs(np.nextafter(t, np.inf) - t)
        h_abs = np.where(fresh & (h_abs < min_step), min_step, h_abs)
        fail = ~(h_abs >= min_step)  # NaN (a field not finite here) fails too: never loops
        fail |= (nsteps >= I.MAX_STEPS) | (ntiny >= I.MAX_TINY_STEPS)  # the step budget
        if fail.any():
            finish(fail, I.STEP_FAILURE, t[fail], y[fail])
        t_new = np.minimum(t + h_abs, rules.t_final)
        h = t_new - t
        h_abs = np.abs(h)
        K = np.empty((7,) + y.shape)
        K[0] = K0
        for s in range(1, 6):
            dy = np.tensordot(I.TABLEAU_A[s, :s], K[:s], axes=(0, 0))
            K[s] = f(t + I.TABLEAU_C[s] * h, y + h[:, None] * dy)
        y_new = y + h[:, None] * np.tensordot(I.TABLEAU_B, K[:6], axes=(0, 0))
        K[6] = f(t + h, y_new)
        with np.errstate(all="ignore"):
            err = h[:, None] * np.tensordot(I.ERROR_E, K, axes=(0, 0))
            en = _rms(err / (atol + np.maximum(np.abs(y), np.abs(y_new)) * rtol))
            acc = (en < 1) & ~fail
            grow = np.where(en == 0, I.MAX_FACTOR, np.minimum(I.MAX_FACTOR, I.SAFETY * en**-0.2))
            grow = np.where(rejected, np.minimum(1.0, grow), grow)
            shrink = np.where(I.SAFETY * en**-0.2 > I.MIN_FACTOR, I.SAFETY * en**-0.2, I.MIN_FACTOR)
        h_abs = np.where(acc, h_abs * grow, h_abs * shrink)
        rejected = np.where(acc, False, True)
        fresh = acc.copy()
        nsteps += acc
        ntiny += acc & (h < tiny_step)
        g_new = _events(system, y_new, rules, margin_tol)
        trig = acc[:, None] & (g_old >= 0) & (g_new <= 0)
        ev_rows = np.flatnonzero(trig.any(axis=1))
        done = fail.copy()
        if ev_rows.size:
            Q = np.einsum("kri,kj->rij", K[:, ev_rows], I.DENSE_P)  # (r, n, 4)
            yy, hh = y[ev_rows], h[ev_rows]
            best_t = np.full(ev_rows.size, np.inf)
            best_e = np.full(ev_rows.size, -1)
            best_x = np.empty((ev_rows.size, n))
            for e in range(3):
                sel = trig[ev_rows, e]
                if not sel.any():
                    continue
                lo, hi = np.zeros(sel.sum()), np.ones(sel.sum())
                ys, hs, Qs = yy[sel], hh[sel], Q[sel]

                def dense(s: np.ndarray, ys=ys, hs=hs, Qs=Qs) -> np.ndarray:
                    pw = s[:, None] ** np.arange(1, 5)
                    return ys + hs[:, None] * np.einsum("rij,rj->ri", Qs, pw)

                for _ in range(64):
                    mid = 0.5 * (lo + hi)
                    gm = _events(system, dense(mid), rules, margin_tol)[:, e]
                    lo, hi = np.where(gm > 0, mid, lo), np.where(gm > 0, hi, mid)
                te = t[ev_rows][sel] + hi * hs
                better = te < best_t[sel]
                pos = np.flatnonzero(sel)[better]
                best_t[pos], best_e[pos], best_x[pos] = te[better], e, dense(hi)[better]
            mask = np.zeros(idx.size, bool)
            mask[ev_rows] = True
            rows = idx[ev_rows]
            code[rows], t_end[rows], x_end[rows] = best_e, best_t, best_x
            steps[rows] = nsteps[ev_rows]
            done |= mask
        adv = acc & ~done
        t = np.where(adv, t_new, t)
        y = np.where(adv[:, None], y_new, y)
        K0 = np.where(adv[:, None], K[6], K0)
        g_old = np.where(adv[:, None], g_new, g_old)
        if terminal is not None:
            cand = np.flatnonzero(adv)
            ent = np.zeros(idx.size, bool)
            ent[cand[terminal.inside(y[cand])]] = True
            if ent.any():
                finish(ent, ENTERED, t[ent], y[ent])
                done |= ent
                adv &= ~ent
        end = adv & (t >= rules.t_final)
        if end.any():
            finish(end, I.UNDECIDED, t[end], y[end])
            done |= end
        keep = ~done
        idx, y, t, K0, g_old = idx[keep], y[keep], t[keep], K0[keep], g_old[keep]
        h_abs, fresh, rejected, nsteps = h_abs[keep], fresh[keep], rejected[keep], nsteps[keep]
        ntiny = ntiny[keep]
    return I.BatchResult(code, t_end, x_end, steps)
