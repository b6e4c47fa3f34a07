"""Shared base of the batch integrators: status codes, the Dormand-Prince 5(4) tableau, results.

:mod:`roa.montecarlo.integrator` (numba kernel and dispatch) and
:mod:`roa.montecarlo.integrator_numpy` (vectorised numpy) both build on this module.
"""

from __future__ import annotations

from dataclasses import dataclass

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
