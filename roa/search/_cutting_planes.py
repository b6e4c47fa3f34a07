"""Sampled search of a polynomial Lyapunov function: one small convex program per round, no SOS
certificate of the decrease over the field (after Topcu-Packard's simulation-aided search), so no
recast of a non-polynomial field and programs of a few dozen coefficients.

In whitened variables ``y`` (``x = x_eq + M y``, ``y'y = V0 / c0`` with ``c0`` the seed's sampled
level, so the unit ball is the seed's estimate), the candidate is

    ``V(y) = m(y)' G m(y)``,   ``m`` the monomials of degree 1..d/2 (even/odd blocks for odd fields),

with every Gram block ``G_b >= eps I`` (so ``V >= eps |y|^2``, globally proper, and the validation's
Gram cover applies). Its coefficients are linear in ``G``; the constraints are linear at sample
points:

* **decrease**: ``V'(y_s) <= -margin |y_s|^2`` at the cut points ``y_s`` (plus the LMI
  ``-(A'P2 + P2 A) >= margin I`` on the quadratic part, so the validation's local proof applies);
* **targets**: ``V <= 1`` at the ``hard`` points, ``V >= 1 + slack`` at excluded points and
  ``V >= 1`` on a sampled sphere ``|y| = outer``; the mean of ``max(V - 1, 0)`` over the ``soft``
  points is minimised (a convex surrogate of "the share of the soft points in ``{V <= 1}``").

Cutting planes: after each solve, rays from the equilibrium through ``{V <= 1 + slack}`` are
sampled and the points with ``V' > -margin |y|^2 / 2`` (the worst ``cuts`` of them) join the cut
points when a simulation from them reaches the equilibrium (``simulate``), else they are
excluded; when the program turns infeasible the latest cuts are excluded instead. The search
stops when a round finds no violator (rays, then :func:`roa.level_search`'s witness). The
programs are solved in floating point by cvxpy + Clarabel and prove nothing: each candidate is a
:class:`PolynomialLyapunov` (built from its Gram matrix) for :func:`roa.certify`, whose interval
validation alone certifies a level.
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import PolynomialLyapunov, QuadraticLyapunov
from roa.model._system import System
from roa.options import SampleSearchOptions
from roa.search._sdp import lyapunov_form, monomials as sdp_monomials, solve
from roa.search._seed import seed_level


@dataclass(frozen=True)
class SampleRound:
    """One round: solver status, objective (mean hinge on the soft points), cut points, violators
    found afterwards, the sampled level estimate of this round's V (min V over sampled ``V' >= 0``,
    ``None`` when none was found) and seconds."""

    index: int
    status: str
    objective: float | None
    cuts: int
    violators: int
    level: float | None
    seconds: float

    def to_dict(self) -> dict[str, Any]:
        return {"round": self.index, "status": self.status, "objective": self.objective,
                "cuts": self.cuts, "violators": self.violators, "level": self.level,
                "seconds": round(self.seconds, 3)}  # fmt: skip


@dataclass(frozen=True)
class SampleSearchResult:
    """Outcome of :func:`sample_search`: ``V`` the last candidate (level 1 is its target level;
    ``None`` if the first program failed), ``converged`` when the last round found no violator."""

    degree: int
    V: PolynomialLyapunov | None
    converged: bool
    rounds: list[SampleRound]
    seconds: float
    sizes: dict[str, Any] = field(default_factory=dict)
    message: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"method": "sampled cutting planes (cvxpy + Clarabel)", "degree": self.degree,
                "converged": self.converged, "rounds": [r.to_dict() for r in self.rounds],
                "seconds": round(self.seconds, 3), "sizes": self.sizes,
                "message": self.message}  # fmt: skip


def monomials(n: int, degrees: Any) -> np.ndarray:
    """Exponent rows of all monomials in ``n`` variables of the given total degrees (each
    degree's in the order of :func:`roa.search._sdp.monomials`)."""
    rows = [m for d in degrees for m in sdp_monomials(n, d, d)]
    return np.array(rows, dtype=int).reshape(-1, n)


def _powers(Y: np.ndarray, dmax: int) -> np.ndarray:
    """``Y**k`` for k = 0..dmax, shape (dmax + 1, N, n)."""
    out = np.ones((dmax + 1, *Y.shape))
    for k in range(1, dmax + 1):
        out[k] = out[k - 1] * Y
    return out


def _phi(Yp: np.ndarray, E: np.ndarray) -> np.ndarray:
    """Monomials ``E`` at the points whose powers are ``Yp`` (from :func:`_powers`), (N, K)."""
    n = E.shape[1]
    out = np.ones((Yp.shape[1], len(E)))
    for i in range(n):
        out *= Yp[E[:, i], :, i].T
    return out


class _Basis:
    """V's monomials ``E`` (degree 2..d), the Gram blocks and the map Gram entries -> coefficients."""

    def __init__(self, n: int, degree: int, odd_field: bool) -> None:
        self.n, self.degree = n, degree
        half = monomials(n, range(1, degree // 2 + 1))
        parities = (1, 0) if odd_field else (None,)
        self.blocks = [half if p is None else half[half.sum(axis=1) % 2 == p] for p in parities]
        self.blocks = [b for b in self.blocks if len(b)]
        degs = [d for d in range(2, degree + 1) if not odd_field or d % 2 == 0]
        self.E = monomials(n, degs)
        self.index = {tuple(e): k for k, e in enumerate(self.E)}
        self.maps = []  # per block: (K, m*m) matrix, coefficients = map @ vec(G)
        for b in self.blocks:
            m = len(b)
            A = np.zeros((len(self.E), m * m))
            for i, j in itertools.product(range(m), range(m)):
                A[self.index[tuple(b[i] + b[j])], i * m + j] += 1.0
            self.maps.append(A)

    def values(self, Y: np.ndarray) -> np.ndarray:
        return _phi(_powers(Y, self.degree), self.E)

    def derivative_rows(self, Y: np.ndarray, F: np.ndarray) -> np.ndarray:
        """Rows ``r`` with ``V'(y) = r . c`` (``F`` the field in y at ``Y``)."""
        Yp = _powers(Y, self.degree)
        out = np.zeros((len(Y), len(self.E)))
        for i in range(self.n):
            Ei = self.E.copy()
            Ei[:, i] = np.maximum(Ei[:, i] - 1, 0)
            out += self.E[None, :, i] * _phi(Yp, Ei) * F[:, i : i + 1]
        return out


class _Problem:
    """The system in whitened variables and the data of the programs."""

    def __init__(self, system: System, V0: QuadraticLyapunov, scale: float,
                 opts: SampleSearchOptions) -> None:  # fmt: skip
        self.system, self.opts = system, opts
        self.center = np.asarray(V0.center, dtype=float)
        self.n = len(self.center)
        self.W = np.linalg.cholesky(np.asarray(V0.P, dtype=float) / scale).T  # y = W (x - x_eq)
        self.M = np.linalg.inv(self.W)
        odd = _odd(system, self.center, self.M)
        sym = odd if opts.symmetry == "auto" else bool(opts.symmetry)
        if opts.symmetry is True and not odd:
            raise RoaInputError("SampleSearchOptions.symmetry=True needs an odd field")
        self.basis = _Basis(self.n, opts.degree, sym)
        self.A = self._jacobian()
        U = np.random.default_rng(opts.seed + 1).standard_normal((opts.outer_points, self.n))
        self.outer = opts.outer * U / np.linalg.norm(U, axis=1, keepdims=True)
        if not opts.outer:
            self.outer = np.zeros((0, self.n))

    def to_y(self, X: np.ndarray) -> np.ndarray:
        return (np.asarray(X, dtype=float) - self.center) @ self.W.T

    def field(self, Y: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):
            F = self.system.f(self.center + Y @ self.M.T)
        return np.asarray(F @ self.W.T)

    def _jacobian(self) -> np.ndarray:
        h = 1e-6
        E = np.eye(self.n) * h
        return np.asarray((self.field(E) - self.field(-E)).T / (2 * h))

    def rows(self, Y: np.ndarray) -> np.ndarray:
        """Normalised decrease rows ``V'(y) / |y|^2`` (finite fields only)."""
        R = self.basis.derivative_rows(Y, self.field(Y))
        return np.asarray(R / np.sum(Y * Y, axis=1)[:, None])

    def solve(self, S: np.ndarray, hard: np.ndarray, soft: np.ndarray,
              out: np.ndarray) -> tuple[str, Any, Any]:  # fmt: skip
        """One program; returns (status, coefficients, Gram blocks) (None when it failed).
        ``S``: decrease cut points; ``out``: excluded points (``V >= 1 + slack``)."""
        import cvxpy as cp

        b, o = self.basis, self.opts
        G = [cp.Variable((len(bl), len(bl)), symmetric=True) for bl in b.blocks]
        c = cp.Variable(len(b.E))  # explicit: each sample row then has len(E) entries only
        cons: list[Any] = [c == sum(A @ cp.vec(g, order="C")
                                    for A, g in zip(b.maps, G, strict=True))]  # fmt: skip
        cons += [g >> o.positivity * np.eye(g.shape[0]) for g in G]
        cons.append(self.rows(S) @ c <= -o.margin)
        # the quadratic part's linearisation: -(A'P2 + P2 A) >= margin I
        Lm = lyapunov_form(self.A, lambda i, j: c[b.index[tuple(int(a == i) + int(a == j)
                                                                for a in range(self.n))]])  # fmt: skip
        local = o.margin if o.local_margin is None else o.local_margin
        cons.append(Lm >> local * np.eye(self.n))
        if len(hard):
            cons.append(b.values(hard) @ c <= 1.0)
        if len(self.outer):  # {V <= 1} inside the ball |y| < outer (sampled)
            cons.append(b.values(self.outer) @ c >= 1.0)
        if len(out):
            cons.append(b.values(out) @ c >= 1.0 + o.slack)
        obj = cp.mean(cp.pos(b.values(soft) @ c - 1.0)) if len(soft) else cp.Constant(0.0)
        prob = cp.Problem(cp.Minimize(obj), cons)
        res = solve(prob)
        if res.status.startswith("solver error"):
            return "solver error", None, None
        if not (res.usable and all(g.value is not None for g in G)):
            return res.status, None, None
        return res.status, np.asarray(c.value, dtype=float), [np.asarray(g.value) for g in G]

    def violators(
        self, coef: np.ndarray, rng: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray, float | None]:
        """Points of ``{V <= 1 + slack}`` (sampled along rays) with ``V' > -margin |y|^2 / 2``,
        worst first, their scores, and the least V at a sampled point with ``V' >= 0``."""
        o, b = self.opts, self.basis
        U = rng.standard_normal((o.directions, self.n))
        U /= np.linalg.norm(U, axis=1, keepdims=True)
        R = self._radius(coef, U, 1.0 + o.slack)
        s = np.linspace(1.0 / o.radial, 1.0, o.radial)
        Y = (U[:, None, :] * (R[:, None] * s[None, :])[:, :, None]).reshape(-1, self.n)
        vd = self.rows(Y) @ coef
        ok = np.isfinite(vd)
        Y, vd = Y[ok], vd[ok]
        bad = vd > -0.5 * o.margin
        pos = vd >= 0
        level = float(np.min(b.values(Y[pos]) @ coef)) if pos.any() else None
        order = np.argsort(-vd[bad])
        return Y[bad][order], vd[bad][order], level

    def converges(self, Y: np.ndarray) -> np.ndarray:
        """Which points' trajectories (RK4, step ``dt``, up to ``horizon``) enter the ball
        ``|y| < 0.3`` (a simulation; decides whether a violator becomes a decrease cut or an
        excluded point)."""
        o = self.opts
        Y = np.array(Y, dtype=float)
        done = np.zeros(len(Y), dtype=bool)
        dt = o.dt
        for _ in range(int(np.ceil(o.horizon / dt))):
            live = ~done & np.all(np.isfinite(Y), axis=1) & (np.sum(Y * Y, axis=1) < 1e8)
            if not live.any():
                break
            y = Y[live]
            k1 = self.field(y)
            k2 = self.field(y + 0.5 * dt * k1)
            k3 = self.field(y + 0.5 * dt * k2)
            k4 = self.field(y + dt * k3)
            Y[live] = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            done |= np.sum(Y * Y, axis=1) < 0.09
        return done

    def witness_cuts(self, V: PolynomialLyapunov, rng: np.random.Generator) -> np.ndarray:
        """The witness of :func:`roa.level_search` (sampled) and points around it, when its level
        is below ``1 + slack`` (else none)."""
        from roa.search._levelset import level_search
        from roa.status import LevelStatus

        res = level_search(self.system, V, shape="level", method="sampled")
        if (res.status is not LevelStatus.FOUND or res.level is None or res.witness is None
                or res.level >= 1.0 + self.opts.slack):  # fmt: skip
            return np.zeros((0, self.n))
        w = self.to_y(np.asarray(res.witness, dtype=float)[None, :])[0]
        near = w * (1 + 0.03 * rng.standard_normal((64, self.n)))
        Y = np.vstack([w[None, :], near])
        vd = self.rows(Y) @ self.coef(V)
        return np.asarray(Y[np.isfinite(vd) & (vd > -0.5 * self.opts.margin)])

    def coef(self, V: PolynomialLyapunov) -> np.ndarray:
        """V's coefficients on the whitened basis (V in y, by least squares at sample points)."""
        rng = np.random.default_rng(1)
        Y = rng.standard_normal((4 * len(self.basis.E), self.n))
        vals = V.value(self.center + Y @ self.M.T)
        return np.asarray(np.linalg.lstsq(self.basis.values(Y), vals, rcond=None)[0])

    def _radius(self, coef: np.ndarray, U: np.ndarray, cap: float) -> np.ndarray:
        """The first radius along each unit direction where ``V = cap`` (V is proper)."""
        degs = self.basis.E.sum(axis=1)
        P = self.basis.values(U) * coef[None, :]
        a = np.stack([P[:, degs == d].sum(axis=1) for d in range(self.opts.degree + 1)], axis=1)

        def V(r: np.ndarray) -> np.ndarray:
            return np.asarray(np.sum(a * r[:, None] ** np.arange(a.shape[1])[None, :], axis=1))

        lo, hi = np.zeros(len(U)), np.full(len(U), 1e-3)
        for _ in range(80):  # bracket
            grow = V(hi) < cap
            if not grow.any():
                break
            lo, hi = np.where(grow, hi, lo), np.where(grow, 2 * hi, hi)
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            below = V(mid) < cap
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return hi

    def to_lyapunov(self, gram: list[np.ndarray], name: str) -> PolynomialLyapunov:
        """``V(y(x)) = m(W d)' G m(W d)`` as a Gram form in ``d = x - x_eq``: the monomials of
        ``W d`` are linear in those of ``d`` (degree by degree), ``m(W d) = T m(d)``."""
        n = self.n
        full = monomials(n, range(1, self.opts.degree // 2 + 1))
        rng = np.random.default_rng(12345)
        D = rng.standard_normal((4 * len(full), n))
        Pd = _phi(_powers(D, self.opts.degree), full)
        Q = np.zeros((len(full), len(full)))
        for bl, g in zip(self.basis.blocks, gram, strict=True):
            Py = _phi(_powers(D @ self.W.T, self.opts.degree), bl)  # m_b(W d) = T_b m(d)
            T = np.linalg.lstsq(Pd, Py, rcond=None)[0].T
            T[np.abs(T) < 1e-13 * max(1.0, float(np.abs(T).max()))] = 0.0
            Q += T.T @ g @ T
        Q = 0.5 * (Q + Q.T)
        keep = np.flatnonzero(np.abs(Q).max(axis=0) > 0)
        return PolynomialLyapunov.from_gram(full[keep].tolist(), Q[np.ix_(keep, keep)],
                                            self.center, name)  # fmt: skip


def _odd(system: System, center: np.ndarray, M: np.ndarray) -> bool:
    """``f(x_eq - d) = -f(x_eq + d)`` at random points (a sampled test of the odd symmetry)."""
    rng = np.random.default_rng(7)
    D = rng.standard_normal((64, len(center))) @ M.T * 0.5
    with np.errstate(all="ignore"):
        a, b = system.f(center + D), system.f(center - D)
    ok = np.isfinite(a).all(axis=1) & np.isfinite(b).all(axis=1)
    return bool(ok.any() and np.allclose(a[ok], -b[ok], rtol=1e-9, atol=1e-12))


def sample_search(system: System, V0: QuadraticLyapunov, *, hard: Any = None, soft: Any = None,
                  options: SampleSearchOptions | None = None) -> SampleSearchResult:  # fmt: skip
    """A polynomial Lyapunov candidate of degree ``options.degree`` by sampled cutting planes.

    Parameters
    ----------
    system : System
        Autonomous, with an equilibrium (the centre of ``V0``).
    V0 : QuadraticLyapunov
        The seed: fixes the whitening (its sampled level set becomes the unit ball).
    hard : array (k, n), optional
        Points (system coordinates) that must lie in ``{V <= 1}``.
    soft : array (m, n), optional
        Points whose share in ``{V <= 1}`` is to be large (hinge surrogate). Default: uniform
        samples of the seed's level set scaled by ``options.grow``.
    options : SampleSearchOptions, optional

    Returns
    -------
    SampleSearchResult
        ``.V`` is a candidate only; certify it with :func:`roa.certify` (or use
        ``roa.certify`` with :class:`roa.CuttingPlanes`, which does both).
    """
    o = SampleSearchOptions() if options is None else options
    if system.equilibrium is None or system.time_varying:
        raise RoaInputError(f"system {system.name!r} must be autonomous with an equilibrium")
    if not V0.is_quadratic:
        raise RoaInputError(f"V0 must be a QuadraticLyapunov seed, got {type(V0).__name__}")
    t0 = time.perf_counter()
    rng = np.random.default_rng(o.seed)
    scale = seed_level(system, V0)
    pb = _Problem(system, V0, scale, o)
    n = pb.n
    H = _points(pb, hard, "hard")
    Sy = o.grow * _ball(rng, o.soft_points, n) if soft is None else _points(pb, soft, "soft")
    # first cut points: the hard targets and the seed's unit ball
    S = np.vstack([H, _ball(rng, o.initial_cuts, n)])
    S = S[np.sum(S * S, axis=1) > 1e-10]
    S = S[np.all(np.isfinite(pb.rows(S)), axis=1)]
    sizes = {"variables": n, "degree": o.degree, "coefficients": len(pb.basis.E),
             "gram_blocks": [len(b) for b in pb.basis.blocks], "hard": len(H),
             "soft": len(Sy), "seed_level": scale}  # fmt: skip
    rounds: list[SampleRound] = []
    V, converged, message = None, False, ""
    out = np.zeros((0, n))
    last = np.zeros((0, n))  # the latest batch of decrease cuts
    for r in range(o.rounds):
        t1 = time.perf_counter()
        status, coef, gram = pb.solve(S, H, Sy, out)
        if (coef is None or gram is None) and len(last):
            # infeasible with the latest cuts: exclude them (V >= 1 + slack) instead
            S, out = S[: len(S) - len(last)], np.vstack([out, last])
            last = np.zeros((0, n))
            status, coef, gram = pb.solve(S, H, Sy, out)
        if coef is None or gram is None:
            rounds.append(SampleRound(r, status, None, len(S), -1, None, time.perf_counter() - t1))
            message = f"round {r}: program {status}" + ("; kept the last candidate" if V else "")
            break
        obj = float(np.mean(np.maximum(pb.basis.values(Sy) @ coef - 1.0, 0.0))) if len(Sy) else 0.0
        Yb, _, level = pb.violators(coef, rng)
        V = pb.to_lyapunov(gram, f"sampled V degree {o.degree}, round {r}")
        rounds.append(SampleRound(r, status, obj, len(S), len(Yb), level, time.perf_counter() - t1))
        if not len(Yb):  # the rays found none: ask the library's sampled level search
            Yb = pb.witness_cuts(V, rng)
            rounds[-1] = dataclasses.replace(rounds[-1], violators=len(Yb),
                                             seconds=time.perf_counter() - t1)  # fmt: skip
            if not len(Yb):
                converged, message = True, f"no violator after round {r}"
                break
        Yb = Yb[: o.cuts]
        ok = pb.converges(Yb) if o.simulate else np.ones(len(Yb), dtype=bool)
        last = Yb[ok]
        S, out = np.vstack([S, last]), np.vstack([out, Yb[~ok]])
    else:
        message = f"{o.rounds} rounds; violators remain (the validation decides)"
    return SampleSearchResult(o.degree, V, converged, rounds, time.perf_counter() - t0, sizes,
                              message)  # fmt: skip


def _ball(rng: np.random.Generator, k: int, n: int) -> np.ndarray:
    """``k`` uniform points of the unit ball in ``n`` dimensions."""
    g = rng.standard_normal((k, n))
    return np.asarray(g * (rng.random(k) ** (1 / n) / np.linalg.norm(g, axis=1))[:, None])


def _points(pb: _Problem, X: Any, name: str) -> np.ndarray:
    if X is None:
        return np.zeros((0, pb.n))
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] != pb.n:
        raise RoaInputError(f"{name} must be an array of shape (k, {pb.n}), got {X.shape}")
    X = X[np.all(np.isfinite(X), axis=1)]
    return pb.to_y(X)
