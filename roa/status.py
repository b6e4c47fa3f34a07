"""Statuses of runs and the stop rules that decide them."""

from __future__ import annotations

import enum
from dataclasses import dataclass


class RunStatus(enum.StrEnum):
    """How one trajectory ended. Never merged: each is counted on its own."""

    CONVERGED = "converged"  # entered the ball ||x - x_eq|| <= converge_tol
    LEFT_DOMAIN = "left_domain"  # crossed the boundary of the system's domain
    DIVERGED = "diverged"  # norm above diverge_bound, or a non-finite state
    UNDECIDED = "undecided"  # none of the above by t_final
    COMPLETED = "completed"  # time-varying run (tracking): reached t_final inside the domain


@dataclass(frozen=True)
class StopRules:
    """When a trajectory stops and with which status.

    Parameters
    ----------
    t_final : float
        Final time; a run still running then is ``undecided`` (``completed`` for tracking runs).
    converge_tol : float
        Radius of the ball around the equilibrium that counts as converged.
    diverge_bound : float
        Norm above which a run is ``diverged``.
    """

    t_final: float = 60.0
    converge_tol: float = 1e-3
    diverge_bound: float = 1e6

    def __post_init__(self) -> None:
        for name in ("t_final", "converge_tol", "diverge_bound"):
            value = getattr(self, name)
            if not (value > 0 and value < float("inf")):
                raise ValueError(f"StopRules.{name} must be a finite number > 0, got {value!r}")
        if self.converge_tol >= self.diverge_bound:
            raise ValueError("StopRules.converge_tol must be smaller than StopRules.diverge_bound")
