"""Dormand-Prince 5(4) written once: status codes, the tableau, the step, its control, results.

The step (:func:`stages`, :func:`error`), scipy's initial step (:func:`initial_step`), the
step-size control (:func:`control`) and the dense output (:func:`dense_coefficients`,
:func:`dense`) are plain Python functions over "elements" ``y[0], ..., y[n-1]``: each operation is
written once, in one order, and works on whatever an element is.

* The numba kernels (:mod:`roa.integration._integrator`) compile them with
  ``numba.njit(inline="always")`` into their one-run loop: an element is a state (a float),
  ``n`` the state dimension, and :func:`select` a scalar select (its numba implementation is
  registered there).
* The numpy batch (:mod:`roa.integration._integrator_numpy`) calls them as they are with one
  element, ``y[0]`` the ``(m, n)`` block of the active rows, per-row quantities (``t``, ``h``, the
  error norm) ``(m, 1)`` columns and :func:`select` ``numpy.where``.

Both perform on every state of every run the same floating-point operations in the same order
(sums accumulated from 0.0 in stage order; ``min``/``max`` as Python's, the first argument
unless the second compares smaller/larger), so given the same field values they give the same
steps bit for bit. The norm is the caller's (``rms``): a state dimension in numba, the last axis
of the block in numpy. Sources: scipy.integrate.RK45 (tableau, control, initial step).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.status import RunStatus

#: Status codes stored per initial condition (int8).
CONVERGED, LEFT_DOMAIN, DIVERGED, UNDECIDED, STEP_FAILURE = 0, 1, 2, 3, 4
#: An undecided run that sat at another equilibrium at t_final (set after integration).
CONVERGED_ELSEWHERE = 5
#: Code -> status; STEP_FAILURE is an undecided run whose step size underflowed or that used up
#: its step budget (:data:`MAX_STEPS`, :data:`MAX_TINY_STEPS`).
CODE_STATUS = {
    CONVERGED: RunStatus.CONVERGED,
    LEFT_DOMAIN: RunStatus.LEFT_DOMAIN,
    DIVERGED: RunStatus.DIVERGED,
    UNDECIDED: RunStatus.UNDECIDED,
    STEP_FAILURE: RunStatus.UNDECIDED,
    CONVERGED_ELSEWHERE: RunStatus.CONVERGED_ELSEWHERE,
}
#: Names by display index (0-3 as the codes, 4 for CONVERGED_ELSEWHERE; STEP_FAILURE shows as undecided).
STATUS_NAMES = ("converged", "left_domain", "diverged", "undecided", "converged_elsewhere")

# Dormand-Prince 5(4) tableau (as in scipy.integrate.RK45).
TABLEAU_C = np.array([0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1])
TABLEAU_A = np.array(
    [
        [0, 0, 0, 0, 0],
        [1 / 5, 0, 0, 0, 0],
        [3 / 40, 9 / 40, 0, 0, 0],
        [44 / 45, -56 / 15, 32 / 9, 0, 0],
        [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0],
        [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
    ]
)
TABLEAU_B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
ERROR_E = np.array([-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
DENSE_P = np.array(
    [
        [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
        [0, 0, 0, 0],
        [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
        [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
        [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
        [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
        [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
    ]
)
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
#: Most accepted steps of one run: a run that has not stopped after them ends as
#: :data:`STEP_FAILURE` (undecided) where it is, so no run costs more than this many steps.
MAX_STEPS = 100_000
#: A step shorter than ``TINY_STEP_FRACTION * t_final`` is tiny (scipy's own minimum,
#: ``10 |nextafter(t) - t|``, is subnormal near ``t = 0``: a field of scale 1e150 asks for steps
#: of 1e-150 and would never reach ``t_final``).
TINY_STEP_FRACTION = 1e-9
#: Most tiny steps of one run before it ends as :data:`STEP_FAILURE`. Not a floor on the step: a
#: blow-up near its escape time takes a few tiny steps (its state grows by a fixed factor per
#: step) and still reaches ``diverge_bound``; a run that would need ~``t_final / h`` of them
#: (a stiff field, a huge parameter) ends after these.
MAX_TINY_STEPS = 1000
EPS = np.finfo(float).eps
#: Modules (of this package) whose numba code or constants the numba kernels compile in: their
#: sources key the kernels' disk caches (:data:`roa.integration._integrator.KERNEL_STAMP`,
#: :func:`roa.integration._kernel_cache.kernel_stamp`).
KERNEL_DEPS = ("_dopri.py", "_terminal.py", "_terminal_poly.py")


@dataclass(frozen=True)
class BatchResult:
    """Per-trajectory outcome: ``code`` (int8, see module constants), ``t_end``, ``x_end``, ``steps``."""

    code: np.ndarray
    t_end: np.ndarray
    x_end: np.ndarray
    steps: np.ndarray

    @property
    def status(self) -> list[RunStatus]:
        return [CODE_STATUS[int(c)] for c in self.code]


def check_tolerances(rtol: float, atol: float, margin_tol: float) -> None:
    """Validate integration tolerances (ValueError naming the field)."""
    if not (100 * EPS <= rtol < 1):
        raise RoaInputError(f"rtol must be in [{100 * EPS:.2g}, 1), got {rtol!r}")
    if not (0 < atol < np.inf):
        raise RoaInputError(f"atol must be a finite number > 0, got {atol!r}")
    if not (0 <= margin_tol < np.inf):
        raise RoaInputError(f"margin_tol must be a finite number >= 0, got {margin_tol!r}")


# ----------------------------------------------------------------------------- the step, once


def select(c: Any, a: Any, b: Any) -> Any:
    """``a`` where ``c`` holds, else ``b`` (``numpy.where``; a scalar select in numba code)."""
    return np.where(c, a, b)


def initial_step(field: Any, fargs: Any, t: Any, y: Any, f: Any, f1: Any, tmp: Any, n: int,
                 rtol: float, atol: float, t_final: float, rms: Any) -> Any:  # fmt: skip
    """scipy's ``select_initial_step`` for the 4th-order error estimator: the first step size
    from ``(t, y)`` with ``f = field(t, y)``; ``f1`` and ``tmp`` are work space (``f1`` holds
    ``field`` at the trial point after the call)."""
    for i in range(n):
        tmp[i] = y[i] / (atol + abs(y[i]) * rtol)
    d0 = rms(tmp)
    for i in range(n):
        tmp[i] = f[i] / (atol + abs(y[i]) * rtol)
    d1 = rms(tmp)
    h0 = select((d0 < 1e-5) | (d1 < 1e-5), 1e-6, 0.01 * d0 / d1)
    h0 = select(t_final < h0, t_final, h0)  # min(h0, t_final)
    for i in range(n):
        tmp[i] = y[i] + h0 * f[i]
    field(t + h0, tmp, fargs, f1)
    for i in range(n):
        tmp[i] = (f1[i] - f[i]) / (atol + abs(y[i]) * rtol)
    d2 = rms(tmp) / h0
    small = h0 * 1e-3
    d12 = select(d2 > d1, d2, d1)  # max(d1, d2)
    h1 = select((d1 <= 1e-15) & (d2 <= 1e-15), select(small > 1e-6, small, 1e-6),
                (0.01 / d12) ** (1.0 / 5.0))  # fmt: skip
    h = 100 * h0
    h = select(h1 < h, h1, h)  # min(100 h0, h1, t_final)
    return select(t_final < h, t_final, h)


def stages(field: Any, fargs: Any, t: Any, y: Any, h: Any, K: Any, tmp: Any, y_new: Any,
           n: int) -> None:  # fmt: skip
    """Stages 2 to 6 of the step of size ``h`` from ``(t, y)`` into ``K[1:6]`` (``K[0]`` holds
    ``field(t, y)``) and the 5th-order solution ``y_new``; ``tmp`` is work space. The 7th stage,
    ``field(t + h, y_new)``, is the caller's (it may fuse it with a coordinate map)."""
    A, B, C = TABLEAU_A, TABLEAU_B, TABLEAU_C
    for s in range(1, 6):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            tmp[i] = y[i] + h * acc
        field(t + C[s] * h, tmp, fargs, K[s])
    for i in range(n):
        acc = 0.0
        for j in range(6):
            acc += B[j] * K[j, i]
        y_new[i] = y[i] + h * acc


def error(h: Any, K: Any, y: Any, y_new: Any, err: Any, n: int, rtol: float,
          atol: float) -> None:  # fmt: skip
    """The scaled error estimate of the step into ``err`` (its norm, scipy's RMS, is the
    caller's): ``h sum_j E_j K_j / (atol + max(|y|, |y_new|) rtol)``."""
    E = ERROR_E
    for i in range(n):
        acc = 0.0
        for j in range(7):
            acc += E[j] * K[j, i]
        a, b = abs(y[i]), abs(y_new[i])
        err[i] = h * acc / (atol + select(b > a, b, a) * rtol)


def control(en: Any, h_abs: Any, rejected: Any) -> tuple[Any, Any]:
    """``(accepted, h_abs)`` after a step of error norm ``en``: accepted when ``en < 1`` (NaN is
    rejected), the next size grown by ``min(MAX_FACTOR, SAFETY en^-1/5)`` (``MAX_FACTOR`` at
    ``en = 0``; at most 1 right after a rejection), a rejected one shrunk by
    ``max(MIN_FACTOR, SAFETY en^-1/5)``, as scipy's RK45."""
    fac = SAFETY * en ** (-0.2)
    grow = select(en == 0.0, MAX_FACTOR, select(fac < MAX_FACTOR, fac, MAX_FACTOR))
    grow = select(rejected, select(grow < 1.0, grow, 1.0), grow)
    shrink = select(fac > MIN_FACTOR, fac, MIN_FACTOR)
    accepted = en < 1.0
    return accepted, h_abs * select(accepted, grow, shrink)


def dense_coefficients(K: Any, Q: Any, n: int) -> None:
    """The step's dense-output coefficients ``Q[i, j] = sum_k K[k, i] P[k, j]``."""
    P = DENSE_P
    for i in range(n):
        for j in range(4):
            acc = 0.0
            for k in range(7):
                acc += K[k, i] * P[k, j]
            Q[i, j] = acc


def dense(y: Any, h: Any, Q: Any, s: Any, out: Any, n: int) -> None:
    """The dense output ``y(t + s h) = y + h sum_j Q[:, j] s^(j+1)`` into ``out``."""
    for i in range(n):
        acc = 0.0
        p = s
        for j in range(4):
            acc += Q[i, j] * p
            p = p * s
        out[i] = y[i] + h * acc
