"""Time plots of IPC-like runs: states and the control force."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import roa.plotting  # noqa: F401  (Agg backend)
from roa.io import atomic_savefig

STATE_LABELS = ("q [-]", r"$\dot q$ [1/s]", r"$\theta$ [rad]", r"$\dot\theta$ [rad/s]")


def plot_runs(
    runs: Sequence[tuple[str, np.ndarray, np.ndarray, np.ndarray | None]],
    path: str | Path,
    *,
    title: str,
    time_label: str = "normalised time t [-]",
) -> Path:
    """Plot several runs ``(label, t, x (m, 4), u (m,) or None)``: the four states and the force."""
    fig, axes = plt.subplots(5, 1, figsize=(8, 11), sharex=True)
    for label, t, x, u in runs:
        for i in range(4):
            axes[i].plot(t, x[:, i], label=label, lw=1.4)
        if u is not None:
            axes[4].plot(t, u, label=label, lw=1.4)
    for ax, lab in zip(axes, (*STATE_LABELS, "force u [-] (normalised, u = F/(m g))"), strict=True):
        ax.set_ylabel(lab)
        ax.grid(alpha=0.3)
        ax.axhline(0, color="k", lw=0.5)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel(time_label)
    fig.suptitle(title)
    fig.tight_layout()
    out = atomic_savefig(fig, path)
    plt.close(fig)
    return out


def plot_run(t: np.ndarray, x: np.ndarray, path: str | Path, *, title: str) -> Path:
    """One run's states (no force)."""
    return plot_runs([("run", t, x, None)], path, title=title)
