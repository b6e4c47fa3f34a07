"""Regression values: ``results/reference.json`` and the registry of functions that recompute them.

``roa check`` recomputes every stored value and exits non-zero naming each one that drifts beyond
its tolerance (or is missing, unregistered or fails); ``tests/test_reference.py`` runs the same check.

How to add a value (one line in :data:`REGISTRY`)::

    "area.name": Entry("package.module:function", rtol=1e-6, method="how it is computed"),

``function(**kwargs)`` (``kwargs`` from ``Entry(..., kwargs={...})``) returns a float, or a dict
with a float under ``"value"`` (or under ``Entry(..., item="name")``). Then store it once with ``roa check --update area.name`` and commit
``results/reference.json``. Stored entries record value, tolerance, method and how to recompute.
"""

from __future__ import annotations

import importlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from roa.io import atomic_write_json

DEFAULT_PATH = Path("results/reference.json")


@dataclass(frozen=True)
class Entry:
    """A recomputable value: ``target`` is ``"module:function"``; tolerance ``rtol``/``atol``."""

    target: str
    rtol: float
    method: str
    kwargs: dict[str, Any] = field(default_factory=dict)
    atol: float = 0.0
    item: str = "value"

    def compute(self) -> float:
        module, func = self.target.split(":")
        out = getattr(importlib.import_module(module), func)(**self.kwargs)
        if isinstance(out, dict):
            out = out[self.item]
        return float(out)


_L = "roa.systems.ipc.lyapunov:khalil_value"
_K = "IPOPT multi-start min s s.t. V'/s >= 0, witness on V' = 0"
_S = "20000 sampled rays + cap refinement, bisection of the first V' >= 0"

#: key -> Entry. Add yours here (one line each); see the module docstring.
REGISTRY: dict[str, Entry] = {
    "ipc.khalil.ball.casadi": Entry(_L, 1e-6, _K, {"shape": "ball", "method": "casadi"}),
    "ipc.khalil.ball.sampled": Entry(_L, 1e-4, _S, {"shape": "ball", "method": "sampled"}),
    "ipc.khalil.level.casadi": Entry(_L, 1e-6, _K, {"shape": "level", "method": "casadi"}),
    "ipc.khalil.level.sampled": Entry(_L, 1e-4, _S, {"shape": "level", "method": "sampled"}),
    "ipc.bound.corrected.c_tilde": Entry(
        "roa.systems.ipc.bound:corrected_bound",
        1e-12,
        "closed form alpha/(2 kappa)",
        item="c_tilde",
    ),
    "ipc.certify.paper.interval": Entry(
        "roa.systems.ipc.certify_runs:certified_level", 1e-6, "0.999 x IPOPT optimum, interval-certified"
    ),
    "vanderpol.level.casadi": Entry(
        "roa.reference:vanderpol_level", 1e-6, _K, {"method": "casadi"}
    ),
}


def vanderpol_level(method: str = "casadi") -> float:
    """Largest V-level of the time-reversed Van der Pol benchmark (published 2.3045)."""
    from roa.levelset import level_search
    from roa.lyapunov import QuadraticLyapunov
    from roa.systems.vanderpol import P_BENCHMARK, vanderpol

    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    return float(level_search(system, V, P_BENCHMARK, shape="level", method=method)["value"])


def load(path: str | Path = DEFAULT_PATH) -> dict[str, Any]:
    path = Path(path)
    if not path.is_file():
        return {}
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: invalid JSON: {exc}") from exc


def _select(keys: list[str] | None) -> list[str]:
    if not keys:
        return list(REGISTRY)
    unknown = [k for k in keys if k not in REGISTRY]
    if unknown:
        raise ValueError(f"unknown reference key(s) {unknown}; registered: {', '.join(REGISTRY)}")
    return list(keys)


def check(
    keys: list[str] | None = None, *, path: str | Path = DEFAULT_PATH
) -> list[dict[str, Any]]:
    """Recompute registered values and compare with the stored ones.

    Returns one row per key: ``{"key", "stored", "recomputed", "rtol", "atol", "status"}`` with
    status ``ok``, ``drift``, ``missing`` (registered, not stored), ``unregistered`` (stored, not
    registered; only when ``keys`` is None) or ``error``.
    """
    stored = load(path)
    rows = []
    for key in _select(keys):
        entry = REGISTRY[key]
        row: dict[str, Any] = {"key": key, "rtol": entry.rtol, "atol": entry.atol}
        try:
            value = entry.compute()
        except Exception as exc:  # noqa: BLE001 - reported per key, never hidden
            rows.append({**row, "status": "error", "error": f"{type(exc).__name__}: {exc}"})
            continue
        row["recomputed"] = value
        if key not in stored:
            rows.append({**row, "status": "missing"})
            continue
        ref = float(stored[key]["value"])
        row["stored"] = ref
        ok = math.isclose(value, ref, rel_tol=entry.rtol, abs_tol=entry.atol)
        row["status"] = "ok" if ok else "drift"
        rows.append(row)
    if not keys:
        rows += [{"key": k, "status": "unregistered"} for k in stored if k not in REGISTRY]
    return rows


def update(keys: list[str] | None = None, *, path: str | Path = DEFAULT_PATH) -> dict[str, Any]:
    """Recompute ``keys`` (default all registered) and store them in ``path`` (atomic)."""
    stored = load(path)
    for key in _select(keys):
        entry = REGISTRY[key]
        stored[key] = {
            "value": entry.compute(),
            "rtol": entry.rtol,
            "atol": entry.atol,
            "method": entry.method,
            "recompute": f"roa check --only {key}",
            "function": entry.target,
            "kwargs": entry.kwargs,
        }
    atomic_write_json(path, dict(sorted(stored.items())))
    return stored
