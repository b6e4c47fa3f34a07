"""The one semidefinite program of the SOS engine: a polynomial identity and one solve.

A :class:`Program` is a polynomial identity ``sum of terms == 0``, coefficient by coefficient
(one row per monomial), whose terms are constant polynomials, polynomials times decision variables
(scalars or vectors, one column each), free multipliers over a monomial basis and Gram forms
``sign * b' Q b * times`` with ``Q`` positive semidefinite (or ``Q >= t I`` for a common margin
``t``); a Gram form may also carry ``level * b' Q b * times_level`` with ``level`` a cvxpy
parameter, so that a program compiled once is re-solved at many levels. Programs made with
:meth:`Program.fork` share the positive semidefinite constraints and are solved together.

:func:`solve` is the one call of a solver (cvxpy; Clarabel by default, any installed cvxpy solver
by name) and maps its status to one of :data:`GROUPS`, as cvxpy groups them: ``optimal``,
``inaccurate`` (a solution, to a lower accuracy), ``infeasible`` and ``error`` (any other status,
or the solver raised). A solution of either of the first two groups is a *candidate* only: the
exact checks of :mod:`roa.proof` decide.

The solver is an option: ``solver`` (or the key ``"solver"`` of the options) names it, and
``"auto"`` takes Clarabel when the largest positive semidefinite block holds at most
:data:`AUTO_SCS_BLOCK` monomials and its memory estimate fits :data:`MAX_SDP_BYTES`, else SCS
(first order, memory linear in the program's size, less accurate: the exact check decides
anyway). :func:`choose_solver` gives that choice from the blocks' sizes before a program is
built (or refuses one too large for both); :func:`settings` writes a tolerance and an iteration
limit in each solver's keywords.

A Gram block may be *scaled diagonally dominant* (``cone="sdd"``, Ahmadi and Majumdar's SDSOS):
``Q = t I + sum_{i<j} E_ij(a, b, c)``, one 2 x 2 positive semidefinite block ``[[a, c], [c, b]]``
(a second-order cone) per pair of monomials at rows ``(i, j)``. A restriction of the PSD block
(such ``Q`` are positive definite), whose memory grows with the pairs (:func:`sdd_bytes`), not
with their square.

Every program is bounded before it is built: a Gram block above :data:`MAX_GRAM_BLOCK` monomials
or an estimated interior-point memory above :data:`MAX_SDP_BYTES` (:func:`sdp_bytes`) is refused.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sps

from roa.errors import RoaInputError
from roa.proof._sos_check import mono_add as _madd

Poly = dict[tuple[int, ...], float]

#: Largest Gram block a program is built with (beyond it the interior-point solver's memory grows
#: past this machine's).
MAX_GRAM_BLOCK = 400

#: Memory budget of one SOS program's interior-point solve (bytes). Clarabel's step on a PSD block
#: of B monomials forms a dense matrix over its B (B + 1) / 2 entries; the estimate
#: (:func:`sdp_bytes`) takes the process's peak as 3 x its 8-byte size. Beyond the budget a
#: program is refused before it is built (about B = 160 for 4 GiB).
MAX_SDP_BYTES = 4 * 2**30

#: The status groups of :func:`solve` (cvxpy's grouping of solver statuses).
GROUPS = ("optimal", "inaccurate", "infeasible", "error")

#: Solvers by name (``auto``: Clarabel up to :data:`AUTO_SCS_BLOCK` monomials per block, else SCS).
SOLVERS = ("auto", "clarabel", "scs")
AUTO_SCS_BLOCK = 80


def sdp_bytes(block: int) -> int:
    """Estimated peak memory of the interior-point solve of a PSD block of ``block`` monomials."""
    entries = block * (block + 1) // 2
    return 3 * 8 * entries**2


def sdd_bytes(block: int) -> int:
    """Estimated memory of a scaled diagonally dominant block of ``block`` monomials (three
    variables and one 3-dimensional cone per pair, a few dozen doubles of solver data each)."""
    return 8 * 40 * 3 * (block * (block - 1) // 2 + block)


def scs_bytes(blocks: list[int], rows: int, nonzeros: int) -> int:
    """Estimated peak memory of SCS on PSD blocks of ``blocks`` monomials, ``rows`` equality rows
    and ``nonzeros`` nonzeros: the factorisation of the sparse ``[I A'; A -I]`` (a few times its
    nonzeros), a few copies of every vector and the largest block's eigendecomposition."""
    entries = sum(m * (m + 1) // 2 for m in blocks)
    return 8 * (20 * nonzeros + 12 * (entries + rows) + 4 * max(blocks, default=0) ** 2)


@dataclass(frozen=True)
class SolverChoice:
    """The solver :func:`choose_solver` picked (``"clarabel"``, ``"scs"``; None: too large for
    either, not to be built), both memory estimates and the reason."""

    solver: str | None
    ipm_bytes: int
    scs_bytes: int
    reason: str


def choose_solver(blocks: list[int], rows: int = 0, nonzeros: int = 0, solver: str = "auto", *,
                  budget: int | None = None) -> SolverChoice:  # fmt: skip
    """The solver of a program with PSD blocks of ``blocks`` monomials, before it is built:
    ``"auto"`` as :func:`solve` (Clarabel for blocks up to :data:`AUTO_SCS_BLOCK` that fit
    ``budget``, default :data:`MAX_SDP_BYTES`, else SCS if its estimate fits); a named solver
    is kept when its estimate fits, else refused (``solver`` None)."""
    if solver not in SOLVERS:
        raise RoaInputError(f"solver must be one of {SOLVERS}, got {solver!r}")
    budget = MAX_SDP_BYTES if budget is None else budget
    ipm = sum(sdp_bytes(m) for m in blocks)
    scs = scs_bytes(blocks, rows, nonzeros)
    gib = 2**30
    small = max(blocks, default=0) <= AUTO_SCS_BLOCK
    if ipm <= budget and (solver == "clarabel" or (solver == "auto" and small)):
        return SolverChoice("clarabel", ipm, scs,
                            f"interior point: an estimated {ipm / gib:.3g} GiB")  # fmt: skip
    if solver == "clarabel":
        return SolverChoice(None, ipm, scs, f"the interior-point solver needs an estimated "
                            f"{ipm / gib:.3g} GiB (budget {budget / gib:.3g} GiB): not built")  # fmt: skip
    if scs <= budget:
        return SolverChoice("scs", ipm, scs, f"first order (SCS): an estimated {scs / gib:.3g} "
                            f"GiB; the interior point would need {ipm / gib:.3g} GiB")  # fmt: skip
    return SolverChoice(None, ipm, scs, f"an estimated {scs / gib:.3g} GiB even for the "
                        f"first-order solver (budget {budget / gib:.3g} GiB): not built")  # fmt: skip


def settings(solver: str = "clarabel", tolerance: float | None = None,
             max_iter: int | None = None) -> dict[str, Any]:  # fmt: skip
    """Solver options naming ``solver`` with ``tolerance`` (gaps and feasibility, relative and
    absolute) and ``max_iter`` in that solver's keywords (``"auto"``: Clarabel's)."""
    if solver not in SOLVERS:
        raise RoaInputError(f"solver must be one of {SOLVERS}, got {solver!r}")
    if tolerance is not None and (isinstance(tolerance, bool)
                                  or not isinstance(tolerance, float | int)
                                  or not 0 < tolerance < 1):  # fmt: skip
        raise RoaInputError(f"tolerance must be a number in (0, 1), got {tolerance!r}")
    if max_iter is not None and (isinstance(max_iter, bool) or not isinstance(max_iter, int)
                                 or max_iter < 1):  # fmt: skip
        raise RoaInputError(f"max_iter must be a positive integer, got {max_iter!r}")
    out: dict[str, Any] = {"solver": solver}
    if tolerance is not None:
        t = float(tolerance)
        if solver == "scs":
            out.update(eps_abs=t, eps_rel=t)
        else:
            out.update(tol_gap_abs=t, tol_gap_rel=t, tol_feas=t)
    if max_iter is not None:
        out["max_iters" if solver == "scs" else "max_iter"] = max_iter
    return out


class ProgramTooLarge(RoaInputError):
    """An SOS program whose Gram blocks exceed :data:`MAX_GRAM_BLOCK` (not built)."""


def check_block(size: int) -> None:
    """Refuse a Gram block of ``size`` monomials above :data:`MAX_GRAM_BLOCK` before any work
    (such programs made the solver request terabytes and abort)."""
    if size > MAX_GRAM_BLOCK:
        raise ProgramTooLarge(f"the SOS program's Gram block would hold {size} monomials, more "
                              f"than the {MAX_GRAM_BLOCK} built here (memory would run out): not "
                              "built; use a lower degree or fewer states")  # fmt: skip


@dataclass(frozen=True)
class Solved:
    """Outcome of :func:`solve`: ``group`` one of :data:`GROUPS`, ``status`` the solver's own
    word (or ``solver error: ...``), the solver used and the seconds of the solve."""

    group: str
    status: str
    solver: str
    seconds: float

    @property
    def usable(self) -> bool:
        """A solution to use as a candidate (optimal or inaccurate)."""
        return self.group in ("optimal", "inaccurate")


#: SCS's status value for a solve it stopped on SIGINT (Ctrl-C): SCS catches the signal itself
#: and cvxpy reports a solver error, so the interruption would be taken for a failed program.
SCS_SIGINT = -5


def interruptible_scs() -> Any:
    """cvxpy's SCS interface as a custom solver that turns SCS's SIGINT status into
    :class:`KeyboardInterrupt` (the run ends as interrupted, not with a candidate)."""
    from cvxpy.reductions.solvers.conic_solvers.scs_conif import SCS

    class InterruptibleSCS(SCS):  # type: ignore[misc]
        def name(self) -> str:
            return "ROA_SCS"

        def solve_via_data(self, data: Any, warm_start: bool, verbose: bool, solver_opts: Any,
                           solver_cache: Any = None) -> Any:  # fmt: skip
            results = super().solve_via_data(data, warm_start, verbose, solver_opts, solver_cache)
            info = results.get("info", {})
            if info.get("status_val", info.get("statusVal")) == SCS_SIGINT:
                raise KeyboardInterrupt("the SDP solver SCS was interrupted (SIGINT)")
            return results

    return InterruptibleSCS()


def _options(solver: str, options: dict[str, Any] | None) -> dict[str, Any]:
    """``options`` in the solver's own names (``time_limit`` and ``max_iters`` are accepted for
    either)."""
    opts = dict(options or {})
    if solver == "SCS":
        if "time_limit" in opts:
            opts["time_limit_secs"] = opts.pop("time_limit")
        return {"eps_abs": 1e-6, "eps_rel": 1e-6, "max_iters": 50_000, **opts}
    if solver == "CLARABEL" and "max_iters" in opts:
        opts["max_iter"] = opts.pop("max_iters")
    return opts


def psd_sizes(constraints: list[Any]) -> list[int]:
    """The sizes of the positive semidefinite ones of cvxpy ``constraints``."""
    import cvxpy as cp

    return [int(c.args[0].shape[0]) for c in constraints if isinstance(c, cp.constraints.PSD)]


def solve(problem: Any, *, solver: str = "clarabel", options: dict[str, Any] | None = None
          ) -> Solved:  # fmt: skip
    """Solve the cvxpy ``problem`` with ``solver`` (``options["solver"]`` wins when given; a
    cvxpy solver name, any case, or ``"auto"``: module docstring) and the other ``options``; a
    solver error is a status (group ``error``), never an exception."""
    import cvxpy as cp

    options = dict(options or {})
    solver = str(options.pop("solver", solver)).lower()
    if solver == "auto":  # SCS when its keywords were given or the blocks are large
        scs_keys = any(k.startswith(("eps_", "acceleration")) for k in options)
        choice = choose_solver(psd_sizes(problem.constraints))
        solver = "scs" if scs_keys or choice.solver != "clarabel" else "clarabel"
    name = solver.upper()
    t0 = time.perf_counter()
    try:
        chosen = interruptible_scs() if name == "SCS" else name
        problem.solve(solver=chosen, **_options(name, options))
        status = str(problem.status)
    except cp.error.SolverError as exc:
        return Solved("error", f"solver error: {exc}", name.lower(), time.perf_counter() - t0)
    group = {cp.OPTIMAL: "optimal", cp.OPTIMAL_INACCURATE: "inaccurate", cp.INFEASIBLE: "infeasible",
             cp.INFEASIBLE_INACCURATE: "infeasible"}.get(status, "error")  # fmt: skip
    return Solved(group, status, name.lower(), time.perf_counter() - t0)


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


# -- sparse float polynomials ``{exponent tuple: float}``: the arithmetic of the programs --------
def poly_of(expr: Any, gens: list[Any]) -> Poly:
    import sympy as sp

    poly = sp.Poly(sp.expand(expr), *gens)
    return {m: float(c) for m, c in poly.terms() if c != 0}


def mul(a: Poly, b: Poly) -> Poly:
    out: Poly = {}
    for (ma, ca), (mb, cb) in itertools.product(a.items(), b.items()):
        m = _madd(ma, mb)
        out[m] = out.get(m, 0.0) + ca * cb
    return out


def lin(*pairs: tuple[float, Poly]) -> Poly:
    """``sum_k w_k p_k``."""
    out: Poly = {}
    for w, p in pairs:
        for m, c in p.items():
            out[m] = out.get(m, 0.0) + c * w
    return out


def power(p: Poly, k: int, nv: int) -> Poly:
    """``p^k`` in ``nv`` variables."""
    out: Poly = {tuple([0] * nv): 1.0}
    for _ in range(k):
        out = mul(out, p)
    return out


def diff(m: tuple[int, ...], i: int) -> Poly:
    """d(y^m)/dy_i."""
    return {tuple(k - (j == i) for j, k in enumerate(m)): float(m[i])} if m[i] else {}


def is_even(polys: list[Poly], nd: int, *, odd: bool = False) -> bool:
    """Every monomial has even (``odd=True``: odd) total degree in the first ``nd`` variables."""
    return all(sum(m[:nd]) % 2 == int(odd) for p in polys for m in p)


def sym_blocks(basis: list[tuple[int, ...]], nd: int, sym: bool, aux_degree: int | None = None
               ) -> list[list[tuple[int, ...]]]:  # fmt: skip
    """The Gram blocks of ``basis`` (capped at degree ``aux_degree`` in the variables past
    ``nd``): its even and odd monomials in the first ``nd`` variables when ``sym`` (the
    reflection ``d -> -d``; empty ones dropped), else one block."""
    basis = basis if aux_degree is None else [m for m in basis if sum(m[nd:]) <= aux_degree]
    if not sym:
        return [basis]
    return [b for p in (0, 1) if (b := [m for m in basis if sum(m[:nd]) % 2 == p])]


def sym_keep(basis: list[tuple[int, ...]], nd: int, sym: bool, aux_degree: int | None = None
             ) -> list[tuple[int, ...]]:  # fmt: skip
    """A free multiplier's monomials of ``basis``: those of :func:`sym_blocks`, the even ones in
    the first ``nd`` variables only when ``sym``."""
    return [m for b in sym_blocks(basis, nd, sym, aux_degree) for m in b
            if not sym or sum(m[:nd]) % 2 == 0]  # fmt: skip


def multipliers(prog: Program, total: int, eqs: list[Poly], nonneg: list[Poly], blocks: Any,
                keep: Any) -> list[tuple[list[tuple[int, ...]], Poly | None]]:  # fmt: skip
    """``+ sum_e mu_e h_e - sigma_0 - sum_j sigma_j g_j`` of degree ``total`` added to ``prog``
    (``mu_e`` free over ``keep``'s monomials, the sigmas Gram forms over ``blocks``'); returns
    the Gram blocks ``(basis, g or None)``."""
    nv = prog.nv
    for h in eqs:
        prog.free(h, keep(monomials(nv, total - max(map(sum, h)))))
    grams: list[tuple[list[tuple[int, ...]], Poly | None]] = [
        (b, None) for b in blocks(monomials(nv, total // 2))]  # fmt: skip
    grams += [(b, g) for g in nonneg
              for b in blocks(monomials(nv, (total - max(map(sum, g))) // 2))]  # fmt: skip
    for b, g in grams:
        prog.gram(b, g)
    return grams


def lyapunov_form(A: np.ndarray, coef: Any) -> Any:
    """``-(A'P + P A)`` symmetrised (cvxpy), ``P`` the quadratic part of a V whose coefficient
    of ``y_i y_j`` is ``coef(i, j)`` (linear in V's coefficients): the local decrease's LMI."""
    import cvxpy as cp

    n = len(A)
    P = cp.bmat([[coef(i, j) if i == j else 0.5 * coef(i, j) for j in range(n)] for i in range(n)])
    L = -(A.T @ P + P @ A)
    return 0.5 * (L + L.T)


def _columns(rcv: list[tuple[int, int, float]]) -> tuple[list, list, list]:
    return [x[0] for x in rcv], [x[1] for x in rcv], [x[2] for x in rcv]


class Program:
    """``sum of terms == 0``, coefficient by coefficient (module docstring)."""

    def __init__(self, nv: int, shared: Program | None = None) -> None:
        self.nv = nv
        self.rows: dict[tuple[int, ...], int] = {}
        # (rows, cols, vals, variable, columns, parameter factor or None)
        self.parts: list[tuple[list, list, list, Any, int, Any]] = []
        self.consts: list[Poly] = []
        self.psd: list[Any] = shared.psd if shared is not None else []
        self.frees: list[tuple[list[tuple[int, ...]], Any]] = []
        self.grams: list[tuple[list[tuple[int, ...]], Any]] = []
        self.cones: list[str] = []  # per Gram block: "psd" or "sdd"
        self.solver, self.status = "", "not solved"

    def fork(self) -> Program:
        """Another identity sharing this one's positive semidefinite constraints."""
        return Program(self.nv, shared=self)

    def row(self, m: tuple[int, ...]) -> int:
        """The row of monomial ``m`` (new rows in order of first use)."""
        return self.rows.setdefault(m, len(self.rows))

    @staticmethod
    def scalar(**kw: Any) -> Any:
        """A cvxpy variable (``shape=n``: a vector)."""
        import cvxpy as cp

        return cp.Variable(**kw)

    def const(self, poly: Poly) -> None:
        """The constant polynomial ``poly``."""
        for m in poly:
            self.row(m)
        self.consts.append(poly)

    def linear(self, polys: list[Poly], var: Any) -> None:
        """``sum_k polys[k] * var[k]`` (``var`` a cvxpy scalar/vector or numbers)."""
        if isinstance(var, int | float | np.ndarray):
            vals = np.atleast_1d(np.asarray(var, dtype=float))
            for p, v in zip(polys, vals, strict=True):
                self.const({m: c * float(v) for m, c in p.items()})
            return
        if getattr(var, "shape", None) == ():
            import cvxpy as cp

            var = cp.hstack([var])
        rcv = [(self.row(m), k, coef) for k, p in enumerate(polys) for m, coef in p.items()]
        self.parts.append((*_columns(rcv), var, len(polys), None))

    def free(self, poly: Poly, basis: list[tuple[int, ...]]) -> Any:
        """A free multiplier ``sum_k q_k b_k`` times ``poly``; returns its variable."""
        q = self.scalar(shape=len(basis))
        self.linear([{_madd(m, b): coef for m, coef in poly.items()} for b in basis], q)
        self.frees.append((basis, q))
        return q

    def _gram_columns(self, basis: list[tuple[int, ...]], times: Poly, sign: float
                      ) -> tuple[list, list, list]:  # fmt: skip
        nb = len(basis)
        return _columns([(self.row(_madd(bij, m)), i * nb + j, sign * coef)
                         for i, j in itertools.product(range(nb), range(nb))
                         for bij in [_madd(basis[i], basis[j])] for m, coef in times.items()])  # fmt: skip

    def gram(self, basis: list[tuple[int, ...]], times: Poly | None = None, *, sign: float = -1.0,
             margin: Any = None, level: Any = None, level_times: Poly | None = None,
             cone: str = "psd") -> Any:  # fmt: skip
        """``sign * b' Q b * times`` (plus ``sign * level * b' Q b * level_times`` with a cvxpy
        parameter ``level``) with ``Q >= margin I`` (``margin`` a variable; else ``Q >= 0``);
        ``cone="sdd"``: ``Q - margin I`` scaled diagonally dominant instead (module docstring;
        a block of one monomial stays PSD). Returns ``Q`` (a variable, or the expression of the
        SDD block; None for an empty basis)."""
        import cvxpy as cp

        if cone not in ("psd", "sdd"):
            raise ValueError(f"cone must be 'psd' or 'sdd', got {cone!r}")
        if not basis:
            return None
        nb = len(basis)
        times = times or {tuple([0] * self.nv): 1.0}
        if cone == "sdd" and nb > 1:
            I, J = np.triu_indices(nb, 1)
            P = len(I)
            u = cp.Variable(3 * P)  # per pair (i, j): [[a, c], [c, b]] >= 0 placed at (i, j)
            a, b, c = u[:P], u[P : 2 * P], u[2 * P :]
            self.psd.append(cp.SOC(a + b, cp.vstack([2 * c, a - b]), axis=0))
            k = np.arange(P)
            rows = np.concatenate([I * nb + I, J * nb + J, I * nb + J, J * nb + I])
            cols = np.concatenate([k, P + k, 2 * P + k, 2 * P + k])
            M = sps.csr_matrix((np.ones(4 * P), (rows, cols)), shape=(nb * nb, 3 * P))
            vecQ = M @ u
            if margin is not None:
                vecQ = vecQ + margin * np.eye(nb).reshape(-1)
            Q: Any = cp.reshape(vecQ, (nb, nb), order="C")
        else:
            cone = "psd"
            check_block(nb)
            Q = cp.Variable((nb, nb), symmetric=True)
            self.psd.append(Q >> 0 if margin is None else Q - margin * np.eye(nb) >> 0)
            vecQ = cp.vec(Q, order="C")
        self.parts.append((*self._gram_columns(basis, times, sign), vecQ, nb * nb, None))
        if level is not None and level_times:
            self.parts.append((*self._gram_columns(basis, level_times, sign), vecQ, nb * nb, level))
        self.grams.append((basis, Q))
        self.cones.append(cone)
        return Q

    def constraint(self) -> Any:
        """The identity as one cvxpy constraint ``A x + level * (B x) == -const``."""
        import cvxpy as cp

        nrow = len(self.rows)
        const = np.zeros(nrow)
        for p in self.consts:
            for m, coef in p.items():
                const[self.rows[m]] += coef
        expr: Any = None
        for factor in {id(p[5]): p[5] for p in self.parts}.values():
            group = [p for p in self.parts if p[5] is factor]
            offsets = np.cumsum([0] + [p[4] for p in group])
            r = np.concatenate([np.asarray(p[0], dtype=np.int64) for p in group])
            c = np.concatenate([np.asarray(p[1], dtype=np.int64) + offsets[i]
                                for i, p in enumerate(group)])  # fmt: skip
            v = np.concatenate([np.asarray(p[2], dtype=float) for p in group])
            A = sps.csr_matrix((v, (r, c)), shape=(nrow, int(offsets[-1])))
            x = group[0][3] if len(group) == 1 else cp.hstack([p[3] for p in group])
            term = A @ x if factor is None else factor * (A @ x)
            expr = term if expr is None else expr + term
        if expr is None:
            return cp.Constant(const) == 0
        return expr == -const

    def sizes(self) -> list[int]:
        """Sizes of the Gram blocks of this identity and those sharing its constraints."""
        return sorted(psd_sizes(self.psd), reverse=True)

    def problem(self, objective: Any, *, maximise: bool = True, also: list[Program] | None = None,
                extra: list[Any] | None = None) -> Any:  # fmt: skip
        """The cvxpy problem: this identity, ``also``'s, the shared PSD constraints and
        ``extra``."""
        import cvxpy as cp

        cons = [self.constraint(), *(o.constraint() for o in also or []), *self.psd, *(extra or [])]
        return cp.Problem(cp.Maximize(objective) if maximise else cp.Minimize(objective), cons)

    def solve(self, objective: Any, *, maximise: bool = True, options: dict[str, Any] | None = None,
              free_index: int | None = None, also: list[Program] | None = None,
              solver: str = "clarabel") -> tuple[bool, float | None, Poly | None]:  # fmt: skip
        """Solve (:func:`solve`, ``solver="auto"`` as there: SCS, first order, is much faster on
        blocks of ~100 monomials, Clarabel's KKT systems growing with the cube of a block's
        triangle); ``(ok, objective value, free multiplier free_index as a Poly)``."""
        res = solve(self.problem(objective, maximise=maximise, also=also), solver=solver,
                    options=options)  # fmt: skip
        self.solver, self.status = res.solver, res.status
        if not res.usable or objective.value is None:
            return False, None, None
        lam = None
        if free_index is not None:
            basis, q = self.frees[free_index]
            lam = {b: float(x) for b, x in zip(basis, q.value, strict=True) if x != 0.0}
        return True, float(np.asarray(objective.value).reshape(-1)[0]), lam
