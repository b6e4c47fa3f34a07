"""Sparse polynomials (``{exponent tuple: float}``) and polynomial identities as cvxpy constraints.

An :class:`Identity` is ``sum of terms == 0`` coefficient by coefficient (one row per monomial);
terms are constant polynomials, polynomials times a decision variable (scalar or vector: one column
each), free multipliers over a monomial basis, and Gram forms ``b' Q b * g`` with ``Q`` positive
semidefinite (entered with a minus sign: ``... - sigma == 0``). Identities made with
:meth:`Identity.fork` share the decision variables and are solved together.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import scipy.sparse as sps
import sympy as sp

from roa.errors import RoaInputError

Poly = dict[tuple[int, ...], float]


class ProgramTooLarge(RoaInputError):
    """An SOS program whose Gram blocks exceed :data:`roa.search.sos.MAX_GRAM_BLOCK` (not built)."""


def check_block(size: int) -> None:
    """Refuse a Gram block of ``size`` monomials above :data:`roa.search.sos.MAX_GRAM_BLOCK`
    before any work (such programs made the solver request terabytes and abort)."""
    from roa.search.sos import MAX_GRAM_BLOCK

    if size > MAX_GRAM_BLOCK:
        raise ProgramTooLarge(
            f"the SOS program's Gram block would hold {size} monomials, more than the "
            f"{MAX_GRAM_BLOCK} built here (memory would run out): not built; use a lower degree "
            "or fewer states"
        )


def solve_margin(prob: Any, solver_options: dict[str, Any] | None = None) -> tuple[str, bool]:
    """Solve a Gram program (cvxpy; Clarabel unless ``solver_options`` name another solver,
    :mod:`roa.search.sdp_solver`): ``(status, usable)``, ``usable`` for an optimal
    or optimal-inaccurate solution (only a candidate: the exact check decides); a solver error
    is a status, never an exception."""
    import cvxpy as cp

    from roa.search.sdp_solver import solve

    status = solve(prob, solver_options)  # the solver and tolerances: roa.search.sdp_solver
    return status, status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE)


def monomials(nvars: int, max_deg: int, min_deg: int = 0) -> list[tuple[int, ...]]:
    """Exponent tuples of total degree ``min_deg..max_deg`` in ``nvars`` variables."""
    out = []
    for deg in range(min_deg, max_deg + 1):
        for c in itertools.combinations_with_replacement(range(nvars), deg):
            e = [0] * nvars
            for i in c:
                e[i] += 1
            out.append(tuple(e))
    return out


def poly_of(expr: Any, gens: list[sp.Symbol]) -> Poly:
    poly = sp.Poly(sp.expand(expr), *gens)
    return {m: float(c) for m, c in poly.terms() if c != 0}


def mul(a: Poly, b: Poly) -> Poly:
    out: Poly = {}
    for (ma, ca), (mb, cb) in itertools.product(a.items(), b.items()):
        m = tuple(x + y for x, y in zip(ma, mb, strict=True))
        out[m] = out.get(m, 0.0) + ca * cb
    return out


def monomial(m: tuple[int, ...]) -> Poly:
    """The polynomial ``y^m``."""
    return {m: 1.0}


def total_degree(p: Poly) -> int:
    """The total degree of ``p``."""
    return max(sum(m) for m in p)


def add(a: Poly, b: Poly) -> Poly:
    out = dict(a)
    for m, c in b.items():
        out[m] = out.get(m, 0.0) + c
    return out


def poly_sum(ps: list[Poly]) -> Poly:
    """The sum of the polynomials ``ps``."""
    out: Poly = {}
    for p in ps:
        out = add(out, p)
    return out


def power(p: Poly, k: int, nv: int) -> Poly:
    """``p^k`` in ``nv`` variables."""
    out: Poly = {tuple([0] * nv): 1.0}
    for _ in range(k):
        out = mul(out, p)
    return out


def scale(a: Poly, c: float) -> Poly:
    return {m: v * c for m, v in a.items()}


def sub(a: Poly, b: Poly) -> Poly:
    out = dict(a)
    for m, c in b.items():
        out[m] = out.get(m, 0.0) - c
    return out


def diff(m: tuple[int, ...], i: int) -> Poly:
    """d(y^m)/dy_i."""
    if m[i] == 0:
        return {}
    return {tuple(k - (j == i) for j, k in enumerate(m)): float(m[i])}


def is_even(polys: list[Poly], nd: int, *, odd: bool = False) -> bool:
    """Every monomial has even (``odd=True``: odd) total degree in the first ``nd`` variables."""
    return all(sum(m[:nd]) % 2 == int(odd) for p in polys for m in p)


class Identity:
    """``sum of terms == 0``, coefficient by coefficient (see the module docstring)."""

    def __init__(self, nv: int, shared: Identity | None = None) -> None:
        self.nv = nv
        self.rows: dict[tuple[int, ...], int] = {}
        self.parts: list[tuple[list, list, list, Any, int]] = []  # rows, cols, vals, var, ncols
        self.consts: list[Poly] = []
        self.psd: list[Any] = shared.psd if shared is not None else []
        self.frees: list[tuple[list[tuple[int, ...]], Any]] = []
        self.status = "not solved"

    def fork(self) -> Identity:
        return Identity(self.nv, shared=self)

    def _row(self, m: tuple[int, ...]) -> int:
        if m not in self.rows:
            self.rows[m] = len(self.rows)
        return self.rows[m]

    @staticmethod
    def scalar() -> Any:
        import cvxpy as cp

        return cp.Variable()

    @staticmethod
    def vector(n: int) -> Any:
        import cvxpy as cp

        return cp.Variable(n)

    def const(self, poly: Poly) -> None:
        for m in poly:
            self._row(m)
        self.consts.append(poly)

    def linear(self, polys: list[Poly], var: Any) -> None:
        """``sum_k polys[k] * var[k]`` (``var`` a cvxpy scalar/vector or numbers)."""
        if isinstance(var, int | float | np.ndarray):
            vals = np.atleast_1d(np.asarray(var, dtype=float))
            for p, v in zip(polys, vals, strict=True):
                self.const(scale(p, float(v)))
            return
        if getattr(var, "shape", None) == ():
            import cvxpy as cp

            var = cp.hstack([var])
        r, c, v = [], [], []
        for k, p in enumerate(polys):
            for m, coef in p.items():
                r.append(self._row(m))
                c.append(k)
                v.append(coef)
        self.parts.append((r, c, v, var, len(polys)))

    def free(self, poly: Poly, basis: list[tuple[int, ...]]) -> Any:
        """A free multiplier ``sum_k q_k b_k`` times ``poly``; returns its variable."""
        q = self.vector(len(basis))
        self.linear([mul(poly, {b: 1.0}) for b in basis], q)
        self.frees.append((basis, q))
        return q

    def gram(self, basis: list[tuple[int, ...]], times: Poly | None) -> None:
        """``- b' Q b * times`` with ``Q`` PSD."""
        import cvxpy as cp

        if not basis:
            return
        nb = len(basis)
        check_block(nb)
        times = times or {tuple([0] * self.nv): 1.0}
        Q = cp.Variable((nb, nb), symmetric=True)
        self.psd.append(Q >> 0)
        r, c, v = [], [], []
        for i, j in itertools.product(range(nb), range(nb)):
            bij = tuple(x + y for x, y in zip(basis[i], basis[j], strict=True))
            for m, coef in times.items():
                r.append(self._row(tuple(x + y for x, y in zip(bij, m, strict=True))))
                c.append(i * nb + j)
                v.append(-coef)
        self.parts.append((r, c, v, cp.vec(Q, order="C"), nb * nb))

    def constraint(self) -> Any:
        nrow = len(self.rows)
        const = np.zeros(nrow)
        for p in self.consts:
            for m, coef in p.items():
                const[self.rows[m]] += coef
        expr: Any = const
        for rows, cols, vals, var, ncols in self.parts:
            expr = expr + sps.csr_matrix((vals, (rows, cols)), shape=(nrow, ncols)) @ var
        return expr == 0

    def sizes(self, also: list[Identity] | None = None) -> list[int]:
        """Sizes of the Gram blocks of this identity and ``also`` (shared PSD list)."""
        return sorted((int(c.args[0].shape[0]) for c in self.psd), reverse=True)

    def solve(self, objective: Any, *, maximise: bool = True, options: dict[str, Any] | None = None,
              free_index: int | None = None, also: list[Identity] | None = None,
              solver: str = "auto") -> tuple[bool, float | None, Poly | None]:  # fmt: skip
        """Solve; ``(ok, objective value, free multiplier free_index as a Poly)``.

        ``solver``: ``clarabel`` (interior point: accurate, but its KKT systems grow with the cube
        of the Gram blocks' triangle size), ``scs`` (first-order, to 1e-6: much faster on blocks
        of ~100 monomials) or ``auto`` (Clarabel when the largest block is <= 80). Either answer is
        a candidate only: certificates come from the interval validation.
        """
        import cvxpy as cp

        cons = [self.constraint(), *(o.constraint() for o in also or []), *self.psd]
        prob = cp.Problem(cp.Maximize(objective) if maximise else cp.Minimize(objective), cons)
        opts = dict(options or {})
        if solver == "auto":
            solver = "clarabel" if max(self.sizes() or [0]) <= 80 else "scs"
        self.solver = solver
        try:
            if solver == "scs":
                if "time_limit" in opts:
                    opts["time_limit_secs"] = opts.pop("time_limit")
                opts = {"eps_abs": 1e-6, "eps_rel": 1e-6, "max_iters": 50_000, **opts}
                prob.solve(solver=cp.SCS, **opts)
            else:
                if "max_iters" in opts:
                    opts["max_iter"] = opts.pop("max_iters")
                prob.solve(solver=cp.CLARABEL, **opts)
        except cp.error.SolverError as exc:
            self.status = f"solver error: {exc}"
            return False, None, None
        self.status = str(prob.status)
        ok = prob.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) and objective.value is not None
        if not ok:
            return False, None, None
        lam = None
        if free_index is not None:
            basis, q = self.frees[free_index]
            lam = {b: float(x) for b, x in zip(basis, q.value, strict=True) if x != 0.0}
        val = objective.value
        return True, float(np.asarray(val).reshape(-1)[0]), lam


#: Memory budget of one SOS program's interior-point solve (bytes). Clarabel's step on a PSD block
#: of B monomials forms a dense matrix over its B (B + 1) / 2 entries; the process peaked at about
#: 3 x its 8-byte size (16.9 GB for B = 231, a 20-state cubic V'). Beyond the budget a program is
#: refused before it is built (about B = 160 for 4 GiB).
MAX_SDP_BYTES = 4 * 2**30


def sdp_bytes(block: int) -> int:
    """Estimated peak memory of the interior-point solve of a PSD block of ``block`` monomials."""
    entries = block * (block + 1) // 2
    return 3 * 8 * entries**2
