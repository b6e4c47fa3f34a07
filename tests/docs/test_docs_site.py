"""The documentation site (#25) stays complete and its build stays in CI.

The strict build itself (``sphinx-build -W``) is the last step of ``.ci/run``; these checks keep
the pieces that a build does not check: every public name of ``roa`` has its page in the API
reference, and the README's test command is what ``.ci/run`` runs.
"""

from __future__ import annotations

import re
from pathlib import Path

import roa

ROOT = Path(__file__).resolve().parents[2]


def test_api_reference_lists_every_public_name():
    listed = set(re.findall(r"^\s+roa\.(\w+)\s*$", (ROOT / "docs" / "api.rst").read_text(), re.M))
    assert set(roa.__all__) - listed == set()
    assert listed - set(roa.__all__) == set()


def test_readme_test_command_is_what_ci_runs():
    readme = (ROOT / "README.md").read_text()
    (line,) = [
        ln for ln in readme.splitlines() if ln.startswith("python3 -m venv") and "[test]" in ln
    ]
    steps = [s.strip() for s in line.split("&&")][2:]  # after creating and activating the venv
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    run = [ln.replace(" --quiet", "") for ln in ci[ci.index('pip install --quiet -e ".[test]"') :]]
    assert steps == [s for s in run if s]
    assert steps[-1].startswith("sphinx-build -W --keep-going")
