"""A content-addressed cache of Lyapunov-function *searches* (candidates, not certificates).

The search of :func:`roa.search.optimise_quadratic` takes minutes; its result is only a
candidate ``P``, which is certified afterwards by the interval validation, recomputed on every
run. Reusing a cached ``P`` therefore never weakens a certificate: a stale candidate could only
give a smaller certified region, never an unsound one. The key is a SHA-256 of the search inputs
(system name, objective, start matrix, options) and of the source of :mod:`roa.search._quadratic`,
so a change of the search recomputes. Changes elsewhere (the level search it calls, the system)
do not: they can only make the cached candidate suboptimal, and its certificate is redone anyway.

The cache is one JSON file (written atomically); :meth:`SearchCache.save` keeps only the entries
used in the current run. Each entry carries the SHA-256 of its key and result: an entry edited by
hand (e.g. a replaced P) no longer matches and is recomputed, never used silently
(:attr:`SearchCache.rejected` counts them).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from roa.io import atomic_write_json, to_json


def _plain(obj: Any) -> Any:
    """JSON-compatible copy (numpy arrays -> lists; floats round-trip exactly)."""
    return json.loads(to_json(obj))


def _source_hash() -> str:
    import roa.search._quadratic as search

    return hashlib.sha256(Path(search.__file__).read_bytes()).hexdigest()


def _checksum(digest: str, entry: dict[str, Any]) -> str:
    blob = json.dumps({"digest": digest, "key": entry.get("key"), "result": entry.get("result")},
                      sort_keys=True)  # fmt: skip
    return hashlib.sha256(blob.encode()).hexdigest()


class SearchCache:
    """``get(key, compute)``: the cached result for ``key`` or ``compute()`` (then stored).

    Parameters
    ----------
    path : Path
        The JSON file (created on :meth:`save`).
    enabled : bool
        ``False`` recomputes every search (the file is still rewritten by :meth:`save`).
    """

    def __init__(self, path: str | Path, *, enabled: bool = True) -> None:
        self.path = Path(path)
        self.enabled = bool(enabled)
        self._old: dict[str, Any] = {}
        if self.enabled and self.path.is_file():
            try:
                self._old = json.loads(self.path.read_text())
            except json.JSONDecodeError:
                self._old = {}
        self._used: dict[str, Any] = {}
        self._code = _source_hash()
        self.rejected = 0
        # a file written before entries carried checksums is accepted once (then re-saved with
        # them); in a file with checksums, an entry without one is rejected like a wrong one
        self._legacy = not any(isinstance(e, dict) and "checksum" in e for e in self._old.values())

    def digest(self, key: dict[str, Any]) -> str:
        blob = json.dumps({"key": _plain(key), "code": self._code}, sort_keys=True)
        return hashlib.sha256(blob.encode()).hexdigest()

    def lookup(self, key: dict[str, Any]) -> dict[str, Any] | None:
        """The cached result for ``key`` (kept for :meth:`save`), or ``None``: then compute it
        (possibly in another process) and :meth:`store` it."""
        d = self.digest(key)
        entry = self._old.get(d)
        legacy = entry is not None and self._legacy and "checksum" not in entry
        if entry is not None and not legacy and entry.get("checksum") != _checksum(d, entry):
            self.rejected += 1  # edited or corrupted: recompute rather than trust it
            entry = None
        if entry is None:
            return None
        self._used[d] = {**entry, "checksum": _checksum(d, entry)}
        return self._used[d]["result"]

    def store(self, key: dict[str, Any], result: dict[str, Any]) -> dict[str, Any]:
        """Keep ``result`` for ``key`` (written by :meth:`save`); returns its JSON form."""
        d = self.digest(key)
        entry = {"key": _plain(key), "result": _plain(result)}
        self._used[d] = {**entry, "checksum": _checksum(d, entry)}
        return self._used[d]["result"]

    def get(
        self, key: dict[str, Any], compute: Callable[[], dict[str, Any]]
    ) -> tuple[dict[str, Any], bool]:
        """``(result, hit)``; ``result`` is the JSON dict ``compute()`` returned (or its cache)."""
        res = self.lookup(key)
        if res is not None:
            return res, True
        return self.store(key, compute()), False

    def save(self) -> None:
        atomic_write_json(self.path, self._used)
