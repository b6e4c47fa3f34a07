"""Compiled kernels for any system whose field is written against ``xp``, cached on disk.

:func:`compiled_system` gives a system without a hand-written numba field a kernel factory
(``System.numba_fast``, a :class:`GeneratedKernels`): the field and margin traced once with sympy
(:mod:`roa.integration._trace`), compiled with the batch Dormand-Prince kernel
(:mod:`roa.integration._codegen`), and checked against the numpy field on sample states. When that
fails the numpy backend runs, and the reason (the term and why) is given once per system and
process as a :class:`KernelFallbackWarning`; the basin result records which backend ran.

Disk cache: the generated module is written to ``kernel_dir()/roa_kernel_<sha256>.py`` (the hash
of its text, so a changed field or integrator gives another file) and numba caches its compiled
code next to it (``cache=True``: keyed by that file). A kernel file is checked against its hash
whenever it is loaded: one that holds anything else (edited, truncated, empty, a link) is
rewritten, and the module runs from the checked text (:func:`load_module`). The index that maps
a field's code to its kernel's hash is believed only for entries tagged with the user's cache
key (:func:`roa.io.cache_tag`), so a forged entry naming an edited kernel is ignored. numba's
compiled code next to a kernel file is trusted as numba trusts it (keyed by that file's path,
modification time and size). The directory is ``$ROA_KERNEL_CACHE`` when
set, else ``kernels/`` in roa's cache directory (``$ROA_CACHE_DIR``, else ``~/.cache/roa``). A
first compilation prints a progress line on stderr (loads from the cache print nothing). With ``backend="auto"`` runs of fewer than :data:`COMPILE_FROM` initial
conditions stay on numpy.

Parameters are kernel arguments: :meth:`GeneratedKernels.with_params` keeps the compiled code
for other values (``System.at``, ``with_params``; the robust basin's parameter samples). The
factory pickles with the module's text, so a worker process (or a Dask worker on another
machine) writes the file if missing and loads the compiled code from its own cache.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import sys
import tempfile
import threading
import time
import types
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from roa.integration._code_identity import sources_digest
from roa.integration._dopri import KERNEL_DEPS
from roa.integration._trace import Untraceable, trace_system
from roa.io import atomic_write_json, atomic_write_text, cache_dir, cache_tag, tag_matches, to_json
from roa.model._system import System

#: Environment variable naming the kernel cache directory.
CACHE_ENV = "ROA_KERNEL_CACHE"
#: Seconds a compilation runs before its progress line is printed.
PROGRESS_AFTER = 0.5
#: With ``backend="auto"``, runs of fewer initial conditions stay on the numpy backend (at a
#: thousand or more runs per second there, less time than compiling a kernel the first time).
COMPILE_FROM = 2000
#: Backend labels recorded in basin results.
NUMPY, OWN, GENERATED = "numpy", "numba", "numba-generated"


class KernelFallbackWarning(UserWarning):
    """A system's field could not be compiled: the numpy backend runs (the message says why)."""


def kernel_dir() -> Path:
    """The directory of generated kernels: ``$ROA_KERNEL_CACHE``, else ``kernels/`` in roa's cache
    directory (``$ROA_CACHE_DIR``, else ``~/.cache/roa``)."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser()
    return cache_dir() / "kernels"


def _write_module(path: Path, text: str) -> None:
    """Make ``path`` a regular file holding exactly ``text``: a file holding anything else (edited,
    truncated, empty) or a link (to ``/dev/null``, to another file) is replaced atomically."""
    if _read_regular(path) != text.encode():
        atomic_write_text(path, text)


def _read_regular(path: Path) -> bytes | None:
    """The bytes of ``path`` if it is a regular file (not a link, device or pipe), else None."""
    try:
        if not stat.S_ISREG(path.lstat().st_mode):
            return None
        return path.read_bytes()
    except OSError:
        return None


def _private_tmp() -> Path:
    """A kernel directory under the system's temporary directory that only this user can write:
    ``roa-kernels-<uid>`` if it is a directory owned by this user and writable by no one else,
    else a fresh private directory (for this process)."""
    global _TMP
    if _TMP is None:
        d = Path(tempfile.gettempdir()) / f"roa-kernels-{os.getuid()}"
        try:
            d.mkdir(mode=0o700, exist_ok=True)
            st = d.lstat()
            ok = stat.S_ISDIR(st.st_mode) and st.st_uid == os.getuid() and not st.st_mode & 0o022
        except OSError:
            ok = False
        _TMP = d if ok else Path(tempfile.mkdtemp(prefix="roa-kernels-"))
    return _TMP


_TMP: Path | None = None


_MODULES: dict[str, Any] = {}
_LOCK = threading.Lock()


def load_module(text: str, digest: str) -> Any:
    """The generated module of ``text``, imported once per process.

    ``digest`` must be the SHA-256 of ``text`` (a ValueError otherwise). The file
    ``roa_kernel_<digest>.py`` is made to hold exactly ``text`` (rewritten when it holds anything
    else, :func:`_write_module`) and the module is executed from ``text`` itself, never from what
    the file holds when it is read again, so an edited kernel file never runs. The file is there
    for numba's cache (``cache=True``), which numba keys by the file's path, modification time and
    size: the compiled code numba stores next to it is trusted as numba trusts it."""
    if hashlib.sha256(text.encode()).hexdigest() != digest:
        raise ValueError(f"generated kernel text does not hash to {digest[:16]}...")
    name = f"roa_kernel_{digest[:32]}"
    with _LOCK:
        mod = _MODULES.get(name)
        if mod is not None:
            return mod
        path = kernel_dir() / f"{name}.py"
        try:
            _write_module(path, text)
        except OSError:  # cache not writable: a private temporary directory
            path = _private_tmp() / f"{name}.py"
            _write_module(path, text)
        code = compile(text, str(path), "exec")
        mod = types.ModuleType(name)
        mod.__file__ = str(path)
        sys.modules[name] = mod  # numba and Inlined look functions up by module name
        try:
            exec(code, mod.__dict__)  # noqa: S102 - roa's own generated text, hash-checked
        except BaseException:
            sys.modules.pop(name, None)
            raise
        _MODULES[name] = mod
        return mod


@dataclass(frozen=True)
class GeneratedKernels:
    """Factory of a generated kernel (``System.numba_fast``): ``kernels()`` returns ``(field,
    margin, params)`` (njit functions), :meth:`kernel` the compiled batch kernel and params.

    ``values`` are the values of the kernel's parameters ``names`` (``p0, p1, ...``)."""

    text: str
    digest: str
    system: str
    names: tuple[str, ...] = ()
    values: tuple[float, ...] = ()

    def __call__(self, coords: str | None = None) -> tuple[Any, Any, np.ndarray]:
        if coords is not None:
            raise KeyError(coords)  # no compiled map to other coordinates
        mod = load_module(self.text, self.digest)
        return mod.field, mod.margin, self.params

    @property
    def params(self) -> np.ndarray:
        return np.array(self.values, dtype=float)

    def kernel(self) -> tuple[Any, np.ndarray]:
        """``(run, params)``: the batch kernel of :mod:`roa.integration._codegen` (compiled now,
        or loaded from the cache, with a progress line on stderr while a compilation runs)."""
        mod = load_module(self.text, self.digest)
        if not mod.run.signatures:
            _warm_up(mod, self.system, len(self.values))
        return mod.run, self.params

    def with_params(self, values: Mapping[str, float]) -> GeneratedKernels | None:
        """The same kernel for other parameter values (None when the values are compiled in)."""
        if not self.names:
            return None if values else self
        return replace(self, values=tuple(float(values[k]) for k in self.names))


def _on_disk(dispatcher: Any) -> bool | None:
    """Whether numba's disk cache holds an index for ``dispatcher`` (None: cannot tell)."""
    try:
        return Path(dispatcher._cache._cache_file._index_path).exists()
    except AttributeError:  # numba internals changed
        return None


def _warm_up(mod: Any, name: str, n_params: int) -> None:
    """Compile (or load) ``mod.run`` for the argument types of an integration without a terminal
    set, with a progress line on stderr when it compiles (numba's cache has no index for it, or
    when that cannot be told, after :data:`PROGRESS_AFTER` seconds)."""
    from roa.integration._terminal import kernel_terminal

    n = int(mod.STATES)
    t0 = time.perf_counter()
    said = threading.Event()

    def say() -> None:
        said.set()
        print(f"roa: compiling the integrator for system {name!r} (once: cached in "
              f"{Path(mod.__file__).parent}) ...", file=sys.stderr, flush=True)  # fmt: skip

    cached = _on_disk(mod.run)
    timer = threading.Timer(PROGRESS_AFTER, say)
    timer.daemon = True
    if cached is False:
        say()
    elif cached is None:
        timer.start()
    try:
        x = np.zeros((1, n))
        code, t_end, steps = np.empty(1, np.int8), np.empty(1), np.empty(1, np.int64)
        mod.run(np.zeros(n_params), x, np.zeros(n), 1e-3, 1e6, 0.0, 1.0, 1e-6, 1e-9,
                kernel_terminal(None, n), code, t_end, x.copy(), steps)  # fmt: skip
    finally:
        timer.cancel()
    if said.is_set():
        print(f"roa: compiled in {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)


def check_against_numpy(system: System, factory: GeneratedKernels, *, seed: int = 0) -> None:
    """Compare the generated field (its Python source, uncompiled) with ``system.f`` on 32 states
    around the equilibrium (normal, scales 0.5 and 2; those inside the domain with a finite
    field); :class:`Untraceable` if they differ beyond ``1e-8 (1 + |f|_max)``."""
    mod = load_module(factory.text, factory.digest)
    n = system.n
    rng = np.random.default_rng(seed)
    center = system.x_eq if system.equilibrium is not None else np.zeros(n)
    X = center + rng.standard_normal((32, n)) * np.repeat([0.5, 2.0], 16)[:, None]
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ok = system.inside(X) if system.margin is not None else np.ones(len(X), bool)
        ref = system.f(X)
        ok &= np.isfinite(ref).all(axis=1)
        p = factory.params
        got = np.empty_like(ref)
        for k in np.flatnonzero(ok):
            mod.field.py_func(0.0, X[k], p, got[k])
    if not ok.any():
        return
    scale = 1.0 + np.abs(ref[ok]).max()
    bad = np.flatnonzero(~(np.abs(got[ok] - ref[ok]) <= 1e-8 * scale).all(axis=1))
    if bad.size:
        k = np.flatnonzero(ok)[bad[0]]
        raise Untraceable(
            f"the traced field differs from the numpy field at x = {X[k].tolist()} "
            f"({got[k].tolist()} vs {ref[k].tolist()}): does it branch on xp or on types?"
        )


#: The sources a generated kernel comes from besides :data:`roa.integration._dopri.KERNEL_DEPS`:
#: the integrator's (its kernel, ``run_rows``), the tracer's and the code generator's.
GENERATOR_SOURCES = ("_integrator.py", "_trace.py", "_codegen.py")


def kernel_stamp() -> str:
    """SHA-256 (first 16 hex digits) of the sources the generated kernels come from
    (:data:`roa.integration._dopri.KERNEL_DEPS` and :data:`GENERATOR_SOURCES`). Part of the
    generated text, so a change there (the step of dopri.py, the kernel of integrator.py) gives
    another text, another kernel file and a new compilation."""
    return sources_digest(Path(__file__).parent, KERNEL_DEPS + GENERATOR_SOURCES)[:16]


def _index_path(system: System) -> Path | None:
    """Where the digest of ``system``'s generated kernel is remembered, keyed by its field's and
    margin's code (:mod:`roa.integration._code_identity`); None when the code has no key."""
    from roa.integration._code_identity import code_key

    field = system.field
    func = getattr(field, "func", field)
    key = code_key(func, system.margin)
    if key is None:
        return None
    blob = repr((key, kernel_stamp(), system.n, tuple(system.params or {})))
    return kernel_dir() / "index" / f"{hashlib.sha256(blob.encode()).hexdigest()[:32]}.json"


def _from_index(system: System, path: Path | None) -> GeneratedKernels | None:
    """The kernel the index names for ``system``, if the entry's tag checks (written by roa with
    this user's key, :func:`roa.io.cache_tag`), its text is on disk, it was built for these
    parameter values (when they are compiled in) and it matches the numpy field; else None."""

    if path is None or not path.exists():
        return None
    try:
        entry = json.loads(path.read_text())
        body = {k: entry[k] for k in ("digest", "names", "baked")}
        if not tag_matches(INDEX_TAG, {"index": path.name, **body}, entry.get("tag")):
            return None
        digest, names = str(entry["digest"]), tuple(entry["names"])
        baked = {str(k): float(v) for k, v in entry["baked"].items()}
        raw = _read_regular(kernel_dir() / f"roa_kernel_{digest[:32]}.py")
        text = raw.decode() if raw is not None else ""
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
    params = dict(system.params or {})
    if hashlib.sha256(text.encode()).hexdigest() != digest or any(
        params.get(k) != v for k, v in baked.items()
    ):
        return None
    factory = GeneratedKernels(text, digest, system.name, names,
                               tuple(float(params[k]) for k in names))  # fmt: skip
    try:
        check_against_numpy(system, factory)
    except Untraceable:
        return None
    return factory


#: The purpose of the index entries' tags (:func:`roa.io.cache_tag`).
INDEX_TAG = "roa-kernel-index-v1"


def _remember(path: Path | None, factory: GeneratedKernels, baked: dict[str, float]) -> None:
    if path is None:
        return
    try:
        body = json.loads(to_json({"digest": factory.digest, "names": list(factory.names),
                                   "baked": baked}))  # fmt: skip
        tag = cache_tag(INDEX_TAG, {"index": path.name, **body})
        if tag is not None:
            atomic_write_json(path, {**body, "tag": tag})
    except (OSError, TypeError, ValueError):
        pass  # no index: the next process traces again


_TRACES: dict[Any, GeneratedKernels | Untraceable] = {}


def _key(system: System) -> Any:
    field = system.field
    func = getattr(field, "func", field)
    params = tuple(system.params or {})
    values = tuple((system.params or {}).values())
    key = (func, system.margin, system.n, system.equilibrium, params, values)
    try:
        hash(key)
    except TypeError:
        return None
    return key


def generate(system: System) -> GeneratedKernels:
    """The kernel factory of ``system``'s traced field (checked against numpy);
    :class:`Untraceable` with the reason if there is none. Cached per process, and on disk by
    the field's code (``kernel_dir()/index``: a later process finds the kernel without tracing,
    after the same check against numpy)."""
    from roa.integration._codegen import kernel_source

    key = _key(system)
    hit = _TRACES.get(key) if key is not None else None
    if hit is not None:
        if isinstance(hit, Untraceable):
            raise hit
        return hit.with_params(dict(system.params or {})) or hit
    index = _index_path(system)
    found = _from_index(system, index)
    if found is not None:
        if key is not None:
            _TRACES[key] = found
        return found
    try:
        try:
            trace = trace_system(system)
        except Untraceable:
            if not system.params:
                raise
            trace = trace_system(system, symbolic_params=False)  # values compiled in
        text = kernel_source(trace, system_name=system.name, stamp=kernel_stamp())
        digest = hashlib.sha256(text.encode()).hexdigest()
        values = tuple(float(system.params[k]) for k in trace.names)  # type: ignore[index]
        factory = GeneratedKernels(text, digest, system.name, trace.names, values)
        check_against_numpy(system, factory)
    except Untraceable as exc:
        if key is not None:
            _TRACES[key] = exc
        raise
    if key is not None:
        _TRACES[key] = factory
    _remember(index, factory, dict(trace.values))
    return factory


_WARNED: set[tuple[str, str]] = set()


def compiled_system(system: System, backend: str = "auto", terminal: Any = None,
                    n: int | None = None) -> tuple[System, str, str | None]:  # fmt: skip
    """``(system, label, note)``: the system to integrate (with a generated kernel factory when
    it has no numba field of its own and ``backend`` is ``auto`` or ``numba``), the backend that
    will run (:data:`OWN`, :data:`GENERATED` or :data:`NUMPY`) and, for a fallback to numpy, why.

    With ``backend="auto"``, a run of ``n`` < :data:`COMPILE_FROM` initial conditions stays on
    numpy (a first compilation costs seconds). ``backend="numba"`` raises
    :class:`roa.RoaInputError` where ``auto`` falls back."""
    from roa.errors import RoaInputError

    if backend == "numpy" or system.time == "discrete":  # a map is iterated with numpy
        return system, NUMPY, None
    if system.numba is not None or isinstance(system.numba_fast, GeneratedKernels):
        return system, (GENERATED if system.numba is None else OWN), None
    if system.numba_fast is not None:
        return system, OWN, None
    if backend == "auto" and n is not None and n < COMPILE_FROM:
        return system, NUMPY, None
    coords = getattr(terminal, "coords", None)
    try:
        if system.time_varying or system.equilibrium is None:
            raise Untraceable("basin kernels need an autonomous system with an equilibrium")
        if coords is not None:
            raise Untraceable(f"the terminal set lives in the coordinates {coords!r}, which a "
                              "generated kernel has no compiled map to")  # fmt: skip
        from roa.stage_limit import guard

        with guard(f"tracing the field of {system.name!r} with sympy for the basin kernel"):
            factory = generate(system)
    except Untraceable as exc:
        note = f"system {system.name!r}: {exc}; the numpy backend runs (slower)"
        if backend == "numba":
            raise RoaInputError(f"backend 'numba': {note}") from None
        if (system.name, note) not in _WARNED:
            _WARNED.add((system.name, note))
            warnings.warn(note, KernelFallbackWarning, stacklevel=3)
        return system, NUMPY, note
    return replace(system, numba_fast=factory), GENERATED, None
