"""Experiment configs (TOML) and their runners.

A config names its ``runner`` as ``"module:function"`` inside a registered study's package
(:mod:`roa.studies`; a config is data and cannot name any other code), an optional ``title`` and a
``[params]`` table, and optionally ``[quick]`` overrides used by ``--quick``. A runner has the signature
``run(params: dict, out: Path, *, quick: bool) -> dict`` and declares its ``[params]`` with
``@accepts(ParamsClass)``, a frozen :class:`roa.options.Options` dataclass holding the defaults: the
config's params are built into it before any work starts (unknown keys and bad values are rejected)
and the runner gets its ``to_dict()``. A runner returns a JSON-able summary with, where it has
something to say about the paper, a list ``claims`` of rows for ``paper_repro.md``::

    {"id": "F1", "claim": "...", "paper": "...", "ours": "...",
     "verdict": "reproduced" | "not reproduced" | "erratum" | "beyond the paper",
     "evidence": "results/NAME/file.json", "details": "markdown (optional)"}

and a list ``figures`` of PNG paths relative to the repository root.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import json
import re
import time
import tomllib
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from roa import numparse
from roa.errors import RoaInputError
from roa.io import atomic_write_json, code_hash, git_revision, package_versions
from roa.options import Options
from roa.studies import _registry as studies

Runner = Callable[..., dict[str, Any]]

VERDICTS = ("reproduced", "not reproduced", "erratum", "beyond the paper", "inconclusive")


def accepts(params_class: type[Options]) -> Callable[[Runner], Runner]:
    """Declare the ``[params]`` of a runner as a frozen :class:`roa.options.Options` dataclass.

    :func:`run_experiment` builds ``params_class`` from the config's ``[params]`` (with ``[quick]``
    overrides) before any work starts -- unknown keys, missing required keys and invalid values are
    rejected by the dataclass -- and passes the runner ``instance.to_dict()``: every key, with its
    default filled in (TOML arrays as tuples)::

        @dataclass(frozen=True, kw_only=True)
        class Figure1Params(Options):
            t_final: float = 20.0

        @accepts(Figure1Params)
        def run_figure1(params: dict, out: Path, *, quick: bool) -> dict: ...
    """
    if not (
        isinstance(params_class, type)
        and issubclass(params_class, Options)
        and dataclasses.is_dataclass(params_class)
        and params_class.__dataclass_params__.frozen  # type: ignore[attr-defined]
    ):
        raise TypeError(
            "@accepts takes a frozen dataclass subclass of roa.options.Options, "
            f"got {params_class!r}"
        )

    def mark(func: Runner) -> Runner:
        func.params = params_class  # type: ignore[attr-defined]
        return func

    return mark


def _value(params: Any, name: str) -> Any:
    return params[name] if isinstance(params, Mapping) else getattr(params, name)


#: Largest seed accepted by :func:`check_int` callers (numpy takes any; 2^63 - 1 is plenty).
MAX_SEED = 2**63 - 1


def check_int(params: Any, name: str, lo: int = 0, hi: int | None = None) -> None:
    """For a params class's ``__post_init__``: field ``name`` must be an integer ``>= lo`` (and
    ``<= hi``: every count that sizes an array has one, so a huge value is refused before work).

    ``params`` is the params instance or a mapping (e.g. ``{"grid[0]": value}``); the same holds
    for :func:`check_number` and :func:`check_numbers`.
    """
    value = _value(params, name)
    if (
        isinstance(value, bool)
        or not isinstance(value, int)
        or value < lo
        or (hi is not None and value > hi)
    ):
        allowed = f">= {lo}" if hi is None else f"in [{lo}, {hi}]"
        raise RoaInputError(f"{name} must be an integer {allowed}, got {numparse.shown(value)}")


def _finite(v: Any, positive: bool) -> bool:
    try:
        numparse.value(v, "")
    except RoaInputError:
        return False
    return v > 0 or not positive


def check_number(params: Any, name: str, *, positive: bool = False) -> None:
    """For a params class's ``__post_init__``: field ``name`` must be a finite number (``> 0``)."""
    value = _value(params, name)
    if not _finite(value, positive):
        raise RoaInputError(
            f"{name} must be a finite number{' > 0' if positive else ''}, got "
            f"{numparse.shown(value)}"
        )


def check_numbers(
    params: Any, name: str, *, size: int | None = None, positive: bool = False
) -> None:
    """For a params class's ``__post_init__``: field ``name`` must be a list of finite numbers
    (``> 0``), of length ``size`` if given."""
    value = _value(params, name)
    ok = isinstance(value, list | tuple) and (size is None or len(value) == size)
    if not (ok and all(_finite(v, positive) for v in value)):
        what = "a list of" + ("" if size is None else f" {size}") + " finite numbers"
        raise RoaInputError(f"{name} must be {what}{' > 0' if positive else ''}, got {value!r}")


def build_params(name: str, params_class: type[Options], params: dict[str, Any]) -> Options:
    """``params_class`` built from ``params``; every problem is a :class:`RoaInputError` naming ``name``."""
    where = f"{name}: [params]"
    fields = dataclasses.fields(params_class)  # type: ignore[arg-type]
    allowed = ", ".join(f.name for f in fields)
    required = [
        f.name
        for f in fields
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    ]
    missing = [k for k in required if k not in params]
    unknown = sorted(set(params) - {f.name for f in fields})
    if unknown and not fields:
        raise RoaInputError(
            f"{where}: unknown option(s) {unknown} for {params_class.__name__}; it takes no params"
        )
    if missing and not unknown:
        raise RoaInputError(
            f"{where}: missing required option(s) {missing} for {params_class.__name__}; "
            f"allowed: {allowed}"
        )
    try:
        return params_class.from_mapping(params, where=where)
    except ValueError as exc:  # RoaInputError, or e.g. float("x") in a params class's checks
        if isinstance(exc, RoaInputError) and str(exc).startswith(where):
            raise
        raise RoaInputError(f"{where}: {exc}") from exc


def check_params(name: str, runner: Runner, params: dict[str, Any]) -> dict[str, Any]:
    """Validate ``params`` against the runner's declared params; return what the runner gets.

    With ``@accepts(ParamsClass)``: ``ParamsClass.from_mapping(params).to_dict()`` (defaults filled
    in), so unknown keys are rejected by the dataclass before any work starts.
    """
    declared = getattr(runner, "params", None)
    if isinstance(declared, type) and issubclass(declared, Options):
        return build_params(name, declared, params).to_dict()
    raise RoaInputError(
        f"{name}: runner {runner.__name__} does not declare its params (@accepts(ParamsClass))"
    )


def load_config(path: str | Path) -> dict[str, Any]:
    """Read and validate an experiment config."""
    path = Path(path)
    if not path.is_file():
        raise RoaInputError(f"experiment config {path} does not exist")
    try:
        cfg = tomllib.loads(path.read_text(),
                            parse_float=lambda s: numparse.parse_number(s, "a number"))  # fmt: skip
    except tomllib.TOMLDecodeError as exc:
        raise RoaInputError(f"experiment config {path}: invalid TOML: {exc}") from exc
    except RoaInputError as exc:
        raise RoaInputError(f"experiment config {path}: {exc}") from None
    except ValueError as exc:  # an integer beyond Python's int-string limit
        raise RoaInputError(
            f"experiment config {path}: a number is too long ({str(exc).split(';')[0]})"
        ) from None
    except (UnicodeDecodeError, RecursionError) as exc:
        raise RoaInputError(
            f"experiment config {path}: not readable ({type(exc).__name__})"
        ) from None
    runner = cfg.get("runner")
    module_re = r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*"
    if not isinstance(runner, str) or not re.fullmatch(module_re + r":[A-Za-z_]\w*", runner):
        raise RoaInputError(
            f"experiment config {path}: runner must be 'module:function', got {runner!r}"
        )
    if not studies.runner_allowed(runner):
        raise RoaInputError(
            f"experiment config {path}: runner {runner!r} is not in a registered study's package "
            f"({', '.join(s.package for s in studies.registered().values())})"
        )
    params = cfg.get("params", {})
    quick = cfg.get("quick", {})
    if not isinstance(params, dict) or not isinstance(quick, dict):
        raise RoaInputError(f"experiment config {path}: [params] and [quick] must be tables")
    depends = cfg.get("depends", [])
    if not isinstance(depends, list) or not all(isinstance(d, str) for d in depends):
        raise RoaInputError(f"experiment config {path}: depends must be a list of experiment names")
    order = cfg.get("order", 100)
    if isinstance(order, bool) or not isinstance(order, int) or not -(10**6) <= order <= 10**6:
        raise RoaInputError(
            f"experiment config {path}: order must be an integer in [-1e6, 1e6], got {order!r}"
        )
    unknown = set(cfg) - {"runner", "title", "params", "quick", "order", "depends"}
    if unknown:
        raise RoaInputError(f"experiment config {path}: unknown keys {sorted(unknown)}")
    cfg.setdefault("title", path.stem)
    cfg["name"] = path.stem
    return cfg


def config_hash(cfg: dict[str, Any], quick: bool, results: Path) -> str:
    """Cache key: the config, the mode, the package code and the summaries of ``depends``."""
    inputs = {}
    for dep in cfg.get("depends", []):
        summary = results / dep / "summary.json"
        inputs[dep] = (
            hashlib.sha256(summary.read_bytes()).hexdigest() if summary.is_file() else None
        )
    blob = json.dumps(
        {
            "cfg": cfg,
            "quick": quick,
            "code": code_hash(),
            "study_code": code_hash(cfg["runner"].split(":")[0].split(".")[0]),
            "inputs": inputs,
        },
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(blob.encode()).hexdigest()


def run_experiment(
    path: str | Path,
    *,
    results: str | Path = "results",
    quick: bool = False,
    force: bool = False,
) -> dict[str, Any]:
    """Run one experiment config into ``results/NAME/``; skip if cached (same config and code)."""
    cfg = load_config(path)
    out = Path(results) / cfg["name"]
    for dep in cfg.get("depends", []):
        if not (Path(results) / dep / "summary.json").is_file():
            raise RoaInputError(
                f"experiment {cfg['name']} depends on {dep!r}: run experiments/{dep}.toml first "
                f"(no {Path(results) / dep / 'summary.json'})"
            )
    digest = config_hash(cfg, quick, Path(results))
    manifest_path = out / "manifest.json"
    old: dict[str, Any] = {}
    if manifest_path.is_file():
        try:
            old = json.loads(manifest_path.read_text())
        except (ValueError, RecursionError):  # bad JSON or not UTF-8: an unusable manifest
            old = {}
        if not isinstance(old, dict):
            old = {}
    source = str(Path(path).resolve())
    if old and not force and old.get("config_path") not in (None, source):
        same = {k: v for k, v in old.get("config", {}).items() if k != "name"} == {
            k: v for k, v in cfg.items() if k != "name"
        }
        if not same:
            raise RoaInputError(
                f"{out} holds the results of another config ({old['config_path']}); this one is "
                f"{source}: use another results directory, or force=True (--force) to replace them"
            )
    if not force and old.get("hash") == digest and not verify_outputs(out, old):
        summary = json.loads((out / "summary.json").read_text())
        summary["cached"] = True
        return summary
    params = dict(cfg.get("params", {}))
    if quick:
        params.update(cfg.get("quick", {}))
    module, func = cfg["runner"].split(":")
    try:
        runner = getattr(importlib.import_module(module), func, None)
    except ImportError as exc:
        raise RoaInputError(f"experiment {cfg['name']}: runner module {module!r}: {exc}") from None
    if runner is None or not callable(runner):
        raise RoaInputError(f"experiment {cfg['name']}: {module} has no runner {func!r}")
    params = check_params(cfg["name"], runner, params)
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    try:
        summary = runner(params, out, quick=quick)
    except BaseException:
        if created and not any(out.iterdir()):  # a failed run leaves no empty results folder
            out.rmdir()
        raise
    elapsed = time.perf_counter() - t0
    for claim in summary.get("claims", []):
        if claim.get("verdict") not in VERDICTS:
            raise RoaInputError(
                f"{cfg['name']}: claim {claim.get('id')} has verdict {claim.get('verdict')!r}"
            )
    summary = {"experiment": cfg["name"], "title": cfg["title"], "quick": quick, **summary}
    atomic_write_json(out / "summary.json", summary)
    atomic_write_json(
        manifest_path,
        {
            "experiment": cfg["name"],
            "config": cfg,
            "quick": quick,
            "hash": digest,
            "config_path": source,
            "outputs": output_hashes(out),
            "git_revision": git_revision(),
            "versions": package_versions(),
            "elapsed_s": round(elapsed, 3),
            "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        },
    )
    summary["cached"] = False
    return summary


def _scratch(rel: str) -> bool:
    """Resumable chunk files (in any ``chunks/`` folder of an experiment, git-ignored): scratch of
    a run, not among its results (the summary records what they held)."""
    return "chunks" in rel.split("/")[:-1]


def output_hashes(out: Path) -> dict[str, str]:
    """SHA-256 of every file an experiment wrote (but its manifest and resumable chunks)."""
    hashes = {}
    for f in sorted(out.rglob("*")):
        rel = f.relative_to(out).as_posix()
        if f.is_file() and rel != "manifest.json" and not _scratch(rel):
            hashes[rel] = hashlib.sha256(f.read_bytes()).hexdigest()
    return hashes


def verify_outputs(out: Path, manifest: dict[str, Any] | None = None) -> list[str]:
    """Problems with the outputs of ``out`` against its manifest (empty when they are intact).

    A file changed, missing or unrecorded since the run is named; a manifest without recorded
    hashes (written before they existed) is one problem: its outputs cannot be verified.
    """
    if manifest is None:
        try:
            manifest = json.loads((out / "manifest.json").read_text())
        except (OSError, ValueError, RecursionError):  # ValueError: bad JSON or not UTF-8
            return [f"{out}/manifest.json is missing or unreadable"]
    if not isinstance(manifest, dict):
        return [f"{out}/manifest.json is not a manifest (a JSON object): re-run the experiment"]
    recorded = manifest.get("outputs")
    if not isinstance(recorded, dict):
        return [f"{out}/manifest.json records no output hashes: re-run the experiment"]
    if "summary.json" not in recorded:
        return [f"{out}: no summary.json recorded"]
    now = output_hashes(out)
    recorded = {k: v for k, v in recorded.items() if not _scratch(k)}  # older manifests had them
    problems = [
        f"{out}/{name} was modified after its run"
        for name in recorded
        if now.get(name) not in (None, recorded[name])
    ]
    problems += [f"{out}/{name} is missing" for name in recorded if name not in now]
    return problems


def list_experiments(directory: str | Path = "experiments") -> list[Path]:
    """Experiment configs in run order (``order`` key, then name)."""
    paths = sorted(Path(directory).glob("*.toml"))

    def key(p: Path) -> tuple[int, str]:
        try:
            return (int(tomllib.loads(p.read_text()).get("order", 100)), p.name)
        except (tomllib.TOMLDecodeError, UnicodeDecodeError, TypeError, ValueError, OverflowError):
            return (100, p.name)  # load_config names the problem when the config is run

    return sorted(paths, key=key)


def experiments_dir(study: studies.Study) -> Path:
    """A study's configs: ``./experiments`` if present (a checkout), else the study's own copy."""
    local = Path("experiments")
    if local.is_dir() and any(local.glob("*.toml")):
        return local
    return study.experiments


def write_report(study: studies.Study, results: str | Path, out: str | Path) -> Path:
    """Render the study's report from ``results`` and write it atomically to ``out``."""
    from roa.io import atomic_write_text

    return atomic_write_text(out, study.render_report(results, out))
