"""Resumable chunk files of a basin run: each chunk is bound to its run and checked on resume.

Each chunk file carries its binding: the run fingerprint, its start index, its length and a
SHA-256 of its arrays. On resume a chunk is used only if that binding matches this run and its
contents; any other chunk (rewritten, truncated or corrupt, of another run, with unknown status
codes) is rejected, deleted and recomputed by :mod:`roa.montecarlo._engine`.
"""

from __future__ import annotations

import hashlib
import io
import json
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from roa.errors import ResultsError, RoaInputError
from roa.integration import _integrator as I  # noqa: N812
from roa.io import atomic_write_bytes, atomic_write_json

#: Version of the chunk file layout (arrays ``code``, ``t_end`` and a JSON ``binding``).
CHUNK_FORMAT = 2
_CHUNK_NAME = re.compile(r"chunk_(\d+)\.npz")
VALID_CODES = (
    I.CONVERGED, I.LEFT_DOMAIN, I.DIVERGED, I.UNDECIDED, I.STEP_FAILURE, I.CONVERGED_ELSEWHERE
)  # fmt: skip


class ChunkRejectedWarning(RuntimeWarning):
    """Chunk files of a resumed run were not used (bad binding or contents) and are recomputed."""


def chunk_path(d: Path, start: int) -> Path:
    return d / f"chunk_{start:012d}.npz"


def chunk_digest(
    run: str, start: int, code: np.ndarray, t_end: np.ndarray, entered: int = 0
) -> str:
    """SHA-256 binding a chunk's arrays (and its count of runs that entered the terminal set) to
    its run fingerprint, start index and length."""
    tail = f"entered={int(entered)}/" if entered else ""
    h = hashlib.sha256(
        f"roa-chunk/{CHUNK_FORMAT}/{run}/{int(start)}/{int(code.size)}/{tail}".encode()
    )
    h.update(np.ascontiguousarray(code, dtype=np.int8).tobytes())
    h.update(np.ascontiguousarray(t_end, dtype="<f4").tobytes())
    return h.hexdigest()


def save_chunk(
    path: Path, run: str, start: int, code: np.ndarray, t_end: np.ndarray, entered: int = 0
) -> None:
    code = np.ascontiguousarray(code, dtype=np.int8)
    t_end = np.ascontiguousarray(t_end, dtype="<f4")
    binding = {
        "format": CHUNK_FORMAT,
        "run": run,
        "start": int(start),
        "length": int(code.size),
        "sha256": chunk_digest(run, start, code, t_end, entered),
    }
    if entered:
        binding["entered"] = int(entered)
    buf = io.BytesIO()
    np.savez(buf, code=code, t_end=t_end, binding=np.array(json.dumps(binding, sort_keys=True)))
    try:
        atomic_write_bytes(path, buf.getvalue())
    except OSError as exc:
        raise ResultsError(
            f"cannot write chunk file {path}: {exc.strerror or exc}; completed chunks were kept"
        ) from None


@dataclass
class _ChunkCheck:
    """Verdict on one chunk file: ``reason`` is None when it can be used as-is."""

    reason: str | None
    code: np.ndarray | None = None
    t_end: np.ndarray | None = None
    run: str | None = None  # the run it is bound to, when its binding is intact
    entered: int = 0  # runs of the chunk that entered the terminal set


def _read_chunk(path: Path, run: str, start: int, length: int) -> _ChunkCheck:
    """Load and verify one chunk file; never raises for a bad file (it is reported instead)."""
    try:
        with np.load(path, allow_pickle=False) as z:
            if "binding" not in z.files:
                return _ChunkCheck("no binding (older format or written by hand)")
            code, t_end, raw = z["code"], z["t_end"], z["binding"]
        binding = json.loads(str(raw.item()))
        b_run, b_start = str(binding["run"]), int(binding["start"])
        b_length, b_sha = int(binding["length"]), str(binding["sha256"])
        fmt = int(binding["format"])
        b_entered = int(binding.get("entered", 0))
    except Exception:  # noqa: BLE001 - truncated zip, bad arrays or JSON: any failure means unusable
        return _ChunkCheck("unreadable (truncated or corrupt)")
    if fmt != CHUNK_FORMAT:
        return _ChunkCheck(f"chunk format {fmt} (expected {CHUNK_FORMAT})")
    if code.dtype != np.int8 or t_end.dtype != np.dtype("<f4") or code.ndim != 1:
        return _ChunkCheck("wrong array types")
    if code.shape != t_end.shape or code.size != b_length:
        return _ChunkCheck("arrays do not match their recorded length")
    if chunk_digest(b_run, b_start, code, t_end, b_entered) != b_sha:
        return _ChunkCheck("checksum mismatch (contents changed)")
    if b_run != run:
        return _ChunkCheck("bound to another run", run=b_run)
    if b_start != start or b_length != length:
        return _ChunkCheck(f"bound to rows {b_start}..{b_start + b_length - 1}, not its place")
    if not np.isin(code, VALID_CODES).all():
        return _ChunkCheck("unknown status codes")
    if not (np.isfinite(t_end).all() and (t_end >= 0).all()):
        return _ChunkCheck("invalid stop times")
    if not 0 <= b_entered <= np.count_nonzero(code == I.CONVERGED):
        return _ChunkCheck("invalid count of runs that entered the certified set")
    return _ChunkCheck(None, code, t_end, b_run, b_entered)


def _read_run_file(run_file: Path) -> str | None:
    """The fingerprint stored in ``run.json``; None when absent or unreadable (then every chunk is
    judged by its own binding)."""
    try:
        data = json.loads(run_file.read_text())
        fp = data.get("fingerprint") if isinstance(data, dict) else None
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    return fp if isinstance(fp, str) else None


def _write_run_file(run_file: Path, digest: str, n: int, chunk_size: int) -> None:
    try:
        atomic_write_json(
            run_file,
            {"fingerprint": digest, "n": n, "chunk_size": chunk_size, "chunk_format": CHUNK_FORMAT},
        )
    except OSError as exc:
        raise ResultsError(f"cannot write {run_file}: {exc.strerror or exc}") from None


def _unlink(paths: list[Path]) -> None:
    for p in paths:
        try:
            p.unlink(missing_ok=True)
        except OSError as exc:
            raise ResultsError(f"cannot delete {p}: {exc.strerror or exc}") from None


def _chunk_files(chunk_dir: Path) -> list[Path]:
    return sorted(p for p in chunk_dir.glob("chunk_*.npz") if p.is_file())


def prepare_out_dir(
    out_dir: str | Path,
    digest: str,
    n: int,
    chunk_size: int,
    code: np.ndarray,
    t_end: np.ndarray,
    *,
    fresh: bool,
    replace_stale: bool,
    entered: list[int] | None = None,
) -> tuple[Path, set[int], dict[str, int]]:
    """Check the run directory, load every verified chunk into ``code``/``t_end``.

    Returns the chunk directory, the starts resumed, and the rejected chunks per reason (those
    files are deleted; their rows are recomputed). ``entered`` (a one-element list) accumulates
    the resumed runs that entered the terminal set.
    """
    chunk_dir = Path(out_dir) / "chunks"
    try:
        chunk_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RoaInputError(
            f"out_dir: cannot create {chunk_dir}: {exc.strerror or exc}; give a writable directory"
        ) from None
    run_file = chunk_dir / "run.json"
    if fresh:
        _unlink(_chunk_files(chunk_dir) + list(chunk_dir.glob(".chunk_*.tmp")))
        _write_run_file(run_file, digest, n, chunk_size)
        return chunk_dir, set(), {}
    old = _read_run_file(run_file)
    if old is not None and old != digest:
        if not replace_stale:
            raise ResultsError(
                f"{chunk_dir} holds chunks of a different run (other system, samples, tolerances, "
                "chunk size or code); use another output directory, delete it, or recompute it "
                "with fresh=True"
            )
        _unlink(_chunk_files(chunk_dir))
        _write_run_file(run_file, digest, n, chunk_size)
        return chunk_dir, set(), {}
    done: set[int] = set()
    rejected: list[tuple[Path, str]] = []
    foreign: set[str] = set()
    for path in _chunk_files(chunk_dir):
        m = _CHUNK_NAME.fullmatch(path.name)
        start = int(m.group(1)) if m else -1
        if start < 0 or start >= n or start % chunk_size:
            rejected.append((path, "not a chunk position of this run"))
            continue
        length = min(start + chunk_size, n) - start
        check = _read_chunk(path, digest, start, length)
        if check.reason is None:
            code[start : start + length], t_end[start : start + length] = check.code, check.t_end
            done.add(start)
            if entered is not None:
                entered[0] += check.entered
            continue
        if check.run is not None and check.run != digest:
            foreign.add(check.run)
        rejected.append((path, check.reason))
    if foreign and old is None and not replace_stale:
        # no run.json of this run, and intact chunks bound to another: the folder is another run's
        raise ResultsError(
            f"{chunk_dir} holds chunks of another run ({len(foreign)} other fingerprint(s); its "
            "run.json is missing or unreadable); use another output directory, delete it, or "
            "recompute it with fresh=True"
        )
    _unlink([p for p, _ in rejected])
    if old != digest:
        _write_run_file(run_file, digest, n, chunk_size)
    reasons: dict[str, int] = {}
    for _, why in rejected:
        reasons[why] = reasons.get(why, 0) + 1
    if rejected:
        detail = ", ".join(f"{k} {why}" for why, k in sorted(reasons.items()))
        warnings.warn(
            f"{chunk_dir}: {len(rejected)} chunk file(s) rejected and recomputed ({detail})",
            ChunkRejectedWarning,
            stacklevel=3,
        )
    return chunk_dir, done, reasons
