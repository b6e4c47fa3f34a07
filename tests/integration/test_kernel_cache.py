"""numba's disk cache sees changes of the kernels' dependencies (roa/integration/_integrator.py).

numba keys a cached function by the source of its own file only; the batch kernels compile in
code of other modules (the polynomial terminal-set test of terminal_poly.py, the tableau of
dopri.py). A copy of the packages (library and study) runs a polynomial terminal set through both
kernels (the IPC's fast path and the public cfunc protocol), then ``member_numba`` is edited to
refuse every point and the same run, in a new process with the same cache directory, must see it:
no run enters the set any more. Before KERNEL_STAMP, the second process loaded the old code from the cache.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = """
import dataclasses, json
import numpy as np
import roa
from roa.lyapunov import PolynomialLyapunov
from roa.integration._integrator import integrate_batch
from roa.integration._terminal import TerminalSet
from roa.status import StopRules
from ipc_paper import system as ipc

system = ipc.closed_loop()
public = dataclasses.replace(system, numba_fast=None)
E = np.eye(4, dtype=int) * 2
V = PolynomialLyapunov(E.tolist(), [1.0] * 4, center=[0.0] * 4)
T = TerminalSet.polynomial(V, 0.01, coords="flat", frame=np.eye(4), box=([-0.1] * 4, [0.1] * 4))
X = np.array([[0.0, 0.0, a, 0.0] for a in (0.2, -0.3, 0.4)])
out = {}
for name, s in (("fast", system), ("public", public)):
    r = integrate_batch(s, X, rules=StopRules(t_final=30.0), terminal=T)
    out[name] = [int(r.entered.sum()), r.status[0].value]
out["file"] = roa.__file__
print(json.dumps(out))
"""


def _run(pkg: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", SCRIPT], cwd=pkg, capture_output=True, text=True,
                         timeout=900, env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(pkg)})  # fmt: skip
    assert out.returncode == 0, out.stderr[-3000:]
    import json

    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_a_change_in_terminal_poly_reaches_the_cached_kernels(tmp_path):
    for pkg in ("roa", "ipc_paper"):  # the library and the study holding the IPC's kernels
        shutil.copytree(ROOT / pkg, tmp_path / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    before = _run(tmp_path)
    assert before.pop("file").startswith(str(tmp_path))  # the copy, not the installed package
    assert before == {"fast": [3, "converged"], "public": [3, "converged"]}
    cache = tmp_path / "roa" / "integration" / "__pycache__"  # the kernels are cached on disk
    assert list(cache.glob("integrator.compile_kernel.locals.run-*.nbi"))
    assert list(cache.glob("integrator._public_kernel.locals.kernel-*.nbi"))
    poly = tmp_path / "roa" / "integration" / "_terminal_poly.py"
    src = poly.read_text()
    marker = "    return v + g * s <= thr\n"
    assert src.count(marker) == 1
    poly.write_text(src.replace(marker, "    return False  # refuses every point\n"))
    after = _run(tmp_path)
    after.pop("file")
    # the runs converge by the ball now, none by the terminal set
    assert after == {"fast": [0, "converged"], "public": [0, "converged"]}


STEP_SCRIPT = """
import dataclasses, json
import numpy as np
import roa
from roa.integration._integrator import integrate_batch
from roa.status import StopRules
from ipc_paper import system as ipc

system = ipc.closed_loop()
centre = roa.System(name="centre", field=lambda t, x, xp: (x[1], -x[0]), equilibrium=(0.0, 0.0),
                    state_names=("a", "b"))
X = np.array([[0.0, 0.0, a, 0.0] for a in (0.2, -0.3)])
out = {}
for name, s, x, backend in (("fast", system, X, "auto"),
                            ("public", dataclasses.replace(system, numba_fast=None), X, "auto"),
                            ("generated", centre, np.array([[1.0, 0.0]]), "numba")):
    out[name] = integrate_batch(s, x, rules=StopRules(t_final=5.0), backend=backend).steps.tolist()
out["file"] = roa.__file__
print(json.dumps(out))
"""


@pytest.mark.slow
def test_a_change_of_the_step_reaches_every_cached_kernel(tmp_path):
    """The Dormand-Prince step is written once (dopri.py) and compiled into the IPC's fast path,
    the public cfunc kernel and the generated kernels, all cached on disk. Editing the step (the
    error estimate made 0: every step accepted and grown tenfold) must reach all three in a new
    process with the same caches: fewer steps, none loaded stale from a cache."""
    import json

    for pkg in ("roa", "ipc_paper"):
        shutil.copytree(ROOT / pkg, tmp_path / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(tmp_path),
           "ROA_KERNEL_CACHE": str(tmp_path / "kernels")}  # fmt: skip

    def run() -> dict:
        out = subprocess.run([sys.executable, "-c", STEP_SCRIPT], cwd=tmp_path, env=env,
                             capture_output=True, text=True, timeout=900)  # fmt: skip
        assert out.returncode == 0, out.stderr[-3000:]
        res = json.loads(out.stdout.strip().splitlines()[-1])
        assert res.pop("file").startswith(str(tmp_path))
        return res

    before = run()
    assert run() == before  # loaded from the caches: the same steps
    dopri = tmp_path / "roa" / "integration" / "_dopri.py"
    src = dopri.read_text()
    marker = "        err[i] = h * acc / ("
    assert src.count(marker) == 1
    dopri.write_text(src.replace(marker, "        err[i] = 0.0 * h * acc / ("))
    after = run()
    for name, steps in before.items():
        assert all(a < b for a, b in zip(after[name], steps, strict=True)), (name, steps, after)
