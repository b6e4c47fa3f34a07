"""Fast start (#25): ``import roa``, building the CLI and ``roa --help`` import no heavy dependency.

Each check runs in a fresh interpreter and inspects ``sys.modules`` afterwards (counts, not times:
the times are printed by benchmarks/bench_startup.py). The heavy dependencies are imported by the
analyses that use them, and the numba cfuncs compile on first use, not at import.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: Modules that take tenths of a second or more to import and are needed by analyses only.
HEAVY = ("cvxpy", "casadi", "numba", "matplotlib", "sympy", "scipy.optimize", "dask", "joblib",
         "mpmath", "flint", "clarabel")  # fmt: skip


def _loaded_after(code: str) -> list[str]:
    """The heavy modules present in ``sys.modules`` after running ``code`` in a fresh process."""
    probe = f"{code}\nimport json, sys\nprint(json.dumps([m for m in {list(HEAVY)!r} if m in sys.modules]))"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=ROOT,
                         env=env, timeout=120)  # fmt: skip
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_import_roa_imports_no_heavy_module():
    assert _loaded_after("import roa") == []


def test_light_public_names_stay_light():
    # the system definition, options and statuses are what a user file imports
    code = "import roa\nroa.System\nroa.RunOptions\nroa.Verdict\nroa.RoaInputError"
    assert _loaded_after(code) == []


def test_cli_parser_with_study_commands_imports_no_heavy_module():
    code = "from roa.cli import build_parser\nbuild_parser()"
    assert _loaded_after(code) == []
    # not even numpy: --help lists the commands, the built-in systems and the defaults only
    code += "\nimport sys\nassert 'numpy' not in sys.modules, 'numpy imported by the parser'"
    assert _loaded_after(code) == []


@pytest.mark.parametrize("args", [["--help"], ["certify", "--help"], ["basin", "--help"]])
def test_help_exits_before_any_heavy_import(args):
    code = (
        "import sys\nfrom roa.cli import main\n"
        f"try:\n    main({args!r})\nexcept SystemExit as e:\n    assert e.code == 0, e.code"
    )
    assert _loaded_after(code) == []


def test_lazy_public_names_resolve_to_the_defining_objects():
    import roa
    from roa.certification import certify
    from roa.model._system import System

    assert roa.System is System and roa.certify is certify
    assert set(roa.__all__) <= set(dir(roa))
    with pytest.raises(AttributeError, match="no_such_name"):
        roa.no_such_name  # noqa: B018


def test_lazy_cfuncs_compile_on_access_and_once():
    from roa.integration import _integrator as I

    assert "identity_coords" in I.__getattr__.names()
    a = I.no_margin
    assert a is I.no_margin and a.address != 0  # one compiled cfunc, a real function pointer
    from roa.integration._integrator import identity_coords

    assert identity_coords is I.identity_coords
    with pytest.raises(AttributeError, match="no_such_kernel"):
        I.no_such_kernel  # noqa: B018
