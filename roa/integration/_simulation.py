"""One trajectory of a system, with a status: the reference integrator (scipy's solve_ivp).

:func:`simulate` is the entry point; it returns a :class:`Trajectory` whose ``status`` is a
:class:`roa.status.RunStatus` (converged, left_domain, diverged, undecided, completed).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from roa.errors import RoaInputError
from roa.integration._divergence import blows_up, growth_message
from roa.integration._equilibria import settled_elsewhere
from roa.model._backend import NP
from roa.model._system import System
from roa.status import RunStatus, StopRules


@dataclass(frozen=True)
class Trajectory:
    """A simulated trajectory and how it ended.

    ``t`` has shape ``(m,)`` and ``x`` shape ``(m, n)``; ``message`` says why the run stopped and,
    for ``undecided`` runs, what to try.
    """

    status: RunStatus
    t: np.ndarray
    x: np.ndarray
    message: str
    system: str
    meta: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0
    problem: System | None = field(default=None, repr=False, compare=False)

    @property
    def final_state(self) -> np.ndarray:
        return self.x[-1]

    @property
    def t_end(self) -> float:
        return float(self.t[-1])

    @property
    def u(self) -> np.ndarray | None:
        """The inputs the loop applied along the run, shape ``(m_points, m)``: the system's
        ``feedback`` at each state (None for a system without one)."""
        if self.problem is None or self.problem.feedback is None:
            return None
        return self.problem.inputs(self.x)

    def to_dict(self) -> dict[str, Any]:
        """What ``roa simulate --json`` prints."""
        out: dict[str, Any] = {
            "system": self.system,
            "status": self.status.value,
            "message": self.message,
            "t_end": self.t_end,
            "final_state": [float(v) for v in self.final_state],
            "seconds": round(self.seconds, 4),
            **self.meta,
        }
        if self.problem is not None:
            out["state_names"] = list(self.problem.state_names)
            if self.problem.state_units:
                out["state_units"] = list(self.problem.state_units)
            u = self.u
            if u is not None:
                out["input_names"] = list(self.problem.input_names)
                if self.problem.input_units:
                    out["input_units"] = list(self.problem.input_units)
                out["final_input"] = [float(v) for v in u[-1]]
                out["max_abs_input"] = [float(v) for v in np.max(np.abs(u), axis=0)]
        return out

    def plot(self, ax: Any = None) -> Any:
        """Every state against time and, for a system with ``feedback``, every input ``u(t)``
        in a panel below (sharing the time axis).

        ``ax``: one axes (the states only), or two (states, inputs); by default a new figure with
        the panels it needs. Returns the states' axes.
        """
        import matplotlib.pyplot as plt

        u = self.u
        ax_u = None
        if ax is None:
            if u is None:
                _, ax = plt.subplots(figsize=(7, 3.5))
            else:
                _, (ax, ax_u) = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True,
                                             height_ratios=(3, 2), layout="constrained")  # fmt: skip
        elif isinstance(ax, list | tuple | np.ndarray):
            ax, ax_u = (list(np.ravel(ax))[:2] + [None])[:2]
        names = (
            self.problem.state_names
            if self.problem
            else tuple(f"x{i}" for i in range(self.x.shape[1]))
        )
        units = (self.problem.state_units if self.problem else ()) or ("-",) * len(names)
        dimless = ("1", "")  # written "-", as in the basin maps
        for i, (nm, un) in enumerate(zip(names, units, strict=True)):
            ax.plot(self.t, self.x[:, i], label=f"{nm} [{'-' if un in dimless else un}]")
        # a unit only where the system declares one (meta["time_unit"]): fields are often scaled
        unit = (self.problem.meta.get("time_unit") if self.problem else None) or None
        xlabel = f"time t [{unit}]" if unit else "time t"
        ax.set_ylabel("state")
        ax.set_title(f"{self.system}: {self.status.value}")
        ax.legend(loc="best", fontsize=8)
        if ax_u is not None and u is not None and self.problem is not None:
            u_names = self.problem.input_names or tuple(f"u{i}" for i in range(u.shape[1]))
            u_units = self.problem.input_units or ("-",) * len(u_names)
            for i, (nm, un) in enumerate(zip(u_names, u_units, strict=True)):
                ax_u.plot(self.t, u[:, i], label=f"{nm} [{'-' if un in dimless else un}]")
            ax_u.set_ylabel("input u")
            ax_u.set_xlabel(xlabel)
            ax_u.legend(loc="best", fontsize=8)
        else:
            ax.set_xlabel(xlabel)
        return ax


class _RunEnds(Exception):
    """Raised by the right-hand side to end the run at ``(t, x)``."""

    def __init__(self, t: float, x: np.ndarray) -> None:
        super().__init__(t)
        self.t, self.x = t, np.array(x, dtype=float)


class _TimeLimit(_RunEnds):
    """The run's wall-clock budget is spent."""


class _NonFiniteField(_RunEnds):
    """The field is NaN or inf."""


def simulate(
    system: System,
    x0: Any,
    *,
    rules: StopRules | None = None,
    rtol: float = 1e-9,
    atol: float = 1e-11,
    method: str = "DOP853",
    t_eval: np.ndarray | None = None,
    max_step: float = np.inf,
    time_limit: float | None = None,
) -> Trajectory:
    """Integrate ``system`` from ``x0`` until an event or ``rules.t_final``.

    A discrete-time system's map is iterated instead (``t_final`` in units of its
    ``sample_time``; the solver options are unused).

    Events (terminal): entering the convergence ball (autonomous systems with an equilibrium),
    reaching the domain boundary, exceeding the divergence bound. Non-finite states end the run as
    ``diverged``; nothing is returned as a silent NaN. A run still going at ``t_final`` that grows
    exponentially far out is ``diverged`` too (:func:`roa.integration._divergence.blows_up`, the factor
    ``rules.diverge_growth``).

    Parameters
    ----------
    system : System
        The system.
    x0 : sequence of float
        Initial state (n components, inside the domain).
    rules : StopRules, optional
        ``t_final``, ``converge_tol``, ``diverge_bound``, ``diverge_growth``.
    rtol, atol, method, t_eval, max_step
        Passed to :func:`scipy.integrate.solve_ivp`.
    time_limit : float, optional
        Wall-clock budget in seconds (> 0): a run still going then ends ``undecided`` with the
        reason ``time_limit`` (a slow field cannot hold the caller forever).

    Returns
    -------
    Trajectory
        ``.status`` (a :class:`RunStatus`), ``.t``, ``.x``, ``.message``.

    Examples
    --------
    >>> import roa
    >>> from roa.systems.vanderpol import vanderpol
    >>> roa.simulate(vanderpol(), [0.5, 0.5]).status
    <RunStatus.CONVERGED: 'converged'>
    """
    t_start = time.perf_counter()
    if time_limit is not None and not (
        isinstance(time_limit, int | float) and 0 < time_limit < np.inf
    ):
        raise RoaInputError(
            f"time_limit must be a finite number of seconds > 0, got {time_limit!r}"
        )
    from roa.model._checks import check_system

    if system.parameters:
        box = ", ".join(f"{k} in [{r.low:g}, {r.high:g}]" for k, r in system.parameters.items())
        first = next(iter(system.parameters))
        raise RoaInputError(
            f"system {system.name!r} has uncertain parameters ({box}): a trajectory needs one "
            f"value of each; simulate system.at({first}=...) or system.nominal() (CLI: --param "
            f"{first}=VALUE)"
        )
    check_system(system)
    if system.time == "discrete":
        traj = _iterate(system, x0, rules, time_limit)
        return dataclasses.replace(traj, seconds=time.perf_counter() - t_start, problem=system)
    traj = _integrate(system, x0, rules, dict(rtol=rtol, atol=atol, method=method,
                                              t_eval=t_eval, max_step=max_step),
                      time_limit=time_limit)  # fmt: skip
    return dataclasses.replace(traj, seconds=time.perf_counter() - t_start, problem=system)


def _iterate(system: System, x0: Any, rules: StopRules | None,
             time_limit: float | None) -> Trajectory:  # fmt: skip
    """The orbit of a discrete-time system (:func:`roa.integration._iterate.orbit`)."""
    from roa.integration._dopri import CODE_STATUS
    from roa.integration._iterate import orbit

    rules = StopRules() if rules is None else rules
    x0 = system.check_state(x0, what="initial state")
    if x0.ndim != 1:
        raise RoaInputError(
            f"initial state must be one state of {system.n} components, got shape {x0.shape}"
        )
    deadline = None if time_limit is None else time.perf_counter() + float(time_limit)
    code, t, x, timed = orbit(system, x0, rules, deadline)
    status = CODE_STATUS[code]
    steps = len(t) - 1
    why = "time_limit" if timed else status.value
    message = (f"{why} after {steps} steps of the map (t = {t[-1]:g}, sample time "
               f"{system.sample_time:g})")  # fmt: skip
    if status is RunStatus.UNDECIDED:
        mask, points = settled_elsewhere(system, x[-1], rules.converge_tol)
        if mask[0]:
            status = RunStatus.CONVERGED_ELSEWHERE
            message = f"settled at the fixed point {points[0].tolist()} after {steps} steps"
        elif not timed:
            message += "; raise rules.t_final to iterate further"
    return Trajectory(status, t, x, message, system.name, meta={"steps": steps})


def _integrate(system: System, x0: Any, rules: StopRules | None, ivp: dict[str, Any],
               time_limit: float | None = None) -> Trajectory:  # fmt: skip
    """The run of :func:`simulate` (``ivp``: its solve_ivp options), without the timing."""
    deadline = None if time_limit is None else time.perf_counter() + float(time_limit)
    rules = StopRules() if rules is None else rules
    t_eval = ivp["t_eval"]
    x0 = system.check_state(x0, what="initial state")
    if x0.ndim != 1:
        raise RoaInputError(
            f"initial state must be one state of {system.n} components, got shape {x0.shape}"
        )
    track_convergence = system.equilibrium is not None and not system.time_varying
    x_eq = system.x_eq if track_convergence else None

    def rhs(t: float, x: np.ndarray) -> np.ndarray:
        if deadline is not None and time.perf_counter() > deadline:
            raise _TimeLimit(t, x)
        f = system.f(x, t)
        if not np.all(np.isfinite(f)):  # solve_ivp would loop forever on a NaN step size
            raise _NonFiniteField(t, x)
        return f

    events = []
    names = []
    if track_convergence:

        def ev_conv(t: float, x: np.ndarray) -> float:
            return float(np.linalg.norm(x - x_eq) - rules.converge_tol)

        ev_conv.terminal = True  # type: ignore[attr-defined]
        ev_conv.direction = -1  # type: ignore[attr-defined]
        events.append(ev_conv)
        names.append(RunStatus.CONVERGED)
    margin = system.margin
    if margin is not None:

        def ev_dom(t: float, x: np.ndarray) -> float:
            return float(margin(list(x), NP))

        ev_dom.terminal = True  # type: ignore[attr-defined]
        ev_dom.direction = -1  # type: ignore[attr-defined]
        events.append(ev_dom)
        names.append(RunStatus.LEFT_DOMAIN)

    def ev_div(t: float, x: np.ndarray) -> float:
        return float(rules.diverge_bound - np.linalg.norm(x))

    ev_div.terminal = True  # type: ignore[attr-defined]
    ev_div.direction = -1  # type: ignore[attr-defined]
    events.append(ev_div)
    names.append(RunStatus.DIVERGED)

    if track_convergence and np.linalg.norm(x0 - x_eq) <= rules.converge_tol:
        return Trajectory(
            RunStatus.CONVERGED, np.array([0.0]), x0[None, :], "started converged", system.name
        )

    with np.errstate(all="ignore"):
        try:
            sol = solve_ivp(
                rhs,
                (0.0, rules.t_final),
                x0,
                events=events,
                dense_output=False,
                **ivp,
            )
        except _RunEnds as stop:  # the run ends here, undecided
            xs = np.asarray(stop.x, dtype=float)
            if isinstance(stop, _TimeLimit):
                reason = "time_limit"
                message = (f"the wall-clock budget of {time_limit:g} s ran out at t = "
                           f"{stop.t:.6g}: no verdict for this run (raise --time-limit)")  # fmt: skip
            else:
                reason = "non_finite_field"
                message = (f"the field is not finite at t = {stop.t:.6g}, x = "
                           f"{np.array2string(xs, precision=6)}: the run cannot go on")  # fmt: skip
            return Trajectory(RunStatus.UNDECIDED, np.array([float(stop.t)]), xs[None, :],
                              message, system.name,
                              meta={"reason": reason, "t": float(stop.t), "x": xs.tolist()})  # fmt: skip
    t, x = sol.t, sol.y.T
    finite = np.all(np.isfinite(x), axis=1)
    if not finite.all():
        k = int(np.argmin(finite))
        return Trajectory(
            RunStatus.DIVERGED, t[:k], x[:k], f"non-finite state at t = {t[k]:.4g}", system.name
        )
    for status, t_ev, x_ev in zip(names, sol.t_events, sol.y_events, strict=True):
        if len(t_ev):
            if t_eval is not None:  # append the event point to the sampled output
                t = np.append(t, t_ev[0])
                x = np.vstack([x, x_ev[0]])
            return Trajectory(status, t, x, f"{status.value} at t = {t_ev[0]:.6g}", system.name)
    if sol.status == -1:
        return Trajectory(
            RunStatus.DIVERGED if not np.all(np.isfinite(x[-1])) else RunStatus.UNDECIDED,
            t,
            x,
            f"integrator failed: {sol.message}; try a looser rtol or a smaller t_final",
            system.name,
        )
    if system.time_varying or not track_convergence:
        return Trajectory(
            RunStatus.COMPLETED, t, x, f"reached t_final = {rules.t_final:g}", system.name
        )
    mask, points = settled_elsewhere(system, x[-1], rules.converge_tol)
    if mask[0]:
        return Trajectory(
            RunStatus.CONVERGED_ELSEWHERE,
            t,
            x,
            f"settled at another equilibrium {np.array2string(points[0], precision=6)} by "
            f"t_final = {rules.t_final:g} (not the studied {np.array2string(system.x_eq, precision=6)})",
            system.name,
            meta={"equilibrium_reached": points[0].tolist()},
        )
    f_end = system.f(x[-1])
    if blows_up(t, x, f_end, system.x_eq, rules):
        r_end = float(np.linalg.norm(x[-1] - system.x_eq))
        return Trajectory(RunStatus.DIVERGED, t, x, growth_message(r_end, rules), system.name,
                          meta={"reason": "growth"})  # fmt: skip
    speed = float(np.linalg.norm(f_end))
    return Trajectory(
        RunStatus.UNDECIDED,
        t,
        x,
        f"time horizon reached: neither converged nor left the domain by t_final = "
        f"{rules.t_final:g}; still moving (|f(x)| = {speed:.3g} at the end): try increasing "
        "t_final or converge_tol",
        system.name,
        meta={"reason": "time_horizon", "final_speed": speed},
    )
