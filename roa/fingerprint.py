"""A fingerprint of a system: what a certificate is bound to, instead of the system's name.

:func:`system_fingerprint` hashes what decides a certificate's meaning: the number, names and
order of the states, the equilibrium, whether the system is time-varying, and a *trace* of the
field (and of the domain margin) at fixed points around the equilibrium. Two systems whose fields
differ anywhere on those points (another parameter, another controller gain, another coordinate
system) get different fingerprints; two builds of the same system get the same one.

The trace is rounded to 10 significant digits before hashing, so that a last-bit difference of a
libm function between platforms does not change it. A fingerprint detects a certificate used for
the wrong system; it proves nothing about the certificate itself (re-verification does that,
:mod:`roa.proof.reverify`).
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

import numpy as np

from roa.system import System

#: Number of trace points and their seed (part of the fingerprint's definition: do not change).
N_POINTS = 8
SEED = 20261202


def _rounded(values: np.ndarray) -> list[str]:
    return [f"{float(v):.10g}" if np.isfinite(v) else str(float(v)) for v in values.ravel()]


def trace_points(system: System) -> np.ndarray:
    """The fixed points of the trace: the equilibrium and ``N_POINTS`` points around it."""
    c = system.x_eq if system.equilibrium is not None else np.zeros(system.n)
    rng = np.random.default_rng(SEED)
    U = rng.uniform(-1.0, 1.0, (N_POINTS, system.n))
    r = 0.1 * (1.0 + float(np.abs(c).max(initial=0.0)))
    return np.concatenate([c[None, :], c + r * U])


def system_fingerprint(system: System) -> str:
    """SHA-256 (hex) of the system's states, equilibrium and field trace (see module doc)."""
    X = trace_points(system)
    with np.errstate(all="ignore"):
        try:
            F = np.asarray(system.f(X), dtype=float)
        except Exception:  # noqa: BLE001 - a field that fails on the trace still has an identity
            F = np.full(X.shape, np.nan)
        margin: Any = None
        if system.margin is not None:
            try:
                comps = [X[:, i] for i in range(system.n)]
                from roa.backend import NP

                margin = _rounded(np.broadcast_to(system.margin(comps, NP), X.shape[:1]))
            except Exception:  # noqa: BLE001
                margin = "error"
    data = {
        "n": system.n,
        "states": list(system.state_names),
        "equilibrium": None if system.equilibrium is None else _rounded(system.x_eq),
        "time_varying": bool(system.time_varying),
        "field": _rounded(F),
        "margin": margin,
    }
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()
