"""``roa check --recompute``: run experiments again and compare their stored summaries with the new ones.

Why: a manifest's SHA-256 hashes detect corruption and stale results, not deliberate edits (whoever
edits a summary can recompute its hash). Recomputing trusts neither the summary nor its hash: the
experiment's config is run again, in the mode of the stored run (``quick`` or full), into a
temporary results directory, and every value of the stored ``summary.json`` is compared with the
recomputed one. The run happens with a scratch folder as its working directory, its results
folder named ``results`` as in a checkout, so that the paths a summary names are the same.

Claims and assumptions:

* Numbers agree when ``math.isclose(rel_tol=RTOL, abs_tol=ATOL)``; numbers inside strings (claims'
  texts) are compared the same way, the rest of a string exactly; booleans, None and list lengths
  exactly; a key present on one side only is a difference.
* Keys that describe how a run went rather than what it found are not compared (:data:`VOLATILE`:
  timings, chunk bookkeeping, the cache flag).
* The results of an experiment's ``depends`` are copied as they are into the temporary directory
  (recompute them on their own to check them; certificate files among them are re-verified
  wherever they are used). Experiments whose computation is not reproducible bit for bit (the
  cutting-plane search of V, README) can differ beyond the tolerance: such a row says ``differs``,
  which means "not confirmed", and names the first differences.
"""

from __future__ import annotations

import contextlib
import json
import math
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

from roa.errors import ResultsError, RoaInputError

#: Relative and absolute tolerance for numbers.
RTOL = 1e-6
ATOL = 1e-12
#: Keys describing the run, not its findings (and any key ending in ``_s``: seconds).
VOLATILE = frozenset(
    {"cached", "seconds", "chunks_computed", "chunks_resumed", "chunks_rejected", "n_jobs_used"}
)
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def _volatile(key: str) -> bool:
    return key in VOLATILE or key.endswith("_s")


def _close(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=RTOL, abs_tol=ATOL)


def _same_text(a: str, b: str) -> bool:
    if a == b:
        return True
    if _NUMBER.sub("#", a) != _NUMBER.sub("#", b):
        return False
    na, nb = _NUMBER.findall(a), _NUMBER.findall(b)
    return all(_close(float(x), float(y)) for x, y in zip(na, nb, strict=True))


def differences(stored: Any, new: Any, where: str = "", *, limit: int = 20) -> list[str]:
    """Where ``stored`` and ``new`` differ (see the module's rules), at most ``limit`` entries."""
    out: list[str] = []

    def walk(a: Any, b: Any, path: str) -> None:
        if len(out) >= limit:
            return
        if isinstance(a, dict) and isinstance(b, dict):
            for k in sorted(set(a) | set(b), key=str):
                if _volatile(str(k)):
                    continue
                if k not in a or k not in b:
                    out.append(
                        f"{path}.{k}: only in the {'recomputed' if k in b else 'stored'} summary"
                    )
                else:
                    walk(a[k], b[k], f"{path}.{k}")
        elif isinstance(a, list) and isinstance(b, list):
            if len(a) != len(b):
                out.append(f"{path}: {len(a)} stored items, {len(b)} recomputed")
            else:
                for i, (x, y) in enumerate(zip(a, b, strict=True)):
                    walk(x, y, f"{path}[{i}]")
        elif isinstance(a, bool) or isinstance(b, bool) or a is None or b is None:
            if a is not b and a != b:
                out.append(f"{path}: stored {a!r}, recomputed {b!r}")
        elif isinstance(a, int | float) and isinstance(b, int | float):
            if not _close(float(a), float(b)):
                out.append(f"{path}: stored {a!r}, recomputed {b!r}")
        elif isinstance(a, str) and isinstance(b, str):
            if not _same_text(a, b):
                out.append(f"{path}: stored {a[:80]!r}, recomputed {b[:80]!r}")
        else:
            out.append(f"{path}: stored {type(a).__name__}, recomputed {type(b).__name__}")

    walk(stored, new, where)
    return out


def _stored_run(folder: Path) -> tuple[dict[str, Any], bool]:
    """The stored summary of ``folder`` and the mode (quick or not) its manifest records."""
    try:
        summary = json.loads((folder / "summary.json").read_text())
        manifest = json.loads((folder / "manifest.json").read_text())
    except (OSError, ValueError, RecursionError) as exc:
        raise ResultsError(
            f"{folder}: no readable summary.json and manifest.json ({type(exc).__name__})"
        ) from None
    if not isinstance(summary, dict) or not isinstance(manifest, dict):
        raise ResultsError(f"{folder}: summary.json and manifest.json must be JSON objects")
    quick = manifest.get("quick", summary.get("quick", False))
    if not isinstance(quick, bool):
        raise ResultsError(f"{folder}/manifest.json: 'quick' must be true or false, got {quick!r}")
    return summary, quick


def recompute(configs: Path, results: Path, names: list[str]) -> list[dict[str, Any]]:
    """Run each experiment of ``names`` again (configs in ``configs``, stored results in
    ``results``) and compare; one row per name: ``{"key", "status", "error"}`` with status ``ok``
    (every compared value agrees), ``differs`` (the first differences in ``error``) or ``error``
    (the experiment could not be recomputed: the reason)."""
    from roa.studies._experiment import load_config, run_experiment

    rows = []
    configs, results = configs.resolve(), results.resolve()  # the runs happen in a scratch folder
    for name in names:
        key = f"recomputed {name}"
        config = configs / f"{name}.toml"
        if not config.is_file():
            raise RoaInputError(
                f"--recompute: no experiment {name!r} (no {config}); experiments: "
                + ", ".join(sorted(p.stem for p in configs.glob("*.toml")))
            )
        try:
            stored, quick = _stored_run(results / name)
            cfg = load_config(config)
            with tempfile.TemporaryDirectory(prefix=f"roa-recompute-{name}-") as tmp:
                scratch = Path(tmp) / "results"  # run from tmp as "results": the same paths
                scratch.mkdir()
                for dep in cfg.get("depends", []):
                    if (results / dep).is_dir():
                        shutil.copytree(results / dep, scratch / dep)
                with contextlib.chdir(tmp):
                    run_experiment(config, results="results", quick=quick, force=True)
                new = json.loads((scratch / name / "summary.json").read_text())
        except (ResultsError, RoaInputError) as exc:
            rows.append({"key": key, "status": "error", "error": str(exc)})
            continue
        diffs = differences(stored, new)
        rows.append({"key": key, "status": "differs" if diffs else "ok",
                     "error": "; ".join(diffs[:5]) + (" ..." if len(diffs) > 5 else "")})  # fmt: skip
    return rows
