"""Experiments ``figure1`` and ``figure2``: the paper's simulations, re-run with the derived model."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from scipy.integrate import solve_ivp

from ipc_paper import system as ipc
from ipc_paper.system.controller import Gains, make_reference
from ipc_paper.system.model import phi0
from roa.errors import RoaInputError
from roa.integration import simulate
from roa.io import atomic_savefig, atomic_write_json
from roa.options import Options
from roa.plotting import plot_runs
from roa.status import StopRules
from roa.studies import accepts, check_int, check_number, check_numbers

IPC_LABELS = ("q [-]", r"$\dot q$ [1/s]", r"$\theta$ [rad]", r"$\dot\theta$ [rad/s]")
FORCE_LABEL = "force u [-] (u = F/(m g))"
TIME_LABEL = "normalised time t [-]"


def _run(system, x0, t_final: float, n_points: int, **kw):
    t_eval = np.linspace(0.0, t_final, n_points)
    # converge_tol tiny: the plot shows the whole horizon; the status comes from a separate run
    return simulate(
        system, x0, rules=StopRules(t_final=t_final, converge_tol=1e-14), t_eval=t_eval, **kw
    )


def _check_common(params: Any) -> None:
    """Checks shared by the figure params: horizon, delta, poles (through Gains), n_points."""
    check_number(params, "t_final", positive=True)
    check_number(params, "delta", positive=True)
    Gains.from_poles(params.poles)
    check_int(params, "n_points", 2, 10**6)


@dataclass(frozen=True, kw_only=True)
class Figure1Params(Options):
    """``[params]`` of :func:`run_figure1`.

    ``initial_conditions`` (required): a table ``name = [q, q', theta, theta']``, one run each;
    ``status_t_final``: horizon of the separate run that gives each status; ``extra_theta0``:
    further runs from ``(0, 0, theta0, 0)`` (claim F2).
    """

    initial_conditions: dict[str, Any]
    t_final: float = 20.0
    delta: float = ipc.DEFAULT_DELTA
    poles: tuple[float, ...] = (-1, -1, -1, -1)
    n_points: int = 801
    status_t_final: float = 60.0
    extra_theta0: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        ics = self.initial_conditions
        if not isinstance(ics, dict) or not ics:
            raise RoaInputError(
                f"initial_conditions must be a table name = [q, q', theta, theta'], got {ics!r}"
            )
        for k, v in ics.items():
            key = f"initial_conditions.{k}"
            check_numbers({key: v}, key, size=4)
        _check_common(self)
        check_number(self, "status_t_final", positive=True)
        check_numbers(self, "extra_theta0")


@accepts(Figure1Params)
def run_figure1(params: dict[str, Any], out: Path, *, quick: bool) -> dict[str, Any]:
    """Figure 1: regulation from p1, p2, p3 of (3.5) with p(s) = (s + 1)^4."""
    ics = {k: np.array(v, dtype=float) for k, v in params["initial_conditions"].items()}
    t_final = float(params["t_final"])
    delta = float(params["delta"])
    gains = Gains.from_poles(params["poles"])
    system = ipc.closed_loop(delta=delta, gains=gains)
    runs, table = [], {}
    for name, x0 in ics.items():
        tr = _run(system, x0, t_final, int(params["n_points"]))
        u = ipc.control_force(tr.t, tr.x.T, delta=delta, gains=gains)
        status = simulate(system, x0, rules=StopRules(t_final=float(params["status_t_final"])))
        runs.append((f"{name} = {x0.tolist()}", tr.t, tr.x, u))
        table[name] = {
            "x0": x0.tolist(),
            "status": status.status.value,
            "t_converged": status.t_end if status.status.value == "converged" else None,
            "state_at_t_final": tr.x[-1].tolist(),
            "max_abs_u": float(np.max(np.abs(u))),
            "max_abs_q": float(np.max(np.abs(tr.x[:, 0]))),
        }
    extra = {}
    for th0 in params["extra_theta0"]:
        st = simulate(system, [0.0, 0.0, th0, 0.0], rules=StopRules(t_final=60.0))
        extra[f"{th0:+g}"] = {"status": st.status.value, "t_end": st.t_end}
    fig_path = out / "figure1.png"
    plot_runs(
        runs,
        fig_path,
        labels=IPC_LABELS,
        input_label=FORCE_LABEL,
        time_label=TIME_LABEL,
        title=f"Figure 1: regulation, p(s) = (s+1)^4, delta = {delta:g}",
    )
    atomic_write_json(
        out / "figure1.json",
        {"delta": delta, "gains": gains.h, "runs": table, "extra_theta0": extra},
    )
    ev = f"results/{out.name}/figure1.json"
    all_conv = all(r["status"] == "converged" for r in table.values())
    ours = "; ".join(
        f"{k}: {r['status']} (||x|| < 1e-3 at t = {r['t_converged']:.1f}), max|u| = {r['max_abs_u']:.2f}"
        if r["t_converged"] is not None
        else f"{k}: {r['status']}"
        for k, r in table.items()
    )
    claims = [
        {
            "id": "F1",
            "claim": "Figure 1: p1, p2, p3 of (3.5) are stabilised to the origin",
            "paper": "all three converge",
            "ours": ours,
            "verdict": "reproduced" if all_conv else "not reproduced",
            "evidence": ev,
            "details": "Simulated with the derived model (E1) and the corrected force (E2-E4), DOP853 rtol 1e-9; "
            "the paper's printed (2.1)/(2.5) would not stabilise anything (E4: positive feedback). "
            "The figure adds the control force u(t) that the paper does not show.",
        }
    ]
    if extra:
        ok = all(v["status"] == "converged" for v in extra.values())
        claims.append(
            {
                "id": "F2",
                "claim": "Sec. 3.3: theta(0) = +-1.3 rad (q = q' = theta' = 0) is stabilised",
                "paper": "stabilised (said to be seen in Figure 1, which shows no such run)",
                "ours": ", ".join(
                    f"theta(0) = {k}: {v['status']} (t = {v['t_end']:.1f})"
                    for k, v in extra.items()
                ),
                "verdict": "reproduced" if ok else "not reproduced",
                "evidence": ev,
            }
        )
    return {"claims": claims, "figures": [f"results/{out.name}/figure1.png"], "runs": table}


def linear_error_prediction(gains: Gains, reference, t: np.ndarray) -> np.ndarray:
    """Tracking error e1 = z1 - F* predicted by the linear error dynamics driven by phi0(F*'') F*'''^2.

    With e = zeta - (F*, F*', F*'', F*'''), (3.3) in (2.6) gives e' = A e + b d(t), d = phi0(w1) w2^2
    entering z2'. Evaluating d on the reference (w1 ~ F*'', w2 ~ F*''') gives an independent estimate of
    the residual error.
    """
    h = gains.h
    A = np.array(
        [[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [-h[0], -h[1], -h[2], -h[3]]], dtype=float
    )

    def rhs(tt: float, e: np.ndarray) -> np.ndarray:
        d = reference.derivatives(tt)
        return A @ e + np.array([0.0, phi0(d[2]) * d[3] ** 2, 0.0, 0.0])

    sol = solve_ivp(rhs, (t[0], t[-1]), np.zeros(4), t_eval=t, rtol=1e-10, atol=1e-12)
    return sol.y[0]


@dataclass(frozen=True, kw_only=True)
class Figure2Params(Options):
    """``[params]`` of :func:`run_figure2`; ``reference`` is parsed by
    :func:`ipc_paper.system.controller.make_reference` (``None`` or ``"0"``: regulation)."""

    initial_condition: tuple[float, ...] = (0.0, 0.0, 1.0, 0.0)
    t_final: float = 60.0
    delta: float = ipc.DEFAULT_DELTA
    poles: tuple[float, ...] = (-1, -1, -1, -1)
    reference: str | None = "2*sin(t/2)"
    n_points: int = 3001

    def __post_init__(self) -> None:
        check_numbers(self, "initial_condition", size=4)
        _check_common(self)
        make_reference(self.reference)


@accepts(Figure2Params)
def run_figure2(params: dict[str, Any], out: Path, *, quick: bool) -> dict[str, Any]:
    """Figure 2: tracking F*(t) = 2 sin(t/2) from theta(0) = 1 rad."""
    x0 = np.array(params["initial_condition"], dtype=float)
    t_final = float(params["t_final"])
    delta = float(params["delta"])
    gains = Gains.from_poles(params["poles"])
    reference = make_reference(params["reference"])
    system = ipc.closed_loop(delta=delta, gains=gains, reference=reference)
    tr = _run(system, x0, t_final, int(params["n_points"]))
    t, x = tr.t, tr.x
    u = ipc.control_force(t, x.T, delta=delta, gains=gains, reference=reference)
    err = ipc.to_flat(x)[:, 0] - reference.derivatives(t)[0]
    half = t >= t_final / 2
    pred = linear_error_prediction(gains, reference, t)
    fig, ax = plt.subplots(2, 2, figsize=(11, 8))
    ax[0, 0].plot(x[:, 2], x[:, 3], lw=1)
    ax[0, 0].plot(x0[2], x0[3], "o", label="start")
    ax[0, 0].set(
        xlabel=r"$\theta$ [rad]",
        ylabel=r"$\dot\theta$ [rad/s]",
        title=r"(a) $(\theta, \dot\theta)$",
    )
    ax[0, 1].plot(x[:, 0], x[:, 1], lw=1)
    ax[0, 1].plot(x0[0], x0[1], "o", label="start")
    ax[0, 1].set(xlabel="q [-]", ylabel=r"$\dot q$ [1/s]", title=r"(b) $(q, \dot q)$")
    ax[1, 0].plot(t, err, label=r"simulated $z_1 - F_*$")
    ax[1, 0].plot(t, pred, "--", label="linear error model driven by $\\phi_0(F_*'')F_*'''^2$")
    lim = 4 * max(float(np.max(np.abs(err[half]))), 1e-3)
    ax[1, 0].set(
        xlabel="normalised time t [-]",
        ylabel=r"$z_1 - F_*$ [-]",
        title=f"(c) tracking error (starts at {err[0]:.2f}, off-scale)",
    )
    ax[1, 0].set_ylim(-lim, lim)
    ax[1, 1].plot(t, u)
    ax[1, 1].set(
        xlabel="normalised time t [-]",
        ylabel="force u [-]",
        title="(d) control force (not in the paper)",
    )
    for a in ax.flat:
        a.grid(alpha=0.3)
    for a in (ax[0, 0], ax[0, 1], ax[1, 0]):
        a.legend(fontsize=8)
    fig.suptitle(
        rf"Figure 2: tracking $F_*(t)$ = {reference.description} from $\theta(0)$ = {x0[2]:g} rad"
    )
    fig.tight_layout()
    atomic_savefig(fig, out / "figure2.png")
    plt.close(fig)
    plot_runs(
        [("tracking", t, x, u)],
        out / "figure2_states.png",
        labels=IPC_LABELS,
        input_label=FORCE_LABEL,
        time_label=TIME_LABEL,
        title="Figure 2 run: states and force",
    )
    res = {
        "x0": x0.tolist(),
        "reference": reference.description,
        "status": tr.status.value,
        "tracking_error_max_last_half": float(np.max(np.abs(err[half]))),
        "tracking_error_rms_last_half": float(np.sqrt(np.mean(err[half] ** 2))),
        "linear_prediction_max_last_half": float(np.max(np.abs(pred[half]))),
        "q_max_abs_last_half": float(np.max(np.abs(x[half, 0]))),
        "theta_max_abs_last_half": float(np.max(np.abs(x[half, 2]))),
        "max_abs_u": float(np.max(np.abs(u))),
    }
    atomic_write_json(out / "figure2.json", res)
    ev = f"results/{out.name}/figure2.json"
    bounded = tr.status.value == "completed" and res["q_max_abs_last_half"] < 10
    # verdicts hold only for the paper's setup: theta(0) = 1 rad from rest, F* = 2 sin(t/2), p(s) =
    # (s + 1)^4, and a horizon long enough to see the periodic motion (several periods of 4 pi)
    paper_setup = (
        np.allclose(x0, [0.0, 0.0, 1.0, 0.0])
        and reference.description == make_reference("2*sin(t/2)").description
        and np.allclose(gains.h, Gains.default().h)
        and t_final >= 40.0
    )
    setup_note = (
        ""
        if paper_setup
        else f"not checked: this run (x0 = {x0.tolist()}, F* = {reference.description}, "
        f"t_final = {t_final:g}) is not the paper's setup; "
    )
    err_max, pred_max = res["tracking_error_max_last_half"], res["linear_prediction_max_last_half"]
    # F4: the error stays away from zero and the linear error model explains it (within 25 %)
    explained = err_max > 1e-3 and abs(err_max - pred_max) <= 0.25 * pred_max
    claims = [
        {
            "id": "F3",
            "claim": "Figure 2: from theta(0) = 1 rad the flat output tracks F* = 2 sin(t/2) with a stable periodic motion, cart bounded",
            "paper": "stable periodic motion, tracking error shown in 2(c)",
            "ours": f"{setup_note}stays in the domain, |q| <= {res['q_max_abs_last_half']:.2f}, |theta| <= "
            f"{res['theta_max_abs_last_half']:.2f} rad over the last half; max|u| = {res['max_abs_u']:.2f}",
            "verdict": "reproduced" if bounded and paper_setup else "not reproduced",
            "evidence": ev,
        },
        {
            "id": "F4",
            "claim": "Figure 2(c): the tracking error z1 - F*",
            "paper": "plotted, no value stated; (3.3) is called approximate tracking",
            "ours": f"{setup_note}does not go to zero: max|z1 - F*| over the last half = {err_max:.4f} "
            f"(linear error model predicts {pred_max:.4f})",
            "verdict": "reproduced" if explained and paper_setup else "not reproduced",
            "evidence": ev,
            "details": "The law (3.3) treats w1 as F'' although z2' = w1 + phi0(w1) w2^2 (2.6). The error "
            "e = zeta - (F*, F*', F*'', F*''') obeys e' = A e + b phi0(w1) w2^2 with A Hurwitz, so it converges to a "
            "periodic residual forced by phi0(F*'') F*'''^2, which is not zero while the reference moves "
            "(transfer function (s^2 + h3 s + h2)/p(s) from the disturbance to e1).",
        },
    ]
    return {
        "claims": claims,
        "figures": [f"results/{out.name}/figure2.png", f"results/{out.name}/figure2_states.png"],
        **{k: res[k] for k in ("status", "tracking_error_max_last_half")},
    }
