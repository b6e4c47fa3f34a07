"""Benchmark: roa.basin with its defaults against JAX + diffrax, the peer a Python user would pick.

Same initial conditions (seeded uniform samples of a box per system), same Dormand-Prince 5(4)
pair, rtol 1e-6, atol 1e-9, T = 30, same stop rules: converged into the ball ``||x - x_eq|| <=
converge_tol``, left the domain (``margin(x) <= 0``), diverged (``||x|| >= diverge_bound``),
else undecided (roa's converged_elsewhere and step-size failures count as undecided). diffrax
runs ``Dopri5`` with ``PIDController(rtol, atol)`` and the three stop rules as a
``diffrax.Event`` of boolean conditions (the solve stops at the end of the step that enters; roa
locates the crossing inside the step; statuses are compared point for point), in float64, in two
set-ups, each in its own process:

* ``jit(vmap)``: one jitted ``vmap`` of the solve over every initial condition;
* ``tuned``: 2 XLA host devices (``--xla_force_host_platform_device_count=2``), ``pmap`` over
  them and ``lax.map`` over batches of ``--batch`` vmapped solves on each (a batch runs until
  its slowest member, so small batches waste fewer lockstep steps, large ones less per-batch
  overhead; ``--batch`` 256 and 1024 were the fastest of 16-4096 tried on VdP, 20,000 states).

The field is the system's own ``field(t, x, xp)`` with a ``jax.numpy`` namespace, so both sides
integrate the same expressions. Systems: Van der Pol (``roa.systems.vanderpol``), the planar
quadrotor under LQR (examples/systems/quadrotor2d.py, 6 states, sin/cos), LyZNet's 10-state
example (examples/systems/lyznet_10d.py) and the IPC (``ipc_paper.system.closed_loop``, its
hand-written kernel). User systems run on the kernel roa generates from their field
(roa/integration/_kernel_cache.py).

Throughput is initial conditions per second of CPU time (roa: the process and its worker
processes, via psutil; diffrax: the process, all its threads), median of ``--reps`` runs after a
first call; compile time is reported apart (roa: generating and compiling the kernel, or loading
it from the disk cache; diffrax: the first call minus a later one). One line per system and peer
set-up::

    peer SYSTEM SETUP roa=N/s peer=M/s ratio=R statuses=K/K

(``ratio`` = roa's throughput / the peer's, CPU time), then the wall-clock throughputs and compile
times. Needs the optional extra ``bench`` (``pip install ".[bench]"`` in a clone: jax, diffrax); without it
prints a message and exits 0.

    python benchmarks/bench_peers.py [--n 20000] [--reps 3] [--systems vdp,quad,lyznet,ipc]
        [--setups tuned,vmap] [--batch 256]

Measured (jax 0.10.2, diffrax 0.7.2, numba 0.68.1; 20,000 initial conditions, median of 3-7
runs; an idle 2-core machine whose rates still vary by about 10 % between runs; statuses
20,000/20,000 in every line):

    system   roa (CPU)     diffrax tuned   ratio       diffrax jit(vmap)   ratio
    vdp      42-46 k/s     20-24 k/s       1.97-2.24   10.8-14 k/s         3.1-3.9
    quad     25-28 k/s     8.1-8.5 k/s     3.0-3.4     2.3-3.6 k/s         7.1-12.4
    lyznet   41-47 k/s     12-13 k/s       3.2-3.9     2.2-3.5 k/s         11.6-21
    ipc      13.4-14.4 k/s 3.2-3.4 k/s     4.0-4.5     1.5-1.6 k/s         9.2

The IPC line is the study's hand-written kernel, as fast before the generated kernels as after
(13.5-13.9 k/s CPU, 23.0-23.2 k/s wall, run side by side). Its wall-clock rate on 2 workers,
23-25 k/s, over diffrax tuned's CPU rate, 3.2-3.4 k/s, is 6.9-7.8; on one clock for both the
ratio is 4.0-4.5 (CPU) or 3.6-4.0 (wall). In the IPC kernel's profile, sincos, log and pow of
libm take about 42 % of the time; a field evaluation costs about 55-60 ns and a step about 0.3
microseconds more. Interleaving two runs per core (same arithmetic) gained 10 % on Van der Pol
and lost 8 % on the IPC, so the kernels stay one run at a time.

roa's kernel compile for a new user field 6-11 s (a fresh install, the library's own kernels not
cached yet, about 10 s), loading it from the cache in a new process under 1 s; diffrax's compile
3-6 s per set-up.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
T_FINAL = 30.0
RTOL, ATOL = 1e-6, 1e-9
MAX_STEPS = 100_000


def _example(path: str) -> Any:
    spec = importlib.util.spec_from_file_location(Path(path).stem, ROOT / path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.SYSTEM


def system_and_box(name: str) -> tuple[Any, list[tuple[float, float]]]:
    """The system and the box its initial conditions are sampled from."""
    if name == "vdp":
        from roa.systems.vanderpol import vanderpol

        return vanderpol(), [(-3.0, 3.0)] * 2
    if name == "quad":
        return _example("examples/systems/quadrotor2d.py"), [(-2.0, 2.0)] * 2 + [(-1.5, 1.5)] + [
            (-2.0, 2.0)
        ] * 3
    if name == "lyznet":
        return _example("examples/systems/lyznet_10d.py"), [(-4.0, 4.0)] * 10
    if name == "ipc":
        from ipc_paper.system import closed_loop

        return closed_loop(), [(-3.0, 3.0), (-3.0, 3.0), (-1.5, 1.5), (-3.0, 3.0)]
    raise SystemExit(f"unknown system {name!r} (vdp, quad, lyznet, ipc)")


def _samples(name: str, n: int) -> tuple[Any, Any, np.ndarray]:
    import roa

    system, box = system_and_box(name)
    sampler = roa.box_sample(system, box, n, seed=0)
    return system, sampler, sampler.points(0, n)


def _tree_cpu() -> dict[int, float]:
    import psutil

    me = psutil.Process()
    out = {}
    for p in [me, *me.children(recursive=True)]:
        try:
            c = p.cpu_times()
            out[p.pid] = c.user + c.system
        except psutil.Error:
            pass
    return out


def _cpu_delta(before: dict[int, float], after: dict[int, float]) -> float:
    return sum(v - before.get(pid, 0.0) for pid, v in after.items())


def roa_side(name: str, n: int, reps: int) -> dict[str, Any]:
    """Statuses, CPU and wall time of ``roa.basin`` with its defaults."""
    import roa
    from roa.integration import _integrator as I  # noqa: N812
    from roa.integration._kernel_cache import compiled_system

    system, sampler, X = _samples(name, n)
    t0 = time.perf_counter()
    ready, ran, _ = compiled_system(system, "auto", None, n)
    if getattr(ready.numba_fast, "kernel", None) is not None:
        ready.numba_fast.kernel()
    else:  # the system's own kernel: compiled (or loaded) on a first run
        I.integrate_batch(system, X[:1])
    compile_s = time.perf_counter() - t0
    cpu, wall, code = [], [], None
    for _ in range(reps + 1):  # the first call also starts the worker processes
        c0, w0 = _tree_cpu(), time.perf_counter()
        res = roa.basin(system, sampler)
        wall.append(time.perf_counter() - w0)
        cpu.append(_cpu_delta(c0, _tree_cpu()))
        code = res.code
    assert res.backend == ran, (res.backend, ran)
    status = np.where(np.isin(code, [I.CONVERGED, I.LEFT_DOMAIN, I.DIVERGED]), code, 3)
    return {"status": status, "cpu": float(np.median(cpu[1:])), "wall": float(np.median(wall[1:])),
            "compile": compile_s, "backend": res.backend}  # fmt: skip


def jax_namespace() -> SimpleNamespace:
    import jax.numpy as jnp

    fns = {k: getattr(jnp, k) for k in ("sin", "cos", "tan", "sqrt", "arctan", "arcsinh",
                                        "arctanh", "exp", "log", "abs", "minimum", "maximum")}  # fmt: skip
    return SimpleNamespace(**fns, clip=lambda x, lo, hi: jnp.minimum(jnp.maximum(x, lo), hi),
                           name="jax")  # fmt: skip


def peer_side(name: str, n: int, reps: int, setup: str, batch: int) -> dict[str, Any]:
    """Statuses, CPU and wall time of diffrax (run in a process of its own)."""
    import diffrax
    import jax
    import jax.numpy as jnp

    from roa.status import StopRules

    jax.config.update("jax_enable_x64", True)
    system, _, X = _samples(name, n)
    rules = StopRules(t_final=T_FINAL)
    xp = jax_namespace()
    dim = system.n
    x_eq = jnp.asarray(system.x_eq)
    tol, bound = rules.converge_tol, rules.diverge_bound

    def vf(t: Any, y: Any, args: Any) -> Any:
        return jnp.stack([jnp.asarray(v, dtype=y.dtype) * jnp.ones_like(y[0])
                          for v in system.field(t, [y[i] for i in range(dim)], xp)])  # fmt: skip

    conds = [lambda t, y, args, **kw: jnp.linalg.norm(y - x_eq) <= tol]
    if system.margin is not None:
        conds.append(lambda t, y, args, **kw: system.margin([y[i] for i in range(dim)], xp) <= 0.0)
    conds.append(lambda t, y, args, **kw: jnp.linalg.norm(y) >= bound)
    codes = [0, 1, 2] if system.margin is not None else [0, 2]

    def solve(y0: Any) -> Any:
        sol = diffrax.diffeqsolve(
            diffrax.ODETerm(vf), diffrax.Dopri5(), 0.0, T_FINAL, None, y0,
            stepsize_controller=diffrax.PIDController(rtol=RTOL, atol=ATOL),
            saveat=diffrax.SaveAt(t1=True), event=diffrax.Event(conds), max_steps=MAX_STEPS,
            throw=False,
        )  # fmt: skip
        status = jnp.asarray(3)
        for c, m in reversed(list(zip(codes, sol.event_mask, strict=True))):
            status = jnp.where(m, c, status)  # the first rule listed wins within one step
        return status

    if setup == "vmap":
        fn = jax.jit(jax.vmap(solve))
        arg = jnp.asarray(X)

        def run() -> np.ndarray:
            return np.asarray(fn(arg).block_until_ready())
    else:
        dev = jax.local_device_count()
        per = -(-n // (dev * batch))
        pad = np.concatenate([X, np.repeat(X[:1], dev * per * batch - n, axis=0)])
        arg = jnp.asarray(pad.reshape(dev, per, batch, dim))
        fn = jax.pmap(lambda xs: jax.lax.map(jax.vmap(solve), xs))

        def run() -> np.ndarray:
            return np.asarray(fn(arg).block_until_ready()).reshape(-1)[:n]

    cpu, wall = [], []
    for _ in range(reps + 1):
        c0, w0 = time.process_time(), time.perf_counter()
        status = run()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    # at t = 0 roa stops runs already inside the ball / outside the domain / beyond the bound
    g0 = [np.linalg.norm(X - system.x_eq, axis=1) <= tol, ~system.inside(X),
          np.linalg.norm(X, axis=1) >= bound]  # fmt: skip
    for c, m in reversed(list(zip([0, 1, 2], g0, strict=True))):
        status = np.where(m, c, status)
    steady = float(np.median(wall[1:]))
    return {"status": status.tolist(), "cpu": float(np.median(cpu[1:])), "wall": steady,
            "compile": wall[0] - steady, "devices": jax.local_device_count()}  # fmt: skip


def _peer(name: str, n: int, reps: int, setup: str, batch: int) -> dict[str, Any]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    if setup == "tuned":
        env["XLA_FLAGS"] = (env.get("XLA_FLAGS", "") +
                            " --xla_force_host_platform_device_count=2").strip()  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "peer.json"
        cmd = [sys.executable, __file__, "--peer", name, "--setup", setup, "--n", str(n),
               "--reps", str(reps), "--batch", str(batch), "--out", str(out)]  # fmt: skip
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if proc.returncode != 0:
            raise SystemExit(f"peer {name} {setup} failed:\n{proc.stderr[-3000:]}")
        return json.loads(out.read_text())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20000, help="initial conditions per system")
    ap.add_argument("--reps", type=int, default=3, help="timed runs after a first one")
    ap.add_argument("--systems", default="vdp,quad,lyznet,ipc")
    ap.add_argument("--setups", default="tuned,vmap")
    ap.add_argument("--batch", type=int, default=256, help="lax.map batch of the tuned set-up")
    ap.add_argument("--peer", help=argparse.SUPPRESS)
    ap.add_argument("--setup", help=argparse.SUPPRESS)
    ap.add_argument("--out", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.peer:
        res = peer_side(a.peer, a.n, a.reps, a.setup, a.batch)
        Path(a.out).write_text(json.dumps(res))
        return
    missing = [m for m in ("jax", "diffrax", "psutil") if importlib.util.find_spec(m) is None]
    if missing:
        print(f"bench_peers: skipped, {', '.join(missing)} not installed "
              "(pip install '.[bench]' in a clone of roa)")  # fmt: skip
        return
    for name in a.systems.split(","):
        mine = roa_side(name, a.n, a.reps)
        for setup in a.setups.split(","):
            peer = _peer(name, a.n, a.reps, setup, a.batch)
            same = int(np.count_nonzero(np.asarray(peer["status"]) == mine["status"]))
            ours, theirs = a.n / mine["cpu"], a.n / peer["cpu"]
            print(f"peer {name} {setup} roa={ours:.0f}/s peer={theirs:.0f}/s "
                  f"ratio={ours / theirs:.2f} statuses={same}/{a.n}")  # fmt: skip
            print(f"     wall: roa={a.n / mine['wall']:.0f}/s peer={a.n / peer['wall']:.0f}/s "
                  f"ratio={peer['wall'] / mine['wall']:.2f}; "
                  f"compile: roa={mine['compile']:.1f} s ({mine['backend']}) "
                  f"peer={peer['compile']:.1f} s ({peer['devices']} device(s))", flush=True)  # fmt: skip
            if same != a.n:
                diff = np.flatnonzero(np.asarray(peer["status"]) != mine["status"])
                pairs = [(int(mine["status"][k]), int(peer["status"][k])) for k in diff[:5]]
                print(f"     differing statuses (roa, peer) at {diff[:5].tolist()}: {pairs}")


if __name__ == "__main__":
    main()
