"""Kernels generated from a field written against ``xp`` (roa/integration/_kernel_cache.py).

The generated kernel and the numpy backend integrate the same ODE with the same Dormand-Prince
5(4) step control (scipy's), so they take the same accepted steps up to rounding: the field's
operations run in sympy's order in the kernel and the field's own order in numpy, a few units in
the last place per evaluation. Statuses must agree on the grids below (no initial condition of
them lies on a separatrix to within such rounding), stop times to a relative 1e-6 and end states
to 1e-6 (1 + |x|): the rounding differences move the step sizes (chosen from error estimates,
raised to the power -1/5) and are amplified along trajectories of at most a few hundred steps, yet
stay far below these bounds (observed: stop times within 2e-8 s, end states within 1e-10
relative), while a wrong field misses them by orders of magnitude.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import roa
import roa.io
from roa.integration import _kernel_cache as kc
from roa.integration._integrator import CONVERGED, integrate_batch
from roa.integration._trace import Untraceable
from roa.systems.vanderpol import vanderpol

ROOT = Path(__file__).resolve().parents[2]


def _grid(lo, hi, k, n=2):
    axes = np.meshgrid(*[np.linspace(lo, hi, k)] * n, indexing="ij")
    return np.stack([a.ravel() for a in axes], axis=1)


def _pendulum(gain=0.5):
    return roa.System(
        name="sincos",
        field=lambda t, x, xp: (x[1], -xp.sin(x[0]) - gain * x[1] + 0.2 * xp.cos(x[0]) * x[1]),
        equilibrium=(0.0, 0.0),
        state_names=("theta", "omega"),
        margin=lambda x, xp: 4.0 - xp.abs(x[0]),
        domain_description="|theta| < 4",
    )


def _agree(system, X):
    gen = integrate_batch(system, X, backend="numba")
    ref = integrate_batch(system, X, backend="numpy")
    assert np.array_equal(gen.code, ref.code)
    assert np.allclose(gen.t_end, ref.t_end, rtol=1e-6, atol=0)
    tol = 1e-6 * (1 + np.abs(ref.x_end))
    assert (np.abs(gen.x_end - ref.x_end) <= tol).all()
    return gen


def test_vanderpol_generated_kernel_matches_numpy(tmp_path, monkeypatch):
    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    res = _agree(vanderpol(), _grid(-3, 3, 15))
    assert 0 < np.count_nonzero(res.code == CONVERGED) < res.code.size  # both statuses occur


@pytest.mark.slow
def test_sincos_system_with_margin_matches_numpy(tmp_path, monkeypatch):
    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    system = _pendulum()
    res = _agree(system, _grid(-5, 5, 13))
    assert {0, 1} <= set(res.code.tolist())  # converged and left the domain |theta| < 4


def test_parameters_are_kernel_arguments(tmp_path, monkeypatch):
    """Another mu reuses the compiled text (one file) and integrates that mu's field."""
    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    a, b = kc.generate(vanderpol(1.0)), kc.generate(vanderpol(2.0))
    assert a.digest == b.digest and a.names == ("mu",) and b.values == (2.0,)
    X = _grid(-2, 2, 7)
    _agree(vanderpol(2.0), X)
    assert kc.load_module(a.text, a.digest) is kc.load_module(b.text, b.digest)


def test_numpy_and_the_numba_kernel_take_the_same_steps(tmp_path, monkeypatch):
    """On a field whose generated and numpy evaluations agree bit for bit (Van der Pol's field at
    mu = 0: x1' = -x2, x2' = x1 + 0 (x1^2 - 1) x2 = x1 exactly, no rounding at all; the kernel
    generated for Van der Pol, mu a kernel argument), the numpy batch and the generated numba
    kernel run the same step, control and initial step (dopri.py, written once): the same codes
    and step counts, and runs still going at t_final (circles around the centre) end at the same
    states to a few units in the last place. Not bit for bit here: numpy's vectorised
    ``en ** -0.2`` (SIMD) differs from libm's ``pow`` by one unit in the last place for a few per
    cent of arguments (measured 4.4 % on this machine), which moves step sizes by as much; the
    step itself is compared bit for bit in
    test_the_step_is_the_same_bits_in_numba_and_numpy. Placed after the test of parameters, so
    that Van der Pol's kernel compiled there serves here (before other tests forget kernels)."""
    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    from roa.integration._dopri import UNDECIDED
    from roa.status import StopRules
    from roa.systems.vanderpol import field

    centre = roa.System(name="vanderpol", field=field, equilibrium=(0.0, 0.0),
                        state_names=("a", "b"), params={"mu": 0.0})  # fmt: skip
    assert kc.generate(centre).digest == kc.generate(vanderpol(1.0)).digest
    X = np.random.default_rng(5).uniform(-2, 2, (200, 2))
    rules = StopRules(t_final=15.0)
    gen = integrate_batch(centre, X, backend="numba", rules=rules)
    ref = integrate_batch(centre, X, backend="numpy", rules=rules)
    going = ref.code == UNDECIDED
    assert going.sum() > 150 and np.array_equal(gen.code, ref.code)
    assert np.array_equal(gen.steps, ref.steps) and np.array_equal(gen.t_end, ref.t_end)
    assert np.all(np.abs(gen.x_end - ref.x_end) <= 1e-13 * (1 + np.abs(ref.x_end)))
    # and they are a Dormand-Prince solution: the circle's radius kept to the tolerances
    r0, r1 = np.linalg.norm(X[going], axis=1), np.linalg.norm(ref.x_end[going], axis=1)
    assert np.all(np.abs(r1 - r0) <= 1e-4 * r0)


def test_untraceable_field_falls_back_naming_the_term(tmp_path, monkeypatch):
    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    system = roa.System(name="uses-np-tanh", field=lambda t, x, xp: (-x[0] + np.tanh(x[1]), -x[1]),
                        equilibrium=(0.0, 0.0), state_names=("a", "b"))  # fmt: skip
    with pytest.raises(Untraceable, match="tanh"):
        kc.generate(system)
    X = _grid(-1, 1, 50)  # 2500 >= COMPILE_FROM: auto would compile
    with pytest.warns(kc.KernelFallbackWarning, match="uses-np-tanh.*tanh.*numpy backend"):
        res = roa.basin(system, roa.box_sample(system, [(-1, 1)] * 2, 2500, seed=1),
                        run=roa.RunOptions(n_jobs=1))  # fmt: skip
    assert res.backend == "numpy" and "tanh" in res.backend_note
    assert res.to_dict()["backend"] == "numpy"
    with warnings.catch_warnings():  # once per system and reason
        warnings.simplefilter("error")
        integrate_batch(system, X)
    with pytest.raises(roa.RoaInputError, match="tanh"):
        integrate_batch(system, X[:5], backend="numba")


def test_branch_on_namespace_is_caught_by_the_numpy_check(tmp_path, monkeypatch):
    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))

    def field(t, x, xp):  # another field in numpy than under sympy
        k = 2.0 if xp.name == "numpy" else 1.0
        return (-k * x[0], -x[1])

    system = roa.System(name="branchy", field=field, equilibrium=(0.0, 0.0),
                        state_names=("a", "b"))  # fmt: skip
    with pytest.raises(Untraceable, match="differs from the numpy field"):
        kc.generate(system)


def test_unsupported_sympy_function_is_named(tmp_path, monkeypatch):
    import sympy as sp

    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    x1, x2 = sp.symbols("x1 x2")
    system = roa.System(name="erf", field=lambda t, x, xp: (-x[0] + sp.erf(x[1]), -x[1]),
                        equilibrium=(0.0, 0.0), state_names=("a", "b"))  # fmt: skip
    with pytest.raises(Untraceable, match="erf"):
        kc.generate(system)


def test_basin_defaults_record_the_generated_backend(tmp_path, monkeypatch):
    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    system = vanderpol()
    sampler = roa.box_sample(system, [(-3, 3)] * 2, 3000, seed=3)
    res = roa.basin(system, sampler, run=roa.RunOptions(n_jobs=1))
    ref = roa.basin(system, sampler, integrator=roa.IntegratorOptions(backend="numpy"),
                    run=roa.RunOptions(n_jobs=1))  # fmt: skip
    assert res.backend == "numba-generated" and ref.backend == "numpy"
    assert res.counts == ref.counts and np.array_equal(res.code, ref.code)
    small = roa.basin(system, roa.box_sample(system, [(-3, 3)] * 2, 100, seed=3),
                      run=roa.RunOptions(n_jobs=1))  # fmt: skip
    assert small.backend == "numpy"  # below COMPILE_FROM: no compilation for a small run


SCRIPT = """
import sys, json
import numpy as np
import roa
from roa.integration import _kernel_cache as kc
from roa.integration._integrator import integrate_batch
gain = float(sys.argv[1])
system = roa.System(name="cached", field=lambda t, x, xp: (x[1], -xp.sin(x[0]) - gain * x[1]),
                    equilibrium=(0.0, 0.0), state_names=("a", "b"))
res = integrate_batch(system, np.array([[1.0, 0.0], [2.5, 0.0]]), backend="numba")
f = kc.generate(system)
print(json.dumps({"digest": f.digest, "codes": res.code.tolist(), "x": res.x_end.tolist(),
                  "traced": "sympy" in sys.modules}))
"""


def _run(cache: Path, gain: float) -> tuple[dict, str]:
    import json

    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), kc.CACHE_ENV: str(cache),
           "ROA_CACHE_DIR": str(cache / "roa")}  # fmt: skip
    out = subprocess.run([sys.executable, "-c", SCRIPT, str(gain)], capture_output=True,
                         text=True, timeout=600, env=env)  # fmt: skip
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1]), out.stderr


@pytest.mark.slow
def test_disk_cache_hit_miss_and_invalidation(tmp_path):
    """A new process traces and compiles (progress line), the next finds the kernel by its
    field's code and loads it (no sympy, no line, same text), a changed field writes another
    module and compiles again."""
    first, err1 = _run(tmp_path, 0.5)
    assert "compiling the integrator" in err1 and "compiled in" in err1
    assert first.pop("traced")
    files = sorted(p.name for p in tmp_path.glob("roa_kernel_*.py"))
    assert files == [f"roa_kernel_{first['digest'][:32]}.py"]
    assert list((tmp_path / "__pycache__").glob("roa_kernel_*.run-*.nbi"))  # numba's cache
    second, err2 = _run(tmp_path, 0.5)
    assert not second.pop("traced")  # found in the index by the field's code
    assert second == first and "compiling" not in err2  # loaded from the cache
    changed, err3 = _run(tmp_path, 0.7)
    assert changed.pop("traced")  # another gain: another code key, traced again
    assert changed["digest"] != first["digest"] and "compiling the integrator" in err3
    assert len(list(tmp_path.glob("roa_kernel_*.py"))) == 2
    assert changed["x"] != first["x"]  # the new gain's trajectories


def test_generated_factory_survives_pickling_and_with_params(tmp_path, monkeypatch):
    import pickle

    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    system, label, note = kc.compiled_system(vanderpol(), "auto", None, 10_000)
    assert label == kc.GENERATED and note is None
    other = pickle.loads(pickle.dumps(system)).with_params(mu=1.5)
    assert isinstance(other.numba_fast, kc.GeneratedKernels) and other.numba_fast.values == (1.5,)
    own = dataclasses.replace(system, numba_fast=None)
    assert kc.compiled_system(own, "numpy")[1] == kc.NUMPY


def test_code_key_follows_constants_closures_and_globals():
    from roa.integration._code_identity import code_key

    def make(gain):
        return lambda t, x, xp: (x[1], -gain * x[0])

    assert code_key(make(1.0)) == code_key(make(1.0))
    assert code_key(make(1.0)) != code_key(make(2.0))  # a closure value
    assert code_key(lambda t, x, xp: (x[1], -x[0])) != code_key(lambda t, x, xp: (x[1], -2 * x[0]))

    class Opaque:  # no picklable state (a local class): no key, the field is traced
        pass

    thing = Opaque()
    assert code_key(lambda t, x, xp: (thing, x[0])) is None


def test_stale_index_entry_is_caught_by_the_numpy_check(tmp_path, monkeypatch):
    """An index entry pointing at another field's kernel is not used."""
    import json

    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    kc._TRACES.clear()
    a = kc.generate(_pendulum(0.5))
    b_sys = _pendulum(0.9)
    path = kc._index_path(b_sys)
    path.parent.mkdir(parents=True, exist_ok=True)
    body = {"digest": a.digest, "names": [], "baked": {}}
    tag = roa.io.cache_tag(kc.INDEX_TAG, {"index": path.name, **body})
    path.write_text(json.dumps({**body, "tag": tag}))  # as roa would write it
    assert kc._from_index(b_sys, path) is None
    assert kc.generate(b_sys).digest != a.digest


def test_an_index_entry_without_the_users_tag_is_ignored(tmp_path, monkeypatch):
    """A consistent forgery (an edited kernel under its own hash, an index entry naming it) is
    ignored: the entry carries no tag under the user's key; the system is traced again."""
    import hashlib
    import json

    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    _forget()
    system = vanderpol()
    good = kc.generate(system)
    path = kc._index_path(system)
    assert kc._from_index(system, path) == good  # the entry roa wrote checks
    bad = _poison(good.text)
    digest = hashlib.sha256(bad.encode()).hexdigest()
    (tmp_path / f"roa_kernel_{digest[:32]}.py").write_text(bad)
    entry = json.loads(path.read_text())
    for forged in ({**entry, "digest": digest}, {"digest": digest, "names": [], "baked": {}}):
        path.write_text(json.dumps(forged))
        assert kc._from_index(system, path) is None
        _forget()
        assert kc.generate(system).digest == good.digest


@pytest.mark.slow
def test_quadratic_terminal_set_in_the_generated_kernel_matches_numpy(tmp_path, monkeypatch):
    """Runs entering a certified ellipsoid of Van der Pol stop there in both backends alike (the
    published P at level 1, inside the certified 2.3045)."""
    from roa.integration._terminal import TerminalSet
    from roa.systems.vanderpol import P_BENCHMARK

    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    T = TerminalSet(P_BENCHMARK, [0.0, 0.0], 1.0)
    X = _grid(-3, 3, 15)
    gen = integrate_batch(vanderpol(), X, backend="numba", terminal=T)
    ref = integrate_batch(vanderpol(), X, backend="numpy", terminal=T)
    assert np.array_equal(gen.code, ref.code) and np.array_equal(gen.entered, ref.entered)
    assert gen.entered.sum() > 0
    assert np.allclose(gen.t_end, ref.t_end, rtol=1e-6, atol=0)


@pytest.mark.slow
def test_generated_kernel_is_the_integrators_kernel_bit_for_bit(tmp_path, monkeypatch):
    """The generated module's kernel (the integrator's batch_kernel on the generated field) takes
    the same steps as the integrator's own kernel (compile_kernel) on the same compiled field:
    identical bits."""
    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    system = _pendulum()
    factory = kc.generate(system)

    class Plain:  # the same njit field and margin, through integrator.compile_kernel
        def __call__(self, coords=None):
            field, margin, params = factory()
            return field, margin, params

    plain = dataclasses.replace(system, numba_fast=Plain())
    X = _grid(-5, 5, 9)
    a = integrate_batch(dataclasses.replace(system, numba_fast=factory), X, backend="numba")
    b = integrate_batch(plain, X, backend="numba")
    for u, v in ((a.code, b.code), (a.t_end, b.t_end), (a.x_end, b.x_end), (a.steps, b.steps)):
        assert np.array_equal(u, v)


# --- damaged kernel files (issue 39, item 2) --------------------------------------------------


def _poison(text: str) -> str:
    """The kernel with ``run`` marking every run converged (the adversarial edit)."""
    line = "          code, t_end, x_end, steps, None)\n"
    assert line in text
    return text.replace(
        line, f"{line}    for k in range(X0.shape[0]):\n        code[k] = {CONVERGED}\n"
    )


def _forget() -> None:
    """What a new process knows of generated kernels: nothing."""
    kc._TRACES.clear()
    for name in list(kc._MODULES):
        del kc._MODULES[name]
        sys.modules.pop(name, None)


@pytest.mark.slow
def test_an_edited_kernel_file_is_rewritten_and_counts_are_a_fresh_runs(tmp_path, monkeypatch):
    """Editing the cached kernel so that ``run`` marks every run converged turned 576 diverged
    runs of this grid into converged ones; the file is now checked against its hash when loaded,
    rewritten, and the counts are those of a fresh run (and of the numpy backend)."""
    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    system, X = vanderpol(), _grid(-3, 3, 30)
    _forget()
    fresh = integrate_batch(system, X, backend="numba")
    counts = np.bincount(fresh.code, minlength=8)
    assert counts[CONVERGED] < len(X)  # some runs diverge: the poisoned kernel would differ
    numpy = integrate_batch(system, X, backend="numpy")
    np.testing.assert_array_equal(numpy.code, fresh.code)
    (path,) = tmp_path.glob("roa_kernel_*.py")
    text = path.read_text()
    path.write_text(_poison(text))
    _forget()
    again = integrate_batch(system, X, backend="numba")
    np.testing.assert_array_equal(again.code, fresh.code)
    assert path.read_text() == text


DAMAGE = {
    "edited": lambda p: p.write_text(_poison(p.read_text())),
    "truncated": lambda p: p.write_text(p.read_text()[:1000]),
    "empty": lambda p: p.write_text(""),
    "linked to /dev/null": lambda p: (p.unlink(), p.symlink_to("/dev/null")),
    "linked to another file": lambda p: (
        p.with_name("other.py").write_text(_poison(p.read_text())),
        p.unlink(),
        p.symlink_to(p.with_name("other.py")),
    ),
}


@pytest.mark.parametrize("damage", list(DAMAGE))
def test_a_damaged_kernel_file_is_rebuilt(tmp_path, monkeypatch, damage):
    """Without compiling: the module loaded after the damage is the kernel's own text (its
    ``run`` has the source of the undamaged one) and the file holds that text again."""
    import inspect

    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    _forget()
    factory = kc.generate(vanderpol())
    path = tmp_path / f"roa_kernel_{factory.digest[:32]}.py"
    good = inspect.getsource(kc.load_module(factory.text, factory.digest).run.py_func)
    DAMAGE[damage](path)
    _forget()
    again = kc.generate(vanderpol())
    assert again.digest == factory.digest
    mod = kc.load_module(again.text, again.digest)
    assert inspect.getsource(mod.run.py_func) == good and "code[k] = " not in good
    assert not path.is_symlink() and path.read_text() == factory.text


def test_a_kernel_text_that_does_not_hash_to_its_digest_is_never_loaded():
    with pytest.raises(ValueError, match="does not hash to"):
        kc.load_module("X = 1\n", "0" * 64)


# --- one Dormand-Prince step (roa/integration/_dopri.py), no copied integrator source ----------


def test_the_generated_module_holds_no_copy_of_the_integrator(tmp_path, monkeypatch):
    """The generated text is the field, the margin and a call of the integrator's own batch
    kernel (``batch_kernel(STATES)``): no step, controller or tableau of its own."""
    monkeypatch.setenv(kc.CACHE_ENV, str(tmp_path))
    text = kc.generate(vanderpol()).text
    assert "_ROWS = batch_kernel(STATES)" in text and "_ROWS(_F, _M, params" in text
    for copied in ("def _one", "TABLEAU", "ERROR_E", "DENSE_P", "SAFETY", "nextafter"):
        assert copied not in text


def test_the_kernel_stamp_follows_the_step_and_the_text_follows_the_field(monkeypatch):
    """The generated text (whose SHA-256 names the kernel file and numba's cache of it) changes
    when the step's source (dopri.py) or the integrator's changes, and when the field changes."""
    from roa.integration import _code_identity as code_identity
    from roa.integration._codegen import kernel_source
    from roa.integration._trace import trace_system

    real = code_identity.source_digest
    stamp = kc.kernel_stamp()
    for name in ("_dopri.py", "_integrator.py", "_terminal_poly.py"):
        monkeypatch.setattr(code_identity, "source_digest",
                            lambda f, name=name: "edited" if f.endswith(name) else real(f))  # fmt: skip
        assert kc.kernel_stamp() != stamp, name
    monkeypatch.setattr(code_identity, "source_digest", real)
    assert kc.kernel_stamp() == stamp
    a = kernel_source(trace_system(_pendulum(0.5)), system_name="p", stamp=stamp)
    b = kernel_source(trace_system(_pendulum(0.7)), system_name="p", stamp=stamp)
    c = kernel_source(trace_system(_pendulum(0.5)), system_name="p", stamp="other")
    assert len({a, b, c}) == 3


def test_the_step_is_the_same_bits_in_numba_and_numpy():
    """dopri.py's step (stages, error estimate, dense output) compiled into the numba kernel
    (integrator._stages, ...: one state per element) and run by numpy (one (m, n) block per
    element) gives identical bits on 500 random steps of a damped linear field; so does the
    step-size control wherever numpy's ``en ** -0.2`` is libm's (see the test above)."""
    import math

    import numba

    from roa.integration import _dopri as dopri, _integrator as ig

    @numba.njit(error_model="numpy")
    def lin(t, x, p, out):
        out[0] = x[1]
        out[1] = -x[0] - p[0] * x[1]

    def lin_block(t, x, p, out):
        out[0][:, 0] = x[0][:, 1]
        out[0][:, 1] = -x[0][:, 0] - p[0] * x[0][:, 1]

    @numba.njit(error_model="numpy")
    def kernel_steps(Y, H, S, p, K_out, Ynew, Err, Q_out, D):
        n = Y.shape[1]
        tmp = np.empty(n)
        for r in range(Y.shape[0]):
            K = K_out[r]
            lin(0.0, Y[r], p, K[0])
            ig._stages(lin, p, 0.0, Y[r], H[r], K, tmp, Ynew[r], n)
            lin(H[r], Ynew[r], p, K[6])
            ig._error(H[r], K, Y[r], Ynew[r], Err[r], n, 1e-6, 1e-9)
            ig._dense_coefficients(K, Q_out[r], n)
            ig._dense(Y[r], H[r], Q_out[r], S[r], D[r], n)

    rng = np.random.default_rng(11)
    m, n = 500, 2
    Y, H, S = rng.normal(0, 2, (m, n)), rng.uniform(1e-4, 0.5, m), rng.uniform(0, 1, m)
    p = np.array([0.3])
    K, Ynew, Err = np.empty((m, 7, n)), np.empty((m, n)), np.empty((m, n))
    Q, D = np.empty((m, n, 4)), np.empty((m, n))
    kernel_steps(Y, H, S, p, K, Ynew, Err, Q, D)
    Kb = np.empty((7, 1, m, n))
    yb, ynb, errb, work = Y[None], np.empty((1, m, n)), np.empty((1, m, n)), np.empty((1, m, n))
    lin_block(0.0, yb, p, Kb[0])
    dopri.stages(lin_block, p, 0.0, yb, H[:, None], Kb, work, ynb, 1)
    lin_block(H[:, None], ynb, p, Kb[6])
    dopri.error(H[:, None], Kb, yb, ynb, errb, 1, 1e-6, 1e-9)
    Qb, Db = np.empty((1, 4, m, n)), np.empty((1, m, n))
    dopri.dense_coefficients(Kb, Qb, 1)
    dopri.dense(yb, H[:, None], Qb, S[:, None], Db, 1)
    assert np.array_equal(Kb[:, 0].transpose(1, 0, 2), K)
    assert np.array_equal(ynb[0], Ynew) and np.array_equal(errb[0], Err)
    assert np.array_equal(Qb[0].transpose(1, 2, 0), Q) and np.array_equal(Db[0], D)
    assert not np.array_equal(Ynew, Y)  # steps were taken

    @numba.njit(error_model="numpy")
    def kernel_control(en, h, rejected, ok, h_out):
        for i in range(en.shape[0]):
            ok[i], h_out[i] = ig._control(en[i], h[i], rejected[i])

    en = np.concatenate([[0.0, np.nan, np.inf, 1.0], rng.uniform(0, 3, 2000),
                         rng.uniform(0, 1e-12, 100)])  # fmt: skip
    h, rejected = rng.uniform(1e-3, 1, en.size), rng.random(en.size) < 0.5
    ok, h_next = np.empty(en.size, bool), np.empty(en.size)
    kernel_control(en, h, rejected, ok, h_next)
    with np.errstate(all="ignore"):
        ok_b, h_b = dopri.control(en, h, rejected)
        libm = np.array([math.pow(e, -0.2) if e > 0 else np.inf for e in en])
        same_pow = (en**-0.2 == libm) | np.isnan(en)
    assert same_pow.mean() > 0.9 and ok.any() and not ok.all()
    assert np.array_equal(ok_b, ok)
    assert np.array_equal(h_b[same_pow], h_next[same_pow], equal_nan=True)
