"""The documentation site (#25) stays complete and its build stays in CI.

The strict build itself (``sphinx-build -W``) is the last step of ``.ci/run``; these checks keep
the pieces that a build does not check: the README's test command is what ``.ci/run`` runs (that
every public name has its entry in the API reference is ``test_api_reference.py``).
"""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


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
