"""Benchmark ladder of the certification from 2 to 30 states (scale issue #23, item 6).

Run: ``python benchmarks/bench_scale.py [--quick] [--only NAME ...]``. Each system runs in its own
process (its peak memory is that process's ``ru_maxrss``) and gets one row:

* ``n``; the SOS level (roa's SOS proposal, ``roa.search._sos_bisection.level_search``, or why
  there is none);
* the certified level and its route: ``roa.certify(system, validator=roa.SosValidator())`` (the
  proposer: the SOS level, else the sampled level search; the exact SOS check, block by block
  when V and V' split over independent blocks of variables);
* the independent optimum of its V: ``min V(x) s.t. V'(x) = 0, V(x) >= 1e-6``, by multistart SLSQP
  (scipy) from the first crossings of V' >= 0 along random rays, with the field written again in
  this file (not roa's) and checked against roa's at random points; closed forms where known
  (Van der Pol: 2.3045 published; poly3d and its rotated copies: 3; the LyZNet 10-state example
  and its decoupled copies: 2025/8, derived in ``tests/search/test_levelset_scale.py``);
* certified / optimum, and a refutation just above: the optimum's point moved out along its ray to
  ``V = 1.0005 x`` the optimum, where ``V' >= 0`` is re-checked at 50 digits (mpmath);
* the SOS proposal's (or level search's), the validation's and the whole certification's seconds
  (and the certification's CPU seconds, the host being shared), the exact back-off's tries (level
  and outcome, the proposal first), and the process's peak memory (``ru_maxrss``) after the
  certification, before anything else;
* for ``n <= 6``, the interval branch and bound on the same level (``roa.certify(level=...)``).

Targets: certified >= 0.99 x the optimum (never above it), 10 states < 60 s, 30 states < 10 min,
peak memory < 8 GiB. The exit status is 1 when a certified level is not below the refuting point,
a refutation is not confirmed at 50 digits, or a level is certified below 0.99 x the optimum (or
not at all); timings and memory are reported, not asserted.

Systems (all polynomial; ``V = (x - x_eq)' P (x - x_eq)``):

* ``vanderpol`` (2): the time-reversed Van der Pol oscillator, the published P;
* ``poly3d`` (3): ``examples/systems/poly3d.py``, V = |x|^2, level 3 (AM-GM);
* ``poly3d-rot-2``, ``poly3d-rot-4`` (6, 12): 2 and 4 copies of poly3d in rotated coordinates
  ``y = Q x`` (Q a seeded random orthogonal matrix): every variable coupled, V = |y|^2, level 3;
* ``lyznet-10d`` (10): LyZNet HSCC'24 example 4 (``examples/systems/lyznet_10d.py``), P from
  A'P + PA = -I;
* ``lyznet-10d-x2``, ``lyznet-10d-x3`` (20, 30): two and three decoupled copies of it;
* ``quadrotor2d`` (6): the planar quadrotor under LyZNet's LQR gain (sin/cos of the pitch,
  ``examples/systems/quadrotor2d.py``), P from A'P + PA = -I: the exact recast route (split by
  sign symmetry), the sampled level search's proposal backed off on the exact route when its
  check fails (``roa.certification._backoff``, every try in the row), no branch and bound;
* ``quadrotor3d`` (9): the quadrotor in space under the LQR gain of its linearisation (sin/cos of
  roll and pitch, ``examples/systems/quadrotor3d.py``), as ``quadrotor2d``;
* ``dense-cubic-20`` (20): ``examples/systems/dense_cubic.py``, every state coupled linearly and
  cubically, V = |x|^2, one dense Gram block of 230 monomials (16 GiB for the interior point):
  sign-symmetry blocks (210 + 20) with the 210 block scaled diagonally dominant
  (``roa.search._sos_program.sdsos``; ``"cone": "sdd"`` blocks, proved by exact dominance);
  closed form ``1 / lambda_max(B)``;
* ``ring-20``, ``ring-30`` (20, 30): ``examples/systems/ring.py``, ``x_i' = -x_i + x_{i+1} / 2 +
  x_i^3`` on a ring, V = |x|^2: every variable coupled to its neighbours (no independent blocks),
  a dense program too large for the memory budget, certified by the sparse (chordal clique)
  route; no closed form (SLSQP only; ``x = e_1`` has V' = 0 at V = 1, an upper bound).
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy import optimize

ROOT = Path(__file__).resolve().parents[1]
QUICK = ("vanderpol", "poly3d", "poly3d-rot-2")
LADDER = ("vanderpol", "poly3d", "poly3d-rot-2", "lyznet-10d", "poly3d-rot-4", "lyznet-10d-x2",
          "lyznet-10d-x3", "ring-20", "ring-30", "quadrotor2d", "quadrotor3d",
          "dense-cubic-20")  # fmt: skip
#: Known optima of V (closed forms or published), beside the SLSQP value.
KNOWN = {"vanderpol": 2.3045, "poly3d": 3.0, "poly3d-rot-2": 3.0, "poly3d-rot-4": 3.0,
         "lyznet-10d": 2025 / 8, "lyznet-10d-x2": 2025 / 8, "lyznet-10d-x3": 2025 / 8}  # fmt: skip


# -- the fields, written here again (arithmetic only: floats, numpy arrays, mpmath numbers) --------
def vanderpol(x: Sequence[Any]) -> list[Any]:
    return [-x[1], x[0] + (x[0] ** 2 - 1) * x[1]]


def poly3d(x: Sequence[Any]) -> list[Any]:
    return [-x[0] + x[1] * x[2], -x[1] + x[0] * x[2], -x[2] + x[0] * x[1]]


def lyznet(x: Sequence[Any]) -> list[Any]:
    x1, x2, x3, x4, x5, x6, x7, x8, x9, x10 = x
    return [-x1 + 0.5 * x2 - 0.1 * x9**2, -0.5 * x1 - x2, -x3 + 0.5 * x4 - 0.1 * x1**2,
            -0.5 * x3 - x4, -x5 + 0.5 * x6 + 0.1 * x7**2, -0.5 * x5 - x6, -x7 + 0.5 * x8,
            -0.5 * x7 - x8, -x9 + 0.5 * x10, -0.5 * x9 - x10 + 0.1 * x2**2]  # fmt: skip


def ring(x: Sequence[Any]) -> list[Any]:
    n = len(x)
    return [-x[i] + 0.5 * x[(i + 1) % n] + x[i] ** 3 for i in range(n)]


def _trig(v: Any, name: str) -> Any:
    """sin or cos of a float, an array or an mpmath number."""
    import mpmath as mp

    if isinstance(v, mp.mpf):
        return getattr(mp, name)(v)
    return getattr(np, name)(v)


def quadrotor2d(x: Sequence[Any]) -> list[Any]:
    """examples/systems/quadrotor2d.py: LyZNet's gain, g = 9.81."""
    u1 = -(1.0 * x[1] + 1.7321 * x[4])
    u2 = -(1.0 * x[0] + 13.5165 * x[2] + 1.938 * x[3] + 5.2946 * x[5])
    s, c = _trig(x[2], "sin"), _trig(x[2], "cos")
    return [x[3], x[4], x[5], 9.81 * s + u1 * s, -9.81 + 9.81 * c + u1 * c, u2 + 0 * x[0]]


def quadrotor3d(x: Sequence[Any]) -> list[Any]:
    """examples/systems/quadrotor3d.py: the LQR gain of its linearisation, g = 9.81."""
    u1 = -(x[2] + 1.7321 * x[5])
    u2 = -(-x[1] - 1.4515 * x[4] + 5.4294 * x[6])
    u3 = -(x[0] + 1.4515 * x[3] + 5.4294 * x[7])
    u4 = -x[8]
    sp_, cp_ = _trig(x[6], "sin"), _trig(x[6], "cos")
    st, ct = _trig(x[7], "sin"), _trig(x[7], "cos")
    T = 9.81 + u1
    return [x[3], x[4], x[5], T * cp_ * st, -T * sp_, T * cp_ * ct - 9.81, u2, u3, u4]


def dense_cubic(mats: tuple[np.ndarray, ...]) -> Callable:
    """x' = (-I + S) x + (x'Bx) x + (x'Cx) T x (examples/systems/dense_cubic.py's matrices)."""
    S, B, C, T = mats
    n = len(S)

    def field(x: Sequence[Any]) -> list[Any]:
        if isinstance(x[0], np.ndarray | float):
            X = np.stack(np.broadcast_arrays(*x), axis=-1)
            b = np.einsum("...i,ij,...j->...", X, B, X)[..., None]
            c = np.einsum("...i,ij,...j->...", X, C, X)[..., None]
            F = -X + X @ S.T + b * X + c * (X @ T.T)
            return list(np.moveaxis(F, -1, 0))
        b = sum(float(B[i, j]) * x[i] * x[j] for i in range(n) for j in range(n))
        c = sum(float(C[i, j]) * x[i] * x[j] for i in range(n) for j in range(n))
        return [-x[i] + sum(float(S[i, j]) * x[j] for j in range(n)) + b * x[i]
                + c * sum(float(T[i, j]) * x[j] for j in range(n)) for i in range(n)]  # fmt: skip

    return field


def copies(block: Callable, size: int, k: int) -> Callable:
    def field(x: Sequence[Any]) -> list[Any]:
        return [v for c in range(k) for v in block(list(x[c * size : (c + 1) * size]))]

    return field


def rotated(field: Callable, Q: list[list[float]]) -> Callable:
    """``y' = Q g(Q' y)`` for ``x' = g(x)``: the same system in coordinates ``y = Q x``."""
    n = len(Q)

    def out(y: Sequence[Any]) -> list[Any]:
        x = [sum(Q[j][i] * y[j] for j in range(n)) for i in range(n)]
        g = field(x)
        return [sum(Q[i][j] * g[j] for j in range(n)) for i in range(n)]

    return out


def case(name: str) -> tuple[Any, Callable, np.ndarray]:
    """roa's system, this file's field and the P of V."""
    import roa

    if name == "vanderpol":
        system = roa.load_system("vanderpol")
        return system, vanderpol, np.asarray(roa.default_lyapunov(system).P)
    if name == "poly3d":
        return roa.load_system(f"{ROOT / 'examples/systems/poly3d.py'}:SYSTEM"), poly3d, np.eye(3)
    if name.startswith("poly3d-rot-"):
        k = int(name.rsplit("-", 1)[1])
        n = 3 * k
        Q = np.linalg.qr(np.random.default_rng(7).standard_normal((n, n)))[0].tolist()
        f = rotated(copies(poly3d, 3, k), Q)
        system = roa.System(name, lambda t, x, xp: tuple(f(x)), (0.0,) * n,
                            tuple(f"y{i + 1}" for i in range(n)), lyapunov=np.eye(n))  # fmt: skip
        return system, f, np.eye(n)
    if name.startswith("lyznet-10d"):
        k = 1 if name == "lyznet-10d" else int(name.rsplit("x", 1)[1])
        attr = {1: "SYSTEM", 2: "SYSTEM_20", 3: "SYSTEM_30"}[k]
        system = roa.load_system(f"{ROOT / 'examples/systems/lyznet_10d.py'}:{attr}")
        return system, copies(lyznet, 10, k), np.asarray(roa.default_lyapunov(system).P)
    if name in ("ring-20", "ring-30"):
        system = roa.load_system(f"{ROOT / 'examples/systems/ring.py'}:SYSTEM_{name[-2:]}")
        return system, ring, np.eye(len(system.x_eq))
    if name in ("quadrotor2d", "quadrotor3d"):
        system = roa.load_system(f"{ROOT / f'examples/systems/{name}.py'}:SYSTEM")
        field = quadrotor2d if name == "quadrotor2d" else quadrotor3d
        return system, field, np.asarray(roa.default_lyapunov(system).P)
    if name.startswith("dense-cubic-"):
        import importlib.util

        spec = importlib.util.spec_from_file_location("dense_cubic",
                                                      ROOT / "examples/systems/dense_cubic.py")  # fmt: skip
        assert spec is not None and spec.loader is not None
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        n = int(name.rsplit("-", 1)[1])
        S, B, C, T = mod.matrices(n)
        KNOWN[name] = float(1.0 / np.linalg.eigvalsh(B)[-1])  # closed form (module docstring)
        return mod.dense_cubic(n), dense_cubic((S, B, C, T)), np.eye(n)
    raise SystemExit(f"unknown system {name!r}; known: {', '.join(LADDER)}")


# -- the independent optimum -----------------------------------------------------------------------
def _vdot(field: Callable, P: np.ndarray, X: np.ndarray) -> np.ndarray:
    F = np.stack([np.broadcast_to(v, X.shape[:-1]) for v in field(list(np.moveaxis(X, -1, 0)))],
                 axis=-1)  # fmt: skip
    return 2.0 * np.einsum("...i,ij,...j->...", X, P, F)


def independent_optimum(field: Callable, P: np.ndarray, *, rays: int = 4000, starts: int = 24,
                        seed: int = 0) -> tuple[float, np.ndarray]:  # fmt: skip
    """min V s.t. V' = 0, V >= 1e-6 (x_eq = 0): multistart SLSQP from the first V' >= 0 along
    random rays (the best ``starts`` of ``rays``). Returns the optimum and its point."""
    n = len(P)
    rng = np.random.default_rng(seed)
    U = rng.standard_normal((rays, n))
    U /= np.sqrt(np.einsum("mi,ij,mj->m", U, P, U))[:, None]  # V(U) = 1
    t = np.geomspace(1e-2, 1e3, 400)
    bad = _vdot(field, P, t[None, :, None] * U[:, None, :]) >= 0
    hit = bad.any(axis=1)
    k = np.argmax(bad, axis=1)
    lo, hi = np.where(k > 0, t[np.maximum(k - 1, 0)], 0.0), t[k]
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        b = _vdot(field, P, mid[:, None] * U) >= 0
        hi, lo = np.where(b, mid, hi), np.where(b, lo, mid)
    order = [i for i in np.argsort(np.where(hit, hi, np.inf)) if hit[i]][:starts]
    if not order:
        raise RuntimeError("no ray reaches V' >= 0 up to V = 1e6")

    def V(x: np.ndarray) -> float:
        return float(x @ P @ x)

    cons = [{"type": "eq", "fun": lambda x: _vdot(field, P, x) / V(x)},
            {"type": "ineq", "fun": lambda x: V(x) - 1e-6}]  # fmt: skip
    best, point = np.inf, None
    for i in order:
        res = optimize.minimize(V, hi[i] * U[i], jac=lambda x: 2 * P @ x, constraints=cons,
                                method="SLSQP", options={"ftol": 1e-14, "maxiter": 1000})  # fmt: skip
        x = res.x
        if V(x) > 1e-6 and abs(_vdot(field, P, x)) <= 1e-9 * V(x) and V(x) < best:
            best, point = V(x), x
    if point is None:
        raise RuntimeError("SLSQP found no point with V' = 0")
    return best, point


def refutation(field: Callable, P: np.ndarray, point: np.ndarray, optimum: float) -> dict:
    """The optimum's point moved out along its ray to V = f x optimum (f = 1.0002 .. 1.001), with
    V' there at 50 digits: the first f where V' >= 0."""
    import mpmath as mp

    with mp.workdps(50):
        Pm = [[mp.mpf(float(v)) for v in row] for row in P]
        n = len(P)
        for f in ("1.0002", "1.0005", "1.001"):
            s = mp.sqrt(mp.mpf(f) * mp.mpf(float(optimum)) / mp.mpf(float(point @ P @ point)))
            x = [s * mp.mpf(float(v)) for v in point]
            fx = field(x)
            Vx = mp.fsum(x[i] * Pm[i][j] * x[j] for i in range(n) for j in range(n))
            Vd = 2 * mp.fsum(x[i] * Pm[i][j] * fx[j] for i in range(n) for j in range(n))
            if Vd >= 0:
                return {"confirmed": bool(Vx <= mp.mpf("1.001") * mp.mpf(float(optimum))),
                        "V": float(Vx), "ratio": float(Vx / mp.mpf(float(optimum))),
                        "vdot": mp.nstr(Vd, 8), "digits": 50}  # fmt: skip
    return {"confirmed": False, "V": None, "ratio": None, "vdot": None, "digits": 50}


# -- one system ------------------------------------------------------------------------------------
def measure(name: str, *, bnb: bool = True) -> dict[str, Any]:
    import roa

    system, field, P = case(name)
    n = len(P)
    X = np.random.default_rng(1).uniform(-1, 1, (5, n))
    ours = np.stack([np.asarray(v, float) for v in field(list(X.T))], axis=1)
    theirs = np.asarray(system.f(X), float)
    assert np.allclose(ours, theirs, rtol=1e-12, atol=1e-12), f"{name}: the fields differ"
    assert np.allclose(P, roa.default_lyapunov(system).P, rtol=1e-10, atol=1e-12)
    row: dict[str, Any] = {"system": name, "n": n}
    t0, c0 = time.perf_counter(), time.process_time()
    cert = roa.certify(system, validator=roa.SosValidator())  # SOS level, else the sampled one
    row["certify_seconds"] = time.perf_counter() - t0
    row["certify_cpu_seconds"] = time.process_time() - c0  # this process (the host is shared)
    # the process's peak so far: loading, the fields' check and the certification
    row["peak_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    row["status"] = cert.status.value
    row["level"] = cert.level
    meta = cert.validation.meta if cert.validation is not None else {}
    row["route"] = f"{cert.level_source} -> {cert.method}"
    if meta.get("route") == "sparse":
        cl = meta["blocks"]["cliques"]
        row["route"] += f", sparse: {len(cl)} cliques <= {max(cl)}"
    row["sos_level"] = None if cert.sos is None else cert.sos.level
    row["sos_message"] = "" if cert.sos is None or cert.sos.level else cert.sos.message[:90]
    row["sos_seconds"] = None if cert.sos is None else cert.sos.seconds
    row["search_seconds"] = None if cert.search is None else cert.search.seconds
    checks = [s for s in cert.trace if str(s.get("stage", "")).startswith("validate")]
    row["check_seconds"] = sum(float(s.get("seconds", 0.0)) for s in checks)
    row["gram_sizes"] = meta.get("gram_sizes")
    if meta.get("route") == "sdsos":
        row["route"] += (
            f", SDSOS: sign blocks {meta['blocks'].get('sign_blocks')}, "
            f"SDD {meta['blocks'].get('sdd_blocks')}"
        )
    row["backoff"] = [(t["level"], t["status"], round(t["seconds"], 1))
                      for t in meta.get("backoff", [])]  # fmt: skip
    row["interval_in_trace"] = any(s.get("by") == "interval" for s in cert.trace)
    row["message"] = cert.message[:160]
    if bnb and n <= 6 and cert.level is not None:
        t0 = time.perf_counter()
        box = roa.certify(system, level=cert.level, validator="interval")
        row["bnb"] = {"status": box.status.value, "seconds": time.perf_counter() - t0,
                      "boxes": None if box.validation is None else box.validation.boxes}  # fmt: skip
    t0 = time.perf_counter()
    opt, point = independent_optimum(field, P)
    row["optimum"], row["optimum_seconds"] = opt, time.perf_counter() - t0
    row["known"] = KNOWN.get(name)
    row["refutation"] = refutation(field, P, point, opt)
    return row


def verdicts(row: dict[str, Any]) -> list[str]:
    """What fails in a row (an empty list: it passes)."""
    out = []
    ref = row["refutation"]
    if not ref["confirmed"]:
        out.append("refutation above not confirmed at 50 digits")
    if row["status"] != "certified" or row["level"] is None:
        out.append(f"not certified ({row['status']})")
        return out
    if ref["V"] is not None and row["level"] >= ref["V"]:
        out.append(f"certified level {row['level']} is not below the refuting point V = {ref['V']}")
    if row["level"] < 0.99 * row["optimum"]:
        out.append(f"certified {row['level'] / row['optimum']:.4f} < 0.99 of the optimum")
    return out


def _fmt(x: Any, spec: str = ".4g") -> str:
    return "-" if x is None else format(x, spec)


def _tries(tries: Any) -> str:
    """The exact back-off's tries as ``level: outcome`` (the proposal first)."""
    if not tries:
        return "-"
    return "; ".join(f"{lv:.6g} {'ok' if st == 'certified' else 'no'}" for lv, st, _ in tries)


def table(rows: list[dict[str, Any]]) -> str:
    head = ("| system | n | SOS level | certified level (route) | certified / optimum | optimum "
            "(SLSQP; known) | refuted at V / optimum | propose s (SOS; search) | check s | "
            "total s (CPU s) | peak MiB | Gram blocks (largest) | exact back-off tries | "
            "B&B same level |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")  # fmt: skip
    lines = [head]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['system']} | {r.get('n', '-')} | {r['error']} |" + " |" * 12)
            continue
        ratio = None if r["level"] is None else r["level"] / r["optimum"]
        bnb = r.get("bnb")
        bnb_s = "-" if bnb is None else f"{bnb['status']}, {bnb['seconds']:.1f} s"
        sos = _fmt(r["sos_level"], ".7g") if r["sos_level"] else "none"
        g = r["gram_sizes"] or []
        grams = f"{len(g)} ({max(g)})" if g else "-"
        ref = r["refutation"]
        refuted = f"{ref['ratio']:.4f}" if ref["confirmed"] else "not confirmed"
        lines.append(
            f"| {r['system']} | {r['n']} | {sos} | {_fmt(r['level'], '.7g')} ({r['route']}) | "
            f"{_fmt(ratio, '.5f')} | {r['optimum']:.7g}; {_fmt(r['known'], '.7g')} | {refuted} | "
            f"{_fmt(r['sos_seconds'], '.1f')}; {_fmt(r['search_seconds'], '.1f')} | "
            f"{r['check_seconds']:.1f} | "
            f"{r['certify_seconds']:.1f} ({_fmt(r.get('certify_cpu_seconds'), '.1f')}) | "
            f"{r['peak_mib']:.0f} | {grams} | {_tries(r.get('backoff'))} | {bnb_s} |"
        )
    return "\n".join(lines)


# -- beyond quadratic V: the V-s iteration of degree 4 against the quadratic ---------------------
def volume_shares(Vs: list[tuple[Any, float]], half: np.ndarray, *, samples: int = 200_000,
                  seed: int = 0) -> list[tuple[float, float]]:  # fmt: skip
    """Share of the box ``[-half, half]`` (around the origin) inside each ``{V <= level}``, with
    its binomial standard error, from the same uniform samples."""
    from roa.model._backend import namespace

    X = np.random.default_rng(seed).uniform(-half, half, (samples, len(half)))
    out = []
    for V, level in Vs:
        vals = np.asarray(V.expr(list(X.T), namespace("numpy")), float)
        p = float(np.mean(vals <= level))
        out.append((p, float(np.sqrt(max(p * (1 - p), 1e-300) / samples))))
    return out


def measure_vs(name: str, budget: float = 600.0, *, objective: str = "volume", reach: float = 1.5,
               rounds: int = 8) -> dict[str, Any]:  # fmt: skip
    """The quadratic V's certified set against the degree-4 V-s iteration's, both proved by the
    exact SOS route (``roa.SosValidator()``): ``roa.certify(system, degree=4,
    vs=VsOptions(objective=..., budget=...))``, the search within ``budget`` seconds. Their volume
    shares of a box twice the quadratic set's bounding box (a lower bound of the volume ratio
    when the degree-4 set leaves the box), the degree-4 V's positive definiteness proved exactly
    (its Gram matrix, exact LDL'), and a refutation just above its level: the least V at the
    first ``V' >= 0`` along random rays, polished by SLSQP (``min V s.t. V' = 0``), the point
    moved out along its ray to ``V = (1 + r) x`` the level (``r =
    2e-4 .. 1e-2``) with ``V' >= 0`` re-checked at 50 digits, V and V' from V's monomials and this
    file's field."""
    import roa
    from roa.options import VsOptions

    system, field, P = case(name)
    row: dict[str, Any] = {"system": name, "n": len(P)}
    t0, c0 = time.perf_counter(), time.process_time()
    quad = roa.certify(system, validator=roa.SosValidator())
    row["quadratic"] = {"status": quad.status.value, "level": quad.level, "method": quad.method,
                        "seconds": time.perf_counter() - t0,
                        "cpu_seconds": time.process_time() - c0}  # fmt: skip
    t0, c0 = time.perf_counter(), time.process_time()
    vs = VsOptions(budget=budget, objective=objective, reach=reach, rounds=rounds)
    four = roa.certify(system, degree=4, vs=vs, validator=roa.SosValidator())
    row["quartic"] = {"status": four.status.value, "level": four.level, "method": four.method,
                      "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0,
                      "vs": None if four.vs is None else four.vs.to_dict(),
                      "V": four.V.name if four.V is not None else None,
                      "message": four.message[:300]}  # fmt: skip
    row["peak_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    if quad.level is None or four.level is None or four.status.value != "certified":
        return row
    half = 2 * np.sqrt(quad.level * np.diag(np.linalg.inv(P)))
    (pq, eq), (p4, e4) = volume_shares([(quad.V, quad.level), (four.V, four.level)], half,
                                       samples=2_000_000)  # fmt: skip
    row["box_half_widths"] = half.tolist()
    row["shares"] = {"quadratic": [pq, eq], "quartic": [p4, e4]}
    row["volume_ratio"] = p4 / pq if pq > 0 else None
    row["volume_ratio_error"] = (p4 / pq) * float(np.hypot(eq / pq, e4 / p4)) if pq > 0 else None
    row["quartic_pd_exact"] = _pd_exact(four.V)
    row["quartic_V"] = four.V.describe()
    row["quartic_refutation"] = poly_refutation(field, four.V, float(four.level))
    return row


def _poly_terms(V: Any) -> list[tuple[tuple[int, ...], float]]:
    return [(tuple(int(k) for k in m), float(c)) for m, c in (V.polynomial_view() or {}).items()]


def _poly_eval(terms: list, field: Callable, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """V and V' = grad V . f at the rows of X (V's monomials, this file's field)."""
    F = np.stack([np.broadcast_to(v, X.shape[:1]) for v in field(list(X.T))], axis=1)
    val, der = np.zeros(len(X)), np.zeros(len(X))
    for m, c in terms:
        e = np.asarray(m)
        val += c * np.prod(X**e, axis=1)
        for i in np.nonzero(e)[0]:
            e2 = e.copy()
            e2[i] -= 1
            der += c * e[i] * np.prod(X**e2, axis=1) * F[:, i]
    return val, der


def _polish(terms: list, field: Callable, X: np.ndarray, vals: np.ndarray, *,
            starts: int) -> tuple[np.ndarray, float]:  # fmt: skip
    """The least ``V`` found by SLSQP (``min V s.t. V' / |x|^2 = 0``) from the ``starts`` lowest
    ray crossings ``X`` (V ``vals``), and its point; the lowest crossing when none improves."""

    def one(fn: int) -> Callable[[np.ndarray], float]:
        return lambda z: (
            float(_poly_eval(terms, field, z[None, :])[fn][0])
            / (1.0 if fn == 0 else max(float(z @ z), 1e-12))
        )

    best = (X[int(np.argmin(vals))], float(np.min(vals)))
    for k in np.argsort(vals)[:starts]:
        res = optimize.minimize(one(0), X[k], method="SLSQP", options={"maxiter": 300},
                                constraints=[{"type": "eq", "fun": one(1)}])  # fmt: skip
        v = one(0)(res.x)
        if res.success and abs(one(1)(res.x)) < 1e-9 and 1e-6 < v < best[1]:
            best = (res.x, v)
    return best


def poly_refutation(field: Callable, V: Any, level: float, *, rays: int = 3000,
                    seed: int = 0, polish: int = 40) -> dict[str, Any]:  # fmt: skip
    """The least V at the first ``V' >= 0`` along random rays (bisected), polished by SLSQP
    (``min V s.t. V' = 0`` from the ``polish`` lowest crossings), and that point moved out along
    its ray to ``V = (1 + r) x level`` for the first ``r`` in 2e-4 .. 1e-2 where ``V' >= 0`` holds
    at 50 digits (mpmath): a point of ``{V <= (1 + r) level}`` where V does not decrease.
    ``x_eq = 0``."""
    import mpmath as mp

    terms = _poly_terms(V)
    n = V.n
    U = np.random.default_rng(seed).standard_normal((rays, n))
    t = np.geomspace(1e-2, 1e2, 300)
    out: dict[str, Any] = {"confirmed": False, "ratio": None, "digits": 50}
    lo_all = []
    for chunk in np.array_split(np.arange(rays), 10):
        X = (t[None, :, None] * U[chunk, None, :]).reshape(-1, n)
        der = _poly_eval(terms, field, X)[1].reshape(len(chunk), len(t))
        hit = der >= 0
        ok = hit.any(axis=1) & ~hit[:, 0]
        k = np.argmax(hit, axis=1)
        lo_all += [(chunk[i], t[k[i] - 1], t[k[i]]) for i in np.nonzero(ok)[0]]
    if not lo_all:
        return out
    idx = np.array([a for a, _, _ in lo_all])
    lo, hi = np.array([b for _, b, _ in lo_all]), np.array([c for _, _, c in lo_all])
    Ui = U[idx]
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        up = _poly_eval(terms, field, mid[:, None] * Ui)[1] >= 0
        lo, hi = np.where(up, lo, mid), np.where(up, mid, hi)
    vals = _poly_eval(terms, field, hi[:, None] * Ui)[0]
    best = int(np.argmin(vals))
    out["crossing_V"], out["crossing_over_level"] = float(vals[best]), float(vals[best] / level)
    x = _polish(terms, field, hi[:, None] * Ui, vals, starts=polish)
    out["polished_V"], out["polished_over_level"] = float(x[1]), float(x[1] / level)
    u = x[0] / np.linalg.norm(x[0])
    reach = float(np.linalg.norm(x[0]))
    with mp.workdps(50):
        um = [mp.mpf(float(v)) for v in u]

        def at(s: Any) -> tuple[Any, Any]:
            x = [s * v for v in um]
            fx = field(x)
            val, der = mp.mpf(0), mp.mpf(0)
            for m, c in terms:
                cm = mp.mpf(c)
                val += cm * mp.fprod(x[i] ** m[i] for i in range(n))
                for i in range(n):
                    if m[i]:
                        e = list(m)
                        e[i] -= 1
                        der += cm * m[i] * mp.fprod(x[j] ** e[j] for j in range(n)) * fx[i]
            return val, der

        for r in ("0.0002", "0.0005", "0.001", "0.0015", "0.002", "0.003", "0.005", "0.01"):
            target = (1 + mp.mpf(r)) * mp.mpf(level)
            a, b = mp.mpf(0), mp.mpf(reach) * 4
            for _ in range(200):  # V(s u) = target on the ray (V grows along it up there)
                m_ = (a + b) / 2
                a, b = (m_, b) if at(m_)[0] < target else (a, m_)
            val, der = at(b)
            if der >= 0:
                out.update(confirmed=True, ratio=float(val / mp.mpf(level)), V=float(val),
                           vdot=mp.nstr(der, 8))  # fmt: skip
                break
    return out


def _pd_exact(V: Any) -> bool:
    """V >= mu |d|^2 proved by its Gram matrix (roa.proof._cover.gram_cover, exact LDL')."""
    from roa.proof._cover import gram_cover

    return gram_cover(V, 1.0) is not None


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help=f"only {', '.join(QUICK)}")
    ap.add_argument("--only", nargs="+", default=None, help="these systems")
    ap.add_argument("--one", default=None, help=argparse.SUPPRESS)  # the child process
    ap.add_argument("--no-bnb", action="store_true", help="skip the branch and bound column")
    ap.add_argument("--json", default=None, help="also write the rows to this JSON file")
    ap.add_argument("--from-json", default=None, help="print the table of rows written by --json")
    ap.add_argument("--vs", default=None, help="the degree-4 V-s rung of this system instead")
    ap.add_argument("--vs-budget", type=float, default=600.0, help="its search budget, seconds")
    ap.add_argument(
        "--vs-objective",
        default="volume",
        choices=("volume", "shape"),
        help="the V-s iteration's objective (VsOptions.objective)",
    )
    ap.add_argument("--vs-reach", type=float, default=1.5, help="VsOptions.reach")
    ap.add_argument("--vs-rounds", type=int, default=8, help="VsOptions.rounds")
    args = ap.parse_args(argv)
    if args.vs:
        r = measure_vs(args.vs, args.vs_budget, objective=args.vs_objective,
                       reach=args.vs_reach, rounds=args.vs_rounds)  # fmt: skip
        print(json.dumps(r, indent=1, default=float))
        ratio, err = r.get("volume_ratio"), r.get("volume_ratio_error")
        ref = r.get("quartic_refutation") or {}
        ok = (ratio is not None and ratio - 2 * err >= 2 and r["quartic_pd_exact"]
              and r["quartic"]["method"] == "sos-exact" and ref.get("confirmed"))  # fmt: skip
        q, f = r["quadratic"], r["quartic"]
        print(f"{args.vs}: quadratic {q['level']} ({q['method']}, {q['seconds']:.0f} s, CPU "
              f"{q['cpu_seconds']:.0f} s), degree 4 {f['level']} ({f['status']}, {f['method']}, "
              f"{f['seconds']:.0f} s, CPU {f['cpu_seconds']:.0f} s), volume ratio {ratio} +- "
              f"{err}, V positive definite (exact) {r.get('quartic_pd_exact')}, refuted at "
              f"{ref.get('ratio')} x the level: {'holds' if ok else 'FAILS'} (>= 2)")  # fmt: skip
        return 0 if ok else 1
    if args.from_json:
        print(table(json.loads(Path(args.from_json).read_text())))
        return 0
    if args.one:
        print("RESULT " + json.dumps(measure(args.one, bnb=not args.no_bnb), default=float))
        return 0
    names = args.only or (QUICK if args.quick else LADDER)
    rows = []
    for name in names:
        cmd = [sys.executable, __file__, "--one", name] + (["--no-bnb"] if args.no_bnb else [])
        try:
            out = subprocess.run(cmd, capture_output=True, text=True, timeout=1800)
        except subprocess.TimeoutExpired:
            rows.append({"system": name, "error": "timed out after 1800 s"})
            continue
        lines = [ln for ln in out.stdout.splitlines() if ln.startswith("RESULT ")]
        if out.returncode or not lines:
            rows.append({"system": name, "error": f"failed: {out.stderr.strip()[-300:]}"})
            continue
        rows.append(json.loads(lines[-1][len("RESULT ") :]))
        r = rows[-1]
        print(f"{name}: n = {r['n']}, {r['status']} {r['level']}, optimum {r['optimum']:.9g}, "
              f"{r['certify_seconds']:.1f} s, {r['peak_mib']:.0f} MiB", flush=True)  # fmt: skip
    print(table(rows))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=float))
    failed = [(r["system"], v) for r in rows for v in (["error"] if "error" in r else verdicts(r))]
    for name, why in failed:
        print(f"FAIL {name}: {why}")
    print("all ladder checks hold" if not failed else f"{len(failed)} check(s) failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
