"""Atomic writes and run manifests: a result file is either whole or absent; the cache's key.

Cache entries that decide a result (proved levels, :mod:`roa.proof._reverify`; the index of
generated kernels, :mod:`roa.integration._kernel_cache`) carry an HMAC-SHA256 tag under a per-user
key (:func:`cache_secret`, a 0600 file in the cache directory). An entry whose tag does not
check is ignored, so a file written into the cache by someone who cannot read the key (another
user of a shared cache directory, a tool, a hand-written JSON) is never believed. Whoever can
read the key (the user's own processes, root) can forge entries, as they can edit roa itself.
"""

from __future__ import annotations

import contextlib
import hashlib
import hmac
import json
import os
import platform
import stat
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from importlib import metadata
from pathlib import Path
from typing import Any

#: The distribution name of this package (pyproject's ``[project] name``); its import name is
#: ``roa``. The distribution "roa" on PyPI is an unrelated project, so it is never looked up.
DISTRIBUTION = "roa-verify"

PACKAGES = (
    DISTRIBUTION,
    "numpy",
    "scipy",
    "sympy",
    "cvxpy",
    "clarabel",
    "casadi",
    "matplotlib",
    "joblib",
    "numba",
)


def _default(obj: Any) -> Any:
    import numpy as np

    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "value") and hasattr(obj, "name"):  # enums
        return obj.value
    raise TypeError(f"cannot serialise {type(obj).__name__} to JSON")


def _finite(obj: Any) -> Any:
    """A copy with every non-finite float (inf, NaN) replaced by ``None`` (JSON has neither)."""
    import numpy as np

    if isinstance(obj, float | np.floating):
        return float(obj) if np.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_finite(v) for v in obj]
    if isinstance(obj, np.ndarray) and obj.dtype.kind == "f":
        return [_finite(v) for v in obj.tolist()]
    return obj


def to_json(obj: Any) -> str:
    """Strict JSON: non-finite numbers become ``null`` (the result's status says why)."""
    return json.dumps(_finite(obj), indent=2, default=_default, allow_nan=False, sort_keys=False)


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file and an atomic rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp creates 0600; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def cache_dir() -> Path:
    """roa's cache directory (``$ROA_CACHE_DIR``, else ``~/.cache/roa``)."""
    root = os.environ.get("ROA_CACHE_DIR")
    return Path(root) if root else Path.home() / ".cache" / "roa"


#: The file in :func:`cache_dir` holding the key that tags cache entries (:func:`cache_tag`).
SECRET_NAME = "secret.key"
#: Bytes of that key.
SECRET_BYTES = 32


def cache_secret() -> bytes | None:
    """The per-user key of roa's cache (``cache_dir()/secret.key``), created on first use; None
    when there is none to trust.

    The key is :data:`SECRET_BYTES` random bytes in a regular file owned by this user with no
    permission for group or others (created with mode 0600). A key file that is a link, is owned
    by another user, is readable or writable by others, or has another length is not used, and
    nothing in the cache is then believed (the caches compute again).
    """
    path = cache_dir() / SECRET_NAME
    for attempt in range(2):
        try:
            fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
        except FileNotFoundError:
            if attempt == 0 and _create_secret(path):
                continue
            return None
        except OSError:  # a link (ELOOP), unreadable, ...
            return None
        try:
            st = os.fstat(fd)
            if not stat.S_ISREG(st.st_mode) or st.st_uid != os.getuid() or st.st_mode & 0o077:
                return None
            data = os.read(fd, SECRET_BYTES + 1)
        except OSError:
            return None
        finally:
            os.close(fd)
        return data if len(data) == SECRET_BYTES else None
    return None


def _create_secret(path: Path) -> bool:
    """Create the key file whole (written to a private temporary file, then hard-linked into
    place, which fails if another process created it first); False if it cannot be created."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")  # mode 0600
    except OSError:
        return False
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(os.urandom(SECRET_BYTES))
            fh.flush()
            os.fsync(fh.fileno())
        try:
            os.link(tmp, path)
        except FileExistsError:
            pass  # another process's key: that one is used
        return True
    except OSError:
        return False
    finally:
        Path(tmp).unlink(missing_ok=True)


def _canonical(purpose: str, payload: Any) -> bytes:
    body = json.dumps(payload, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return purpose.encode() + b"\0" + body.encode()


def cache_tag(purpose: str, payload: Any) -> str | None:
    """HMAC-SHA256 with :func:`cache_secret` of ``payload`` (JSON data, as read back from a file)
    for ``purpose`` (entries of one cache never pass for another's); None without a key."""
    key = cache_secret()
    if key is None:
        return None
    return hmac.new(key, _canonical(purpose, payload), hashlib.sha256).hexdigest()


def tag_matches(purpose: str, payload: Any, tag: Any) -> bool:
    """Whether ``tag`` is :func:`cache_tag` of ``payload`` (False without a key or for a payload
    that is not JSON data)."""
    try:
        want = cache_tag(purpose, payload)
    except (TypeError, ValueError):
        return False
    return want is not None and isinstance(tag, str) and hmac.compare_digest(want, tag)


def atomic_write_text(path: str | Path, text: str) -> Path:
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | Path, obj: Any) -> Path:
    return atomic_write_text(path, to_json(obj) + "\n")


@contextlib.contextmanager
def folder_lock(folder: str | Path, what: str) -> Iterator[None]:
    """Hold an exclusive lock on ``folder`` (its ``.lock`` file, flock) for the block; another
    process holding it is an input error naming ``what`` (never two runs mixing one folder)."""
    import fcntl

    from roa.errors import RoaInputError

    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd = os.open(folder / ".lock", os.O_RDWR | os.O_CREAT, 0o666 & ~_umask())
    except OSError as exc:
        raise RoaInputError(
            f"{what}: cannot create {folder}: {exc.strerror or exc}; give a writable directory"
        ) from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise RoaInputError(
                f"{what} {folder.parent}: in use by another run (lock {folder / '.lock'}); wait "
                "for it to end or choose another folder"
            ) from None
        yield
    finally:
        os.close(fd)  # closing releases the lock


#: Figure formats :func:`atomic_savefig` writes (by the file's extension).
FIGURE_FORMATS = ("png", "pdf", "svg", "jpg", "jpeg", "eps", "ps", "tif", "tiff", "webp")


def check_figure_path(path: str | Path, what: str = "--plot") -> Path:
    """``path`` as a figure file to (over)write: a regular file or a new name in an existing
    directory, with a known extension; else an input error naming ``what``."""
    from roa.errors import RoaInputError

    p = Path(path)
    ext = p.suffix.lstrip(".").lower()
    if ext not in FIGURE_FORMATS:
        raise RoaInputError(
            f"{what} {path}: the extension must be one of {', '.join(FIGURE_FORMATS)}, got "
            f"{p.suffix or 'none'}"
        )
    if p.exists() and not p.is_file():
        raise RoaInputError(f"{what} {path}: exists and is not a regular file (never replaced)")
    if not p.parent.is_dir() and p.parent.exists():
        raise RoaInputError(f"{what} {path}: {p.parent} is not a directory")
    return p


def atomic_savefig(fig: Any, path: str | Path, **kwargs: Any) -> Path:
    """Save a matplotlib figure atomically (PNG by default); never replaces a non-regular file."""
    import io

    check_figure_path(path, "figure")
    buf = io.BytesIO()
    kwargs.setdefault("dpi", 130)
    kwargs.setdefault("bbox_inches", "tight")
    fig.savefig(buf, format=Path(path).suffix.lstrip(".") or "png", **kwargs)
    return atomic_write_bytes(path, buf.getvalue())


def git_revision() -> str | None:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=5,
            cwd=Path(__file__).resolve().parent,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None if out.returncode == 0 else None


def package_versions() -> dict[str, str | None]:
    """Installed versions of Python, the platform and :data:`PACKAGES` (None when not installed).

    This package is reported under ``"roa"`` with the version of the distribution
    :data:`DISTRIBUTION` (None when ``roa`` runs from a source tree that is not installed): an
    unrelated distribution named ``roa`` is never reported as this one.
    """
    versions: dict[str, str | None] = {
        "python": sys.version.split()[0],
        "platform": platform.platform(),
    }
    for name in PACKAGES:
        key = "roa" if name == DISTRIBUTION else name
        try:
            versions[key] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[key] = None
    return versions


def code_hash(package: str = "roa") -> str:
    """SHA-256 of a package's source files: a change of code invalidates cached experiment runs."""
    import importlib

    h = hashlib.sha256()
    mod = importlib.import_module(package)
    root = Path(mod.__file__ or "").resolve().parent
    for path in sorted(root.rglob("*.py")):
        h.update(str(path.relative_to(root)).encode())
        h.update(path.read_bytes())
    return h.hexdigest()
