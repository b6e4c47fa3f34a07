"""Time plots of runs: every state against time, and optionally an input signal."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from roa.io import atomic_savefig
from roa.model._system import System


def state_labels(system: System) -> tuple[str, ...]:
    """Axis labels ``name [unit]`` from a system's state names and units (dimensionless, ``"1"``
    or none, is written ``-`` as in the basin maps)."""
    units = system.state_units or ("-",) * system.n
    return tuple(
        f"{n} [{u if u not in ('1', '') else '-'}]"
        for n, u in zip(system.state_names, units, strict=True)
    )


def plot_runs(
    runs: Sequence[tuple[str, np.ndarray, np.ndarray, np.ndarray | None]],
    path: str | Path,
    *,
    labels: Sequence[str],
    title: str,
    input_label: str | None = None,
    time_label: str = "time t",
) -> Path:
    """Plot runs ``(label, t, x (m, n), u (m,) or None)``: each state, and the input if labelled.

    ``labels`` are the n state axis labels (see :func:`state_labels`); ``input_label`` adds a
    panel for ``u``.
    """
    n = len(labels)
    rows = n + (input_label is not None)
    fig, axes = plt.subplots(rows, 1, figsize=(8, 2.2 * rows), sharex=True, squeeze=False)
    axes = axes[:, 0]
    for label, t, x, u in runs:
        for i in range(n):
            axes[i].plot(t, x[:, i], label=label, lw=1.4)
        if u is not None and input_label is not None:
            axes[n].plot(t, u, label=label, lw=1.4)
    all_labels = (*labels, input_label) if input_label is not None else tuple(labels)
    for ax, lab in zip(axes, all_labels, strict=True):
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


def plot_run(system: System, t: np.ndarray, x: np.ndarray, path: str | Path, *, title: str) -> Path:
    """One run's states."""
    return plot_runs([("run", t, x, None)], path, labels=state_labels(system), title=title)
