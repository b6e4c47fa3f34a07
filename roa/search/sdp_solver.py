"""The solver of an SOS program, its tolerances, and its memory estimate before the program is built.

Every SOS program here is a cvxpy problem with positive semidefinite blocks (Gram matrices) and,
for the scaled-diagonally-dominant pattern (:mod:`roa.search.sos_sdd`), second-order cones. Two
solvers are used:

* **Clarabel** (interior point, the default): accurate, but each PSD block of ``m`` monomials
  makes its KKT system hold a dense ``s x s`` scaling block, ``s = m (m + 1) / 2``: about
  ``24 s^2`` bytes (:func:`roa.search.polysdp.sdp_bytes`), 16 GiB at ``m = 231``;
* **SCS** (first order, operator splitting): memory linear in the program's nonzeros and the
  blocks' entries (:func:`scs_bytes`), less accurate (the exact check decides anyway).

``solver_options`` of the SOS programs (:class:`roa.SosValidator`, ``SosOptions``) take the
key ``"solver"`` (``"clarabel"``, ``"scs"`` or ``"auto"``: Clarabel when its estimate fits the
budget, else SCS when its estimate does, else the program is refused before it is built) and the
solver's own keywords (tolerances, iteration limits); :func:`settings` writes a tolerance in each
solver's terms.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from roa.errors import RoaInputError
from roa.search.polysdp import MAX_SDP_BYTES, sdp_bytes

SOLVERS = ("auto", "clarabel", "scs")


def scs_bytes(blocks: Sequence[int], rows: int, nonzeros: int) -> int:
    """Estimated peak memory of SCS on PSD blocks of ``blocks`` monomials with ``rows`` equality
    rows and ``nonzeros`` nonzeros in the constraint matrix: the factorisation of the sparse
    ``[I A'; A -I]`` (a few times its nonzeros) and a few copies of every vector, plus one dense
    eigendecomposition of the largest block per iteration."""
    entries = sum(m * (m + 1) // 2 for m in blocks)
    biggest = max(blocks, default=0)
    return 8 * (20 * nonzeros + 12 * (entries + rows) + 4 * biggest * biggest)


def ipm_bytes(blocks: Sequence[int]) -> int:
    """Estimated peak memory of Clarabel on PSD blocks of ``blocks`` monomials."""
    return sum(sdp_bytes(m) for m in blocks)


@dataclass(frozen=True)
class SolverChoice:
    """The solver chosen for a program (``"clarabel"`` or ``"scs"``; ``None``: too large for
    both), the estimates it was chosen by, and the reason."""

    solver: str | None
    ipm_bytes: int
    scs_bytes: int
    reason: str

    @property
    def figures(self) -> dict[str, Any]:
        return {"solver": self.solver, "ipm_gib": round(self.ipm_bytes / 2**30, 4),
                "scs_gib": round(self.scs_bytes / 2**30, 4)}  # fmt: skip


def choose(blocks: Sequence[int], rows: int, nonzeros: int, solver: str = "auto", *,
           budget: int = MAX_SDP_BYTES) -> SolverChoice:  # fmt: skip
    """The solver of a program with PSD blocks of ``blocks`` monomials (module docstring), from
    the memory estimates against ``budget`` bytes. A forced solver is kept even over budget when
    it is Clarabel's estimate that is exceeded only for ``"scs"``; a forced ``"clarabel"`` over
    budget is refused (None)."""
    if solver not in SOLVERS:
        raise RoaInputError(f"solver must be one of {SOLVERS}, got {solver!r}")
    ipm, scs = ipm_bytes(blocks), scs_bytes(blocks, rows, nonzeros)
    gib = 2**30

    def out(name: str | None, why: str) -> SolverChoice:
        return SolverChoice(name, ipm, scs, why)

    if solver in ("auto", "clarabel") and ipm <= budget:
        return out("clarabel", f"interior point: an estimated {ipm / gib:.3g} GiB")
    if solver == "clarabel":
        return out(None, f"the interior-point solver needs an estimated {ipm / gib:.3g} GiB "
                   f"(budget {budget / gib:.3g} GiB): not built")  # fmt: skip
    if scs <= budget:
        return out("scs", f"first order (SCS): an estimated {scs / gib:.3g} GiB; the interior "
                   f"point would need {ipm / gib:.3g} GiB")  # fmt: skip
    return out(None, f"an estimated {scs / gib:.3g} GiB even for the first-order solver (budget "
               f"{budget / gib:.3g} GiB): not built")  # fmt: skip


def settings(solver: str = "clarabel", tolerance: float | None = None,
             max_iter: int | None = None) -> dict[str, Any]:  # fmt: skip
    """``solver_options`` for ``solver`` with ``tolerance`` (relative and absolute gap and
    feasibility) and ``max_iter`` written in that solver's keywords."""
    if solver not in SOLVERS:
        raise RoaInputError(f"solver must be one of {SOLVERS}, got {solver!r}")
    if tolerance is not None and not (isinstance(tolerance, float | int) and 0 < tolerance < 1):
        raise RoaInputError(f"tolerance must be a number in (0, 1), got {tolerance!r}")
    if max_iter is not None and (isinstance(max_iter, bool) or not isinstance(max_iter, int)
                                 or max_iter < 1):  # fmt: skip
        raise RoaInputError(f"max_iter must be a positive integer, got {max_iter!r}")
    out: dict[str, Any] = {"solver": solver}
    if tolerance is not None:
        t = float(tolerance)
        if solver == "scs":
            out.update(eps_abs=t, eps_rel=t)
        else:  # Clarabel's keywords (also the first choice of "auto")
            out.update(tol_gap_abs=t, tol_gap_rel=t, tol_feas=t)
    if max_iter is not None:
        out["max_iters" if solver == "scs" else "max_iter"] = max_iter
    return out


def split(solver_options: dict[str, Any] | None) -> tuple[str, dict[str, Any]]:
    """``(solver, keywords)`` of ``solver_options``: the ``"solver"`` key (default ``"auto"``)
    and the rest, passed to the solver."""
    opts = dict(solver_options or {})
    solver = str(opts.pop("solver", "auto")).lower()
    if solver not in SOLVERS:
        raise RoaInputError(f"solver_options['solver'] must be one of {SOLVERS}, got {solver!r}")
    return solver, opts


def psd_sizes(prob: Any) -> list[int]:
    """The sizes of the PSD constraints of a cvxpy problem."""
    import cvxpy as cp

    return [int(c.args[0].shape[0]) for c in prob.constraints if isinstance(c, cp.constraints.PSD)]


def solve(prob: Any, solver_options: dict[str, Any] | None = None) -> str:
    """Solve the built cvxpy problem with the solver of ``solver_options`` (``"auto"``: Clarabel
    unless SCS keywords were given or its PSD blocks exceed Clarabel's memory budget; the
    refusal of programs too large for both comes before they are built, :func:`choose`); the
    status, or ``"solver error: ..."`` (never an exception)."""
    import cvxpy as cp

    solver, opts = split(solver_options)
    if solver == "auto":  # SCS when its keywords were given or Clarabel's blocks do not fit
        scs_keys = any(k.startswith(("eps_", "max_iters", "acceleration")) for k in opts)
        solver = "scs" if scs_keys or ipm_bytes(psd_sizes(prob)) > MAX_SDP_BYTES else "clarabel"
    name = cp.SCS if solver == "scs" else cp.CLARABEL
    try:
        prob.solve(solver=name, **opts)
        return str(prob.status)
    except cp.error.SolverError as exc:
        return f"solver error: {exc}"
