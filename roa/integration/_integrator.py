"""Batch adaptive Dormand-Prince 5(4) integration of many initial conditions, each with its own events.

Every trajectory has its own step size and stops at its own first event, with the semantics of
:func:`roa.integration.simulate` / scipy's ``solve_ivp(method="RK45")``:

* ``converged``: ``||x - x_eq|| - converge_tol`` goes from >= 0 to <= 0;
* ``left_domain``: the system's ``margin(x) - margin_tol`` goes from >= 0 to <= 0 (``margin_tol`` is 0
  by default: the domain boundary itself);
* ``diverged``: ``diverge_bound - ||x||`` goes from >= 0 to <= 0 (non-finite stage values make the
  step be rejected and shrunk, as in scipy);
* ``undecided``: none of the above by ``t_final`` (code :data:`UNDECIDED`), or the step size fell
  below scipy's minimum, or the run used up its step budget (:data:`MAX_STEPS` steps, or
  :data:`MAX_TINY_STEPS` steps shorter than ``TINY_STEP_FRACTION * t_final``) (code
  :data:`STEP_FAILURE`, counted as undecided but reported apart: no run does unbounded work);
  after the batch, undecided runs sitting at another equilibrium are ``converged_elsewhere`` and
  those blowing up (:func:`roa.integration._divergence.blows_up`, confirmed by the reference integrator)
  ``diverged``.

When several events trigger in one step, each root is located on the step's dense output (bisection
to machine precision) and the earliest wins, as in ``solve_ivp``. Step-size control, the initial step
and the error norm follow scipy's ``RK45`` exactly, so classifications agree with it.

Two back ends with identical semantics: a numba kernel (one trajectory at a time, compiled scalar
code) used when ``system.numba`` is a callable returning ``(field, margin, params)`` --
``field(t, x, params, out)`` and ``margin(x, params) -> float``, both ``numba.cfunc`` compiled with
:data:`FIELD_SIGNATURE` / :data:`MARGIN_SIGNATURE` (function pointers keep one kernel cacheable on
disk for every system; see ipc_paper/system/fast.py); otherwise a vectorised numpy version over
``system.f``. A system with neither gets a fast path generated from its field
(:mod:`roa.integration._kernel_cache`: traced with sympy, compiled with :func:`batch_kernel`, cached
on disk), for runs of ``kernel_cache.COMPILE_FROM`` rows or more. Built-in systems add a fast path,
``system.numba_fast``: the same functions as ``numba.njit`` functions, compiled into a kernel of
their own (:func:`compile_kernel`: no call through a pointer, the field fused with the map to a
terminal set's coordinates), bit for bit the same trajectories. Throughputs:
benchmarks/bench_montecarlo.py and benchmarks/bench_peers.py; against another checkout:
benchmarks/bench_dopri_kernels.py.

The Dormand-Prince step, initial step, step-size control and dense output are
:mod:`roa.integration._dopri`'s, written once for both back ends; every numba entry point (the
public kernel, :func:`compile_kernel`, the generated modules) runs :data:`run_rows` (or
:func:`batch_kernel`), into which numba inlines them.
"""

from __future__ import annotations

import functools
import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numba
import numpy as np
from numba.core.imputils import lower_constant
from numba.extending import models, overload, register_model, typeof_impl

from roa.errors import RoaInputError
from roa.integration import _budget as budget, _dopri as _base
from roa.integration._code_identity import source_digest as _source_digest, sources_digest
from roa.integration._dopri import (  # noqa: F401  (re-exported: codes and tableau)
    CODE_STATUS,
    CONVERGED,
    CONVERGED_ELSEWHERE,
    DENSE_P,
    DIVERGED,
    EPS,
    ERROR_E,
    KERNEL_DEPS,
    LEFT_DOMAIN,
    MAX_FACTOR,
    MAX_STEPS,
    MAX_TINY_STEPS,
    MIN_FACTOR,
    SAFETY,
    STATUS_NAMES,
    STEP_FAILURE,
    TABLEAU_A,
    TABLEAU_B,
    TABLEAU_C,
    TINY_STEP_FRACTION,
    UNDECIDED,
    check_tolerances,
)
from roa.integration._equilibria import settled_elsewhere
from roa.integration._integrator_numpy import integrate_numpy
from roa.integration._lazy_cfunc import LazyCfuncs
from roa.integration._terminal import ENTERED, REASON, TerminalSet, kernel_terminal  # noqa: F401
from roa.integration._terminal_poly import member_numba
from roa.model._system import System
from roa.status import StopRules

_ARR = numba.types.float64[::1]
#: Signature of a compiled field ``field(t, x, params, out)`` (``numba.cfunc``).
FIELD_SIGNATURE = numba.types.void(numba.types.float64, _ARR, _ARR, _ARR)
#: Signature of a compiled margin ``margin(x, params) -> float`` (``numba.cfunc``).
MARGIN_SIGNATURE = numba.types.float64(_ARR, _ARR)
#: Signature of a compiled coordinate map ``coords(x, params, out)`` (simulated -> analysis
#: coordinates of a terminal set; inf outside the map's domain).
COORDS_SIGNATURE = numba.types.void(_ARR, _ARR, _ARR)


def integrate_batch(
    system: System,
    x0: np.ndarray,
    *,
    rules: StopRules | None = None,
    rtol: float = 1e-6,
    atol: float = 1e-9,
    margin_tol: float = 0.0,
    backend: str = "auto",
    terminal: TerminalSet | None = None,
    deadline: float | None = None,
) -> BatchResult:
    """Integrate ``system`` from every row of ``x0`` (shape ``(m, n)``) until its own event.

    A discrete-time system's map is iterated instead (:func:`roa.integration._iterate.iterate_map`:
    ``t_final`` in units of its ``sample_time``; tolerances and backend unused).

    Parameters
    ----------
    system : System
        Autonomous system with an equilibrium.
    x0 : array of shape (m, n)
        Initial states (any finite values; rows outside the domain are ``left_domain`` at t = 0).
    rules : StopRules, optional
        ``t_final``, ``converge_tol``, ``diverge_bound``.
    rtol, atol : float
        Error tolerances of the DP5(4) pair (scipy's definitions).
    margin_tol : float
        The domain is left when ``margin(x) <= margin_tol`` (default 0: the boundary itself).
    backend : {"auto", "numba", "numpy"}
        ``auto`` uses the system's numba kernel (``system.numba`` / ``numba_fast``) when it has
        one, else for 2000 rows or more (``kernel_cache.COMPILE_FROM``) a kernel generated from its
        field (:mod:`roa.integration._kernel_cache`), else numpy (for a field that cannot be
        compiled with a :class:`~roa.integration._kernel_cache.KernelFallbackWarning` saying why);
        ``numba`` refuses the fallback (:class:`roa.RoaInputError`).
    terminal : TerminalSet, optional
        A certified set: runs entering it stop as ``converged`` (``entered`` marks them; see
        :mod:`roa.integration._terminal`).
    deadline : float, optional
        Absolute wall-clock deadline (:mod:`roa.integration._budget`): past it the batch stops with
        :class:`roa.integration._budget.BudgetExhausted` and returns nothing (checked between slices
        of ``budget.SLICE`` rows on the numba kernel, at every field evaluation with numpy).
    """
    rules = StopRules() if rules is None else rules
    check_tolerances(rtol, atol, margin_tol)
    if system.time_varying or system.equilibrium is None:
        raise RoaInputError(
            f"system {system.name!r}: basin runs need an autonomous system with an equilibrium"
        )
    x0 = np.ascontiguousarray(np.asarray(x0, dtype=float))
    if x0.ndim != 2 or x0.shape[1] != system.n:
        raise RoaInputError(f"x0 must have shape (m, {system.n}); got {x0.shape}")
    if backend not in ("auto", "numba", "numpy"):
        raise RoaInputError(f"backend must be auto, numba or numpy; got {backend!r}")
    bound = None if terminal is None else terminal.bind(system)
    if system.time == "discrete":  # a map: iterated, nothing to integrate
        from roa.integration._iterate import iterate_map

        res = iterate_map(system, x0, rules=rules, margin_tol=margin_tol, terminal=bound,
                          deadline=deadline)  # fmt: skip
        entered = res.code == ENTERED
        res.code[entered] = CONVERGED
        return _elsewhere(system, BatchResult(res.code, res.t_end, res.x_end, res.steps, entered),
                          rules.converge_tol)  # fmt: skip
    from roa.integration._kernel_cache import NUMPY, compiled_system

    system, ran, _ = compiled_system(system, backend, terminal, x0.shape[0])
    if ran != NUMPY:
        run, params = _numba_kernel(system, terminal)
        T = kernel_terminal(terminal, system.n)
        m = x0.shape[0]
        code = np.empty(m, np.int8)
        t_end = np.empty(m)
        x_end = np.empty_like(x0)
        steps = np.empty(m, np.int64)
        p = np.ascontiguousarray(params, dtype=float)
        step = m if deadline is None else budget.SLICE
        for a in range(0, m, max(step, 1)):  # contiguous row slices: the same runs bit for bit
            budget.check(deadline)
            b = min(a + step, m)
            run(p, x0[a:b], system.x_eq, rules.converge_tol, rules.diverge_bound, margin_tol,
                rules.t_final, rtol, atol, T, code[a:b], t_end[a:b], x_end[a:b], steps[a:b])  # fmt: skip
        res = _base.BatchResult(code, t_end, x_end, steps)
    else:
        res = integrate_numpy(system, x0, rules=rules, rtol=rtol, atol=atol, margin_tol=margin_tol,
                              terminal=bound, deadline=deadline)  # fmt: skip
    entered = res.code == ENTERED
    res.code[entered] = CONVERGED
    res = BatchResult(res.code, res.t_end, res.x_end, res.steps, entered)
    res = _elsewhere(system, res, rules.converge_tol)
    return _grown(system, x0, res, rules, rtol, atol)


def _numba_kernel(system: System, terminal: TerminalSet | None) -> tuple[Callable[..., None], Any]:
    """The numba kernel for ``system`` (and ``terminal``) and the parameters it takes.

    It is called ``run(params, X0, x_eq, converge_tol, diverge_bound, margin_tol, t_final, rtol,
    atol, T, code, t_end, x_end, steps)`` with ``T`` from :func:`kernel_terminal`. The fast path
    ``system.numba_fast`` (njit functions compiled into a kernel of their own,
    :func:`compile_kernel`) is used when the system provides it, with a terminal set in other
    coordinates when it has a map to them; else the public ``system.numba`` (cfuncs of
    ``FIELD_SIGNATURE``, ...) with the shared kernel. Both give the same trajectories bit for bit
    (tests/test_terminal_fastpath.py).
    """
    fast = system.numba_fast
    name = None if terminal is None else terminal.coords
    ready = getattr(fast, "kernel", None)  # a generated kernel (roa.integration._kernel_cache)
    if ready is not None and name is None:
        return ready()
    if fast is not None:
        try:
            # (field, margin, params), with coordinates (..., coords, field_coords)
            fns = fast() if name is None else fast(coords=name)
        except (TypeError, ValueError, KeyError):
            fns = None  # no map to these coordinates on the fast path: the public one
        if fns is not None:
            field, margin, params, *more = fns
            coords, field_coords = more if more else (None, None)
            return compile_kernel(field, margin, coords, field_coords), params
    factory = system.numba
    if name is None:
        field, margin, params = factory()
        coords = __getattr__("identity_coords")
    else:
        try:
            field, margin, params, coords = factory(coords=name)
        except (TypeError, ValueError, KeyError):
            raise RoaInputError(
                f"system {system.name!r}: its numba kernels have no compiled map to the "
                f"coordinates {name!r} of the terminal set (use backend='numpy')"
            ) from None

    kernel = _public_kernel()

    def run(params: Any, X0: Any, x_eq: Any, tol: float, bound: float, margin_tol: float,
            t_final: float, rtol: float, atol: float, T: Any, code: Any, t_end: Any, x_end: Any,
            steps: Any) -> None:  # fmt: skip
        kernel(field, margin, params, X0, x_eq, tol, bound, margin_tol, t_final, rtol, atol, T,
               coords, code, t_end, x_end, steps)  # fmt: skip

    return run, params


@functools.cache
def _public_kernel() -> Callable[..., None]:
    """The kernel of the public protocol (cfuncs as first-class function values), compiled once
    and cached on disk, its key holding :data:`KERNEL_STAMP`."""
    stamp = KERNEL_STAMP

    @numba.njit(cache=True, error_model="numpy")
    def kernel(field, margin, params, X0, x_eq, tol, bound, margin_tol, t_final, rtol, atol, T,
               coords, code, t_end, x_end, steps):  # fmt: skip
        if stamp < 0:  # never: the stamp is here for the cache key
            return
        run_rows(field, margin, params, X0, x_eq, tol, bound, margin_tol, t_final, rtol, atol,
                 T, coords, code, t_end, x_end, steps, None)  # fmt: skip

    return kernel


@dataclass(frozen=True)
class BatchResult(_base.BatchResult):
    """:class:`roa.integration._dopri.BatchResult` plus ``entered``: the converged runs that entered
    the terminal set (their ``t_end`` is the entry time, their reason :data:`REASON`)."""

    entered: np.ndarray | None = None

    def reasons(self) -> list[str]:
        """Per run: :data:`REASON` for runs finished by the terminal set, else the status name."""
        ent = np.zeros(self.code.size, bool) if self.entered is None else self.entered
        return [
            REASON if e else CODE_STATUS[int(c)].value for c, e in zip(self.code, ent, strict=True)
        ]


def _elsewhere(system: System, res: BatchResult, converge_tol: float) -> BatchResult:
    """Undecided runs that sat at another equilibrium by t_final become CONVERGED_ELSEWHERE."""
    undecided = np.flatnonzero(res.code == UNDECIDED)
    if undecided.size:
        mask, _ = settled_elsewhere(system, res.x_end[undecided], converge_tol)
        res.code[undecided[mask]] = CONVERGED_ELSEWHERE
    return res


def _grown(system: System, x0: np.ndarray, res: BatchResult, rules: StopRules, rtol: float,
           atol: float) -> BatchResult:  # fmt: skip
    """Undecided runs blowing up at t_final become DIVERGED (:func:`roa.integration._divergence.blows_up`).

    The batch keeps no history, so runs ending far out (``||x_end - x_eq|| >= diverge_bound /
    diverge_growth``, the rule's first condition) are run again by the reference integrator
    (scipy's RK45 at the batch's tolerances), which applies the whole rule; only its
    ``diverged`` verdict changes the code. Runs ending nearer stay as they are, uninspected."""
    if rules.diverge_growth is None:
        return res
    undecided = np.flatnonzero(res.code == UNDECIDED)
    if not undecided.size:
        return res
    with np.errstate(all="ignore"):
        far = np.linalg.norm(res.x_end[undecided] - system.x_eq, axis=1)
    from roa.integration._simulation import _integrate
    from roa.status import RunStatus

    ivp = {"rtol": rtol, "atol": atol, "method": "RK45", "t_eval": None, "max_step": np.inf}
    for i in undecided[far >= rules.diverge_bound / rules.diverge_growth]:
        if _integrate(system, x0[i], rules, ivp).status is RunStatus.DIVERGED:
            res.code[i] = DIVERGED
    return res


# ----------------------------------------------------------------------------- numba kernel
# One kernel, two ways to take the system's functions. The public protocol passes cfuncs as
# first-class function values: one compiled kernel, cached on disk, serves every system, and
# each call goes through a pointer. The fast path (compile_kernel) passes njit functions as
# compile-time constants (Inlined): the kernel is compiled for them, LLVM inlines them, and the
# result is cached on disk too, keyed by the source of the functions' modules.


class Inlined:
    """A ``numba.njit`` function handed to the kernel as a compile-time constant (see
    :func:`compile_kernel`): the kernel calls it directly (LLVM inlines it), where a cfunc is
    called through its pointer. It pickles by name with the SHA-256 of its module's source, so a
    kernel cached on disk is recompiled when that source changes; only that module is hashed, so
    an inlined function must not call numba code of other modules."""

    def __init__(self, fn: Any) -> None:
        self.fn = fn
        py = fn.py_func
        self.key = (py.__module__, py.__qualname__, _source_digest(py.__code__.co_filename))

    def __reduce__(self) -> tuple[Any, tuple[str, str, str]]:
        return (_inlined_by_name, self.key)


#: The SHA-256 of the sources of :data:`roa.integration._dopri.KERNEL_DEPS` (dopri.py, terminal.py,
#: terminal_poly.py: the modules whose numba code or constants the kernels compile in; first 60
#: bits of the digests' digest). numba keys a cached function by the source of the file defining
#: it only (changes in other files are not seen: its documented caching limitation), so the
#: kernels' entry points (:func:`compile_kernel`, ``_public_kernel``) are closures over
#: KERNEL_STAMP, whose value numba hashes into their cache key, and the functions they call that
#: reach into these modules (``_member``, ``_inside``, ``_one``, ``run_rows`` and the step of
#: dopri.py), or take an inlined function of the fast path (``_events``: its cache key would name
#: the function by its address only), are not cached on their own.
KERNEL_STAMP = int(sources_digest(Path(__file__).parent, KERNEL_DEPS)[:15], 16)


def _inlined_by_name(module: str, qualname: str, digest: str) -> Inlined:
    obj: Any = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return Inlined(obj)


class _InlinedType(numba.types.Dispatcher):
    """The numba type of an :class:`Inlined`: called as its njit function, lowered as no value."""


@typeof_impl.register(Inlined)
def _typeof_inlined(val: Inlined, c: Any) -> _InlinedType:
    return _InlinedType(val.fn)


register_model(_InlinedType)(models.OpaqueModel)


@lower_constant(_InlinedType)
def _lower_inlined(context: Any, builder: Any, ty: Any, pyval: Any) -> Any:
    return context.get_dummy_value()  # a type, no value: no address baked into the code


@numba.njit(cache=True, error_model="numpy")
def _rms(v: np.ndarray) -> float:
    s = 0.0
    for i in range(v.shape[0]):
        s += v[i] * v[i]
    return np.sqrt(s / v.shape[0])


@numba.njit(cache=True, error_model="numpy")
def _dist(x: np.ndarray, c: np.ndarray) -> float:
    s = 0.0
    for i in range(x.shape[0]):
        d = x[i] - c[i]
        s += d * d
    return np.sqrt(s)


@numba.njit(error_model="numpy")  # compiled into the entry points (margin inlined)
def _events(x, x_eq, tol, bound, margin, params, margin_tol, g):
    g[0] = _dist(x, x_eq) - tol
    g[1] = margin(x, params) - margin_tol
    s = 0.0
    for i in range(x.shape[0]):
        s += x[i] * x[i]
    g[2] = bound - np.sqrt(s)


@numba.njit(cache=True, error_model="numpy")
def _copy(src, dst):
    # dst[:] = src without slice assignment (whose shape-error path costs seconds to compile)
    for i in range(src.shape[0]):
        dst[i] = src[i]


@overload(_base.select)
def _select_scalar(c, a, b):
    # dopri.select on scalars (the numba kernels): a select, no array
    def impl(c, a, b):
        return a if c else b

    return impl


# The Dormand-Prince step of roa.integration._dopri, written once there, inlined here into _one
# (numba IR inlining: the same code as if written in _one).
_inline = numba.njit(inline="always", error_model="numpy")
_initial_step = _inline(_base.initial_step)
_stages = _inline(_base.stages)
_error = _inline(_base.error)
_control = _inline(_base.control)
_dense_coefficients = _inline(_base.dense_coefficients)
_dense = _inline(_base.dense)


@numba.njit(cache=True, error_model="numpy")
def _v_le(w, tP, tc, thr):
    # V(w) <= thr; NaN compares False (outside)
    n = w.shape[0]
    v = 0.0
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += tP[i, j] * (w[j] - tc[j])
        v += (w[i] - tc[i]) * acc
    return v <= thr


@numba.njit(error_model="numpy")  # compiled into the entry points
def _member(w, T, d, pw):
    # w (analysis coordinates) in the terminal set T (kernel_terminal): quadratic or polynomial
    if T[0] == 1:
        return _v_le(w, T[1], T[2], T[3])
    return member_numba(w, T[2], T[4], T[5], T[6], T[7], T[3], T[8], d, pw)


@numba.njit(error_model="numpy")  # compiled into the entry points
def _inside(y, coords, params, T, w, d, pw):
    # coords(y) in the terminal set
    coords(y, params, w)
    return _member(w, T, d, pw)


def _one_for(states: int) -> Any:
    """The one-run loop (a numba function, compiled into the entry points) for ``states``
    states, a compile-time constant (LLVM unrolls the loops over them), or any number (0)."""

    @numba.njit(error_model="numpy")
    def one(
        field, margin, params, y0, x_eq, tol, bound, margin_tol, t_final, rtol, atol,
        T, coords, x_out, field_coords,
    ):  # fmt: skip
        n = y0.shape[0] if states == 0 else states  # a constant for states > 0
        K = np.empty((7, n))
        y = np.empty(n)
        _copy(y0, y)
        y_new = np.empty(n)
        tmp = np.empty(n)
        err = np.empty(n)
        g_old = np.empty(3)
        g_new = np.empty(3)
        Q = np.empty((n, 4))
        _events(y, x_eq, tol, bound, margin, params, margin_tol, g_old)
        for i in range(n):
            if not np.isfinite(y[i]):
                _copy(y, x_out)
                return DIVERGED, 0.0, 0
        if g_old[0] <= 0.0:
            _copy(y, x_out)
            return CONVERGED, 0.0, 0
        if g_old[1] <= 0.0:
            _copy(y, x_out)
            return LEFT_DOMAIN, 0.0, 0
        if g_old[2] <= 0.0:
            _copy(y, x_out)
            return DIVERGED, 0.0, 0
        w = np.empty(n)
        term = T[0] != 0
        d = np.empty(n)
        pw = np.empty((n, T[9] + 1))
        if term and _inside(y, coords, params, T, w, d, pw):
            _copy(y, x_out)
            return ENTERED, 0.0, 0
        t = 0.0
        field(t, y, params, K[0])
        h_abs = _initial_step(field, params, t, y, K[0], K[1], tmp, n, rtol, atol, t_final, _rms)
        steps = 0
        tiny = 0
        tiny_step = TINY_STEP_FRACTION * t_final
        while True:
            if t >= t_final:
                _copy(y, x_out)
                return UNDECIDED, t, steps
            if steps >= MAX_STEPS or tiny >= MAX_TINY_STEPS:  # the run's step budget: undecided
                _copy(y, x_out)
                return STEP_FAILURE, t, steps
            min_step = 10 * abs(np.nextafter(t, np.inf) - t)
            if h_abs < min_step:
                h_abs = min_step
            step_rejected = False
            while True:
                if not (h_abs >= min_step):  # NaN (a field not finite here) fails too: never loops
                    _copy(y, x_out)
                    return STEP_FAILURE, t, steps
                h = h_abs
                t_new = t + h
                if t_new - t_final > 0:
                    t_new = t_final
                h = t_new - t
                h_abs = abs(h)
                _stages(field, params, t, y, h, K, tmp, y_new, n)
                if field_coords is None:  # pruned at compile time
                    field(t + h, y_new, params, K[6])
                else:  # the field and coords(y_new) in one call (w: for the set test below)
                    field_coords(t + h, y_new, params, K[6], w)
                _error(h, K, y, y_new, err, n, rtol, atol)
                accepted, h_abs = _control(_rms(err), h_abs, step_rejected)
                if accepted:
                    break
                step_rejected = True
            steps += 1
            if h < tiny_step:  # the step just taken
                tiny += 1
            _events(y_new, x_eq, tol, bound, margin, params, margin_tol, g_new)
            first = -1
            t_first = np.inf
            for e in range(3):
                if g_old[e] >= 0.0 and g_new[e] <= 0.0:
                    # root of event e on this step's dense output, by bisection
                    if first == -1:
                        _dense_coefficients(K, Q, n)
                    lo, hi = 0.0, 1.0
                    for _ in range(64):
                        mid = 0.5 * (lo + hi)
                        _dense(y, h, Q, mid, tmp, n)
                        if e == 0:
                            gm = _dist(tmp, x_eq) - tol
                        elif e == 1:
                            gm = margin(tmp, params) - margin_tol
                        else:
                            gm = bound - _rms(tmp) * np.sqrt(n)
                        if gm > 0.0:
                            lo = mid
                        else:
                            hi = mid
                        if (hi - lo) * h <= 4 * EPS * max(1.0, abs(t)):
                            break
                    te = t + hi * h
                    if te < t_first:
                        t_first = te
                        first = e
                        _dense(y, h, Q, hi, x_out, n)
            if first >= 0:
                return first, t_first, steps  # codes 0, 1, 2 match the event order
            if term:
                if field_coords is None:
                    inside = _inside(y_new, coords, params, T, w, d, pw)
                else:  # w holds coords(y_new) from the last stage
                    inside = _member(w, T, d, pw)
            else:
                inside = False
            if inside:
                _copy(y_new, x_out)
                return ENTERED, t_new, steps
            t = t_new
            for i in range(n):
                y[i] = y_new[i]
                K[0, i] = K[6, i]
            for e in range(3):
                g_old[e] = g_new[e]

    return one


_one = _one_for(0)


def _rows_for(one: Any) -> Any:
    # the batch: ``one`` from every row (inlined into every entry point)
    @_inline
    def rows(field, margin, params, X0, x_eq, tol, bound, margin_tol, t_final, rtol, atol, T,
             coords, code, t_end, x_end, steps, field_coords):  # fmt: skip
        for k in range(X0.shape[0]):
            code[k], t_end[k], steps[k] = one(field, margin, params, X0[k], x_eq, tol, bound,
                                              margin_tol, t_final, rtol, atol, T, coords,
                                              x_end[k], field_coords)  # fmt: skip

    return rows


#: The batch kernel of every entry point (the public one, :func:`compile_kernel`, the generated
#: modules of :mod:`roa.integration._codegen`): :func:`_one` from every row of ``X0``, called
#: ``run_rows(field, margin, params, X0, x_eq, tol, bound, margin_tol, t_final, rtol, atol, T,
#: coords, code, t_end, x_end, steps, field_coords)``.
run_rows = _rows_for(_one)


@functools.cache
def batch_kernel(states: int = 0) -> Any:
    """:data:`run_rows` for ``states`` states, a compile-time constant (LLVM unrolls the loops
    over them; 0: any number). The generated modules of :mod:`roa.integration._codegen` run
    ``batch_kernel(STATES)``: the same code, the same operations in the same order."""
    return run_rows if states == 0 else _rows_for(_one_for(states))


def _no_margin(x: np.ndarray, params: np.ndarray) -> float:
    """Margin of a system whose domain is the whole space (for numba fields)."""
    return np.inf


def _identity_coords(x: np.ndarray, params: np.ndarray, out: np.ndarray) -> None:
    """The identity coordinate map (a terminal set in the simulated coordinates)."""
    for i in range(x.shape[0]):
        out[i] = x[i]


#: The public cfuncs ``no_margin`` (:func:`_no_margin`, MARGIN_SIGNATURE) and ``identity_coords``
#: (:func:`_identity_coords`, COORDS_SIGNATURE), compiled on first access, not at import.
__getattr__ = LazyCfuncs(
    __name__,
    {
        "no_margin": (MARGIN_SIGNATURE, _no_margin),
        "identity_coords": (COORDS_SIGNATURE, _identity_coords),
    },
)


# ----------------------------------------------------------------------------- fast path
# njit functions for the fast path (system.numba_fast): the same arguments as the
# public signatures, compiled into the kernel by compile_kernel.


@numba.njit(cache=True, error_model="numpy")
def no_margin_njit(x: np.ndarray, params: np.ndarray) -> float:
    """:func:`no_margin` for the fast path."""
    return np.inf


@numba.njit(cache=True, error_model="numpy")
def identity_coords_njit(x: np.ndarray, params: np.ndarray, out: np.ndarray) -> None:
    """:func:`identity_coords` for the fast path."""
    for i in range(x.shape[0]):
        out[i] = x[i]


_COMPILED: dict[tuple[Any, ...], Any] = {}


def compile_kernel(
    field: Any, margin: Any, coords: Any = None, field_coords: Any = None
) -> Callable[..., None]:
    """The batch kernel compiled for these ``numba.njit`` functions (the fast path).

    ``field(t, x, params, out)``, ``margin(x, params) -> float`` and ``coords(x, params, out)``
    take the arguments of the public signatures (``FIELD_SIGNATURE``, ...); ``field_coords(t, x,
    params, out, w)`` (optional) writes ``field`` to ``out`` and ``coords(x)`` to ``w``, bit for
    bit what the two give, for the terminal-set test after the last stage of a step (the field's
    sin, cos and log are not computed twice). The kernel calls them directly: LLVM inlines them
    (no call through a pointer). Compiled once per process and cached on disk (the functions
    enter the cache key with the SHA-256 of their modules' source). Returns ``run(params, X0,
    x_eq, converge_tol, diverge_bound, margin_tol, t_final, rtol, atol, T, code, t_end, x_end,
    steps)`` (``T``: :func:`kernel_terminal`).
    """
    key = (field, margin, coords, field_coords)
    if key in _COMPILED:
        return _COMPILED[key]
    f, m = Inlined(field), Inlined(margin)
    c = Inlined(identity_coords_njit if coords is None else coords)
    fc = None if field_coords is None else Inlined(field_coords)
    stamp = KERNEL_STAMP

    @numba.njit(cache=True, error_model="numpy")
    def run(params, X0, x_eq, tol, bound, margin_tol, t_final, rtol, atol, T, code, t_end, x_end,
            steps):  # fmt: skip
        if stamp < 0:  # never: the stamp is here for the cache key
            return
        run_rows(f, m, params, X0, x_eq, tol, bound, margin_tol, t_final, rtol, atol, T, c,
                 code, t_end, x_end, steps, fc)  # fmt: skip

    _COMPILED[key] = run
    return run
