"""Vectorised numpy version of the batch DP5(4) integrator (any system, through ``system.f``).

Same semantics as the numba kernel of :mod:`roa.integration._integrator`: per-row step sizes,
scipy's RK45 step control, events located by bisection on the dense output. Rows are dropped from
the active set as soon as they stop. The step, the initial step, the control and the dense output
are those of :mod:`roa.integration._dopri` (written once; here with one element, the ``(m, n)``
block of the active rows, per-row quantities ``(m, 1)`` columns): each row takes the operations of
the numba kernel in its order.
"""

from __future__ import annotations

import numpy as np

from roa.integration import (
    _budget as budget,
    _dopri as I,  # noqa: N812
)
from roa.integration._terminal import ENTERED, BoundTerminal
from roa.model._system import System
from roa.status import StopRules


def _rms_block(v: np.ndarray) -> np.ndarray:
    # dopri's norm on one element: per row of the (1, m, n) block, an (m, 1) column
    return np.sqrt(np.mean(v[0] * v[0], axis=-1, keepdims=True))


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
    from roa.model._backend import NP

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
    """See :func:`roa.integration._integrator.integrate_batch` (``backend="numpy"``).

    Runs that enter ``terminal`` get the internal code :data:`roa.integration._terminal.ENTERED`.
    Past ``deadline`` (absolute wall-clock time) the next field evaluation raises
    :class:`roa.integration._budget.BudgetExhausted`.
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

    def field(tc: np.ndarray, x: np.ndarray, _: None, out: np.ndarray) -> None:
        # dopri's field protocol on one element: t a column, x and out (1, m, n) blocks
        out[0] = f(tc[:, 0], x[0])

    y = x0[idx].copy()
    t = np.zeros(idx.size)
    g_old = g0[idx]
    K0 = f(t, y)
    with np.errstate(all="ignore"):
        h_abs = I.initial_step(field, None, t[:, None], y[None], K0[None], np.empty((1,) + y.shape),
                               np.empty((1,) + y.shape), 1, rtol, atol, rules.t_final,
                               _rms_block)[:, 0]  # fmt: skip
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
        K = np.empty((7, 1) + y.shape)
        K[0, 0] = K0
        y_new, work, err = (np.empty((1,) + y.shape) for _ in range(3))
        hc = h[:, None]
        I.stages(field, None, t[:, None], y[None], hc, K, work, y_new, 1)
        K[6, 0] = f(t + h, y_new[0])
        with np.errstate(all="ignore"):
            I.error(hc, K, y[None], y_new, err, 1, rtol, atol)
            accepted, h_next = I.control(_rms_block(err)[:, 0], h_abs, rejected)
        acc = accepted & ~fail
        h_abs = h_next
        rejected = ~acc
        fresh = acc.copy()
        y_new = y_new[0]
        nsteps += acc
        ntiny += acc & (h < tiny_step)
        g_new = _events(system, y_new, rules, margin_tol)
        trig = acc[:, None] & (g_old >= 0) & (g_new <= 0)
        ev_rows = np.flatnonzero(trig.any(axis=1))
        done = fail.copy()
        if ev_rows.size:
            Q = np.empty((1, 4, ev_rows.size, n))
            I.dense_coefficients(K[:, :, ev_rows], Q, 1)
            yy, hh = y[ev_rows], h[ev_rows]
            best_t = np.full(ev_rows.size, np.inf)
            best_e = np.full(ev_rows.size, -1)
            best_x = np.empty((ev_rows.size, n))
            for e in range(3):
                sel = trig[ev_rows, e]
                if not sel.any():
                    continue
                lo, hi = np.zeros(sel.sum()), np.ones(sel.sum())
                ys, hs, Qs = yy[sel][None], hh[sel][:, None], Q[:, :, sel]
                at = np.empty_like(ys)
                for _ in range(64):
                    mid = 0.5 * (lo + hi)
                    I.dense(ys, hs, Qs, mid[:, None], at, 1)
                    gm = _events(system, at[0], rules, margin_tol)[:, e]
                    lo, hi = np.where(gm > 0, mid, lo), np.where(gm > 0, hi, mid)
                te = t[ev_rows][sel] + hi * hs[:, 0]
                better = te < best_t[sel]
                pos = np.flatnonzero(sel)[better]
                I.dense(ys, hs, Qs, hi[:, None], at, 1)
                best_t[pos], best_e[pos], best_x[pos] = te[better], e, at[0][better]
            mask = np.zeros(idx.size, bool)
            mask[ev_rows] = True
            rows = idx[ev_rows]
            code[rows], t_end[rows], x_end[rows] = best_e, best_t, best_x
            steps[rows] = nsteps[ev_rows]
            done |= mask
        adv = acc & ~done
        t = np.where(adv, t_new, t)
        y = np.where(adv[:, None], y_new, y)
        K0 = np.where(adv[:, None], K[6, 0], K0)
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
