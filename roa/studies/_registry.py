"""The registry of studies: the ``roa.studies`` entry points, looked up by name."""

from __future__ import annotations

import functools
import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

from roa.errors import RoaInputError

GROUP = "roa.studies"


@dataclass(frozen=True)
class Study:
    """A case study driven by the ``roa`` CLI.

    Parameters
    ----------
    name : str
        Short name (``--study NAME``).
    package : str
        The study's Python package; experiment runners must live in it.
    experiments : Path
        Directory of its experiment configs (``*.toml``), used when ``./experiments`` is absent.
    reference : str
        ``"module:NAME"`` of its registry of reference values (``{key: roa.studies.Entry}``).
    report : str
        ``"module:function"`` rendering its report: ``render(results, out) -> str``.
    report_name : str
        Default file name of the report.
    commands : tuple of str
        Modules with ``register(subparsers)`` adding study commands to ``roa``.
    systems : dict of str to str
        Systems the study adds to the library's built-ins: name -> ``"module:factory"``, the
        factory taking keyword parameters (floats) and returning a :class:`roa.System`. They are
        loaded by name like the built-ins (``load_system("NAME:key=value")``, ``--system``); a
        library built-in of the same name takes precedence.
    """

    name: str
    package: str
    experiments: Path
    reference: str
    report: str
    report_name: str = "report.md"
    commands: tuple[str, ...] = field(default=())
    systems: dict[str, str] = field(default_factory=dict, hash=False)

    def resolve(self, target: str) -> Any:
        module, attr = target.split(":")
        return getattr(importlib.import_module(module), attr)

    def registry(self) -> dict[str, Any]:
        return dict(self.resolve(self.reference))

    def render_report(self, results: str | Path, out: str | Path) -> str:
        render: Callable[..., str] = self.resolve(self.report)
        return render(results, out)


@functools.lru_cache(maxsize=1)
def registered() -> dict[str, Study]:
    """Every study installed (entry point group ``roa.studies``), by name."""
    out: dict[str, Study] = {}
    for ep in metadata.entry_points(group=GROUP):
        study = ep.load()
        if not isinstance(study, Study):
            raise RoaInputError(f"entry point {ep.name} = {ep.value} is not a roa.studies.Study")
        out[study.name] = study
    return out


def get(name: str | None = None) -> Study:
    """The study called ``name`` (default: the only one installed)."""
    studies = registered()
    if not studies:
        raise RoaInputError(
            "no study is installed (entry point group 'roa.studies'); install the project with "
            "`pip install .` from its checkout"
        )
    if name is None:
        if len(studies) != 1:
            raise RoaInputError(f"several studies are installed: choose one of {sorted(studies)}")
        name = next(iter(studies))
    if name not in studies:
        raise RoaInputError(f"study must be one of {sorted(studies)}, got {name!r}")
    return studies[name]


def systems() -> dict[str, list[tuple[str, str]]]:
    """The systems the installed studies declare: name -> ``[("module:factory", study name)]``.

    A name normally has one entry; two studies declaring the same name give two (an error when
    that name is loaded: which one would ``--system NAME`` mean?).
    """
    out: dict[str, list[tuple[str, str]]] = {}
    for study in registered().values():
        for name, target in study.systems.items():
            out.setdefault(name, []).append((target, study.name))
    return out


def runner_allowed(target: str) -> bool:
    """Whether ``module:function`` names a function inside a registered study's package."""
    module = target.split(":", 1)[0]
    return any(
        module == s.package or module.startswith(s.package + ".") for s in registered().values()
    )
