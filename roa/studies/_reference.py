"""Regression values: a reference file (``results/reference.json``) and the functions that recompute them.

``roa check`` recomputes every stored value and exits non-zero naming each one that drifts beyond
its tolerance (or is missing, unregistered or fails); ``ipc_paper/tests/test_reference.py`` runs the same check.
The registry ``{key: Entry}`` belongs to a study (:mod:`roa.studies`); the functions here take it
as an argument and never read the working directory on their own.

How to add a value (one line in the study's registry)::

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

from roa.errors import ResultsError, RoaInputError
from roa.io import atomic_write_json


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


Registry = dict[str, Entry]


def load(path: str | Path, *, must_exist: bool = False) -> dict[str, Any]:
    """The stored values in ``path`` (``{}`` if absent, unless ``must_exist``)."""
    path = Path(path)
    if not path.is_file():
        if must_exist:
            raise ResultsError(
                f"reference file {path.resolve()} does not exist: run roa check from the "
                "project's checkout, or pass the reference file's path"
            )
        return {}
    try:
        data = json.loads(path.read_text())
    except (ValueError, RecursionError) as exc:  # bad JSON, not UTF-8, nested too deep
        raise ResultsError(f"{path}: not a readable JSON file ({type(exc).__name__})") from None
    if not isinstance(data, dict):
        raise ResultsError(
            f"{path}: expected a JSON object of stored values, got {type(data).__name__}"
        )
    return data


def _select(registry: Registry, keys: list[str] | None) -> list[str]:
    if not keys:
        return list(registry)
    unknown = [k for k in keys if k not in registry]
    if unknown:
        raise RoaInputError(
            f"unknown reference key(s) {unknown}; registered: {', '.join(registry)}"
        )
    return list(keys)


def check(
    registry: Registry, keys: list[str] | None = None, *, path: str | Path
) -> list[dict[str, Any]]:
    """Recompute registered values and compare with the stored ones.

    Returns one row per key: ``{"key", "stored", "recomputed", "rtol", "atol", "status"}`` with
    status ``ok``, ``drift``, ``missing`` (registered, not stored), ``unregistered`` (stored, not
    registered; only when ``keys`` is None) or ``error``.
    """
    stored = load(path, must_exist=True)
    rows = []
    for key in _select(registry, keys):
        entry = registry[key]
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
        stored_entry = stored[key]
        raw = stored_entry.get("value") if isinstance(stored_entry, dict) else None
        if isinstance(raw, bool) or not isinstance(raw, int | float) or not math.isfinite(raw):
            rows.append({**row, "status": "error",
                         "error": f"the stored value of {key} in {path} is not a finite number "
                                  f"({raw!r}): restore the file (git) or roa check --update"})  # fmt: skip
            continue
        ref = float(raw)
        row["stored"] = ref
        ok = math.isclose(value, ref, rel_tol=entry.rtol, abs_tol=entry.atol)
        row["status"] = "ok" if ok else "drift"
        rows.append(row)
    if not keys:
        rows += [{"key": k, "status": "unregistered"} for k in stored if k not in registry]
    return rows


def update(
    registry: Registry, keys: list[str] | None = None, *, path: str | Path
) -> dict[str, Any]:
    """Recompute ``keys`` (default all registered) and store them in ``path`` (atomic)."""
    stored = load(path)
    for key in _select(registry, keys):
        entry = registry[key]
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
