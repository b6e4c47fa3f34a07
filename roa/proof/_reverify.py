"""Re-verify a certificate read from a file before anything trusts it.

A certificate file (``roa certify --json``) says that ``{V <= level}`` is certified for a system.
Nothing in the file is believed: :func:`reverify` runs the interval validation
(:func:`roa.proof.validate_level`) for ``V`` and ``level`` on the system *as loaded*, so a
forged level, a scaled ``P``, an edited polynomial or a certificate of another system is refused
with the validation's reason (its refutation witness, re-checked at 50 digits, where there is
one). What a terminal set, an overlay or a report row then uses is what was proved here,
including the validation's own frame ``M`` (never the file's).

Proved results are cached by content: the key is the SHA-256 of the system's exact identity
(:func:`roa.model._fingerprint.system_identity`: states, equilibrium, parameters, the code and captured
values of its field and margin and the sources they may call), ``V``'s exact description, the
level's exact value and the hash of the library's code, so a change of any of them re-runs the
validation. A system or V that cannot be identified exactly (a function V, a field closing over
an object of unknown kind) is proved every time, never served from the cache. The cache
lives in ``$ROA_CACHE_DIR`` (default ``~/.cache/roa``) under ``verified/``. An entry holds the key,
the verdict, the validation record and an HMAC-SHA256 tag of them under the per-user key of
:func:`roa.io.cache_secret` (a 0600 file in the cache directory); an entry whose tag does not
check (written by hand, by another user, for another key, edited) is ignored and the level is
proved again. The cache trusts whoever can read that key: the user running ``roa`` (and root).
Without a usable key (a key file with loose permissions or another owner, a read-only cache)
nothing is cached.
"""

from __future__ import annotations

import functools
import hashlib
import json
import stat
import time
from dataclasses import dataclass, field
from typing import Any

from roa.io import cache_dir, cache_tag, tag_matches
from roa.lyapunov import Lyapunov
from roa.model._fingerprint import system_identity
from roa.model._system import System
from roa.options import IntervalOptions
from roa.status import Verdict


@dataclass(frozen=True)
class Reverified:
    """The verdict of a re-verification: ``status`` is ``certified`` only when proved here (or
    proved earlier for exactly this content, ``cached``)."""

    status: Verdict
    level: float
    message: str
    seconds: float
    cached: bool = False
    validation: dict[str, Any] = field(default_factory=dict)

    @property
    def certified(self) -> bool:
        return self.status is Verdict.CERTIFIED

    @property
    def frame(self) -> list[list[float]] | None:
        """The validation's frame ``M`` (``x = x_eq + M y``) of a non-quadratic V."""
        return self.validation.get("M")


@functools.lru_cache(maxsize=1)
def _code_stamp() -> str:
    from roa.io import code_hash

    return code_hash("roa")


def content_key(system: System, V: Lyapunov, level: float) -> str | None:
    """SHA-256 of what a re-verification depends on (see module doc), or None when it cannot be
    pinned down exactly: a system without an exact identity (:func:`system_identity`) or a V whose
    description does not determine it (a function V)."""
    identity = system_identity(system)
    if identity is None or not V.has_exact_description():
        return None
    data = {
        "system": identity,
        "V": V.describe(),
        "center": [float(c).hex() for c in V.center],
        "level": float(level).hex(),
        "code": _code_stamp(),
    }
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()


#: The purpose of the cache's tags (:func:`roa.io.cache_tag`).
TAG_PURPOSE = "roa-verified-v1"


def _entry(key: str, validation: Any) -> dict[str, Any]:
    """What a cache entry's tag covers: the key, the verdict and the validation record."""
    return {"key": key, "status": "certified", "validation": validation}


def _read(key: str) -> dict[str, Any] | None:
    """The cached proof of ``key``, if its tag checks (else None: proved again)."""
    path = cache_dir() / "verified" / f"{key}.json"
    try:
        if not stat.S_ISREG(path.lstat().st_mode):
            return None
        data = json.loads(path.read_text())
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    if not isinstance(data, dict) or data.get("key") != key or data.get("status") != "certified":
        return None
    validation = data.get("validation")
    if not isinstance(validation, dict):
        return None
    if not tag_matches(TAG_PURPOSE, _entry(key, validation), data.get("tag")):
        return None
    return data


def _write(key: str, validation: dict[str, Any]) -> None:
    """Remember the proof of ``key`` with its tag (nothing without a usable cache key)."""
    from roa.io import atomic_write_json, to_json

    try:
        record = json.loads(to_json(validation))  # what a later read will see
        tag = cache_tag(TAG_PURPOSE, _entry(key, record))
        if tag is not None:
            atomic_write_json(cache_dir() / "verified" / f"{key}.json",
                              {**_entry(key, record), "tag": tag})  # fmt: skip
    except (OSError, TypeError, ValueError):  # a read-only home: the proof stands, unremembered
        pass


def reverify(
    system: System,
    V: Lyapunov,
    level: float,
    *,
    interval: IntervalOptions | None = None,
    use_cache: bool = True,
    cover_estimate: Any = None,
) -> Reverified:
    """Prove (or fail to prove) ``{V <= level}`` for ``system`` by interval validation
    (``cover_estimate``: the proposal of a box for a V without a Gram matrix, see
    :func:`roa.proof.validate_level`).

    Never raises for a bad certificate: a level the validation cannot take (not finite, so large
    that the arithmetic overflows) is ``inconclusive`` with the reason.
    """
    from roa.proof._validate import validate_level

    t0 = time.perf_counter()
    lvl = float(level)
    key = content_key(system, V, lvl) if use_cache else None
    hit = _read(key) if key is not None else None
    if hit is not None:
        return Reverified(Verdict.CERTIFIED, lvl, "proved earlier for this exact content",
                          time.perf_counter() - t0, True, hit.get("validation", {}))  # fmt: skip
    opts = IntervalOptions() if interval is None else interval
    try:
        if system.parameters:  # every parameter of the box, as the certificate claims
            from roa.proof._robust import validate_robust

            v = validate_robust(system, V, lvl, max_boxes=opts.max_boxes, batch=opts.batch,
                                cover_estimate=cover_estimate)  # fmt: skip
        else:
            v = validate_level(system, V, lvl, max_boxes=opts.max_boxes, batch=opts.batch,
                               cover_estimate=cover_estimate)  # fmt: skip
    except (OverflowError, FloatingPointError, ZeroDivisionError) as exc:
        return Reverified(Verdict.INCONCLUSIVE, lvl,
                          f"the validation cannot take level {lvl!r} ({type(exc).__name__})",
                          time.perf_counter() - t0)  # fmt: skip
    record = v.to_json()
    out = Reverified(v.status, lvl, v.message, time.perf_counter() - t0, False, record)
    if key is not None and out.certified:
        _write(key, record)
    return out
