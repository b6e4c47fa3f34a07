"""The SOS route of dense coupled systems too large for the dense program (sign symmetry, SDSOS).

Used by :class:`roa.SosValidator` and :class:`roa.SosLevel` where the dense program's Gram
block does not fit the memory budget and the correlative-sparsity route does not apply
(:func:`roa.search.sos_sparse.choose_route` says ``too_large``): the program of
:mod:`roa.search.sos_sdd` proposes, :func:`roa.proof.sos_sdd.check_sdd` proves. The compiled
program is kept for the last few exact data (a back-off or a bisection re-solves it at other
levels without building it again).
"""

from __future__ import annotations

import resource
import time
from collections import OrderedDict
from fractions import Fraction
from typing import Any

import numpy as np

from roa.proof.sos_check import ExactData
from roa.proof.validation import Validation
from roa.status import SosStatus, Verdict

_PROGRAMS: OrderedDict[tuple, Any] = OrderedDict()
_KEEP = 2


def _key(data: ExactData, eps: Fraction, multiplier_degree: Any, solver_options: Any) -> tuple:
    return (data.n, tuple(sorted(data.V.items())), tuple(sorted(data.Vdot.items())), eps,
            multiplier_degree, repr(sorted((solver_options or {}).items())))  # fmt: skip


def program(data: ExactData, eps: Fraction, multiplier_degree: Any = None,
            solver_options: dict[str, Any] | None = None) -> tuple[Any, str]:  # fmt: skip
    """The compiled program of ``data`` (cached), or None and why there is none."""
    from roa.search.sos_sdd import SddProgram, plan

    key = _key(data, eps, multiplier_degree, solver_options)
    if key in _PROGRAMS:
        _PROGRAMS.move_to_end(key)
        return _PROGRAMS[key], ""
    p, why = plan(data, multiplier_degree, solver_options)
    if p is None:
        return None, why
    prog = SddProgram(data, p, eps=eps, solver_options=solver_options)
    _PROGRAMS[key] = prog
    while len(_PROGRAMS) > _KEEP:
        _PROGRAMS.popitem(last=False)
    return prog, ""


def validate_sdd(data: ExactData, level: float, eps: Fraction, multiplier_degree: Any,
                 solver_options: dict[str, Any] | None, why_dense: str,
                 out: Any) -> Validation | None:  # fmt: skip
    """The SDSOS certificate of ``data`` at ``level`` as a validation (``out(status, message,
    **meta)`` builds it), None when even this program does not fit."""
    from roa.proof.sos_sdd import check_sdd, to_json

    prog, why = program(data, eps, multiplier_degree, solver_options)
    if prog is None:
        return None
    cand = prog.solve(level)
    figures: dict[str, Any] = {
        "route": "sdsos", "why_sdsos": why_dense, "solver_status": cand.solver_status,
        "margin": cand.margin, "sdp_seconds": round(cand.seconds, 3), **cand.figures,
        "gram_sizes": [len(b) for b in prog.plan.sigma]}  # fmt: skip
    if cand.sigma is None or cand.lam is None:
        return out(Verdict.INCONCLUSIVE, f"SDSOS solver failed ({cand.solver_status})",
                   **figures)  # fmt: skip
    t0 = time.perf_counter()
    sigma = [(b, Q, "fresh" if s else None)
             for b, Q, s in zip(prog.plan.sigma, cand.sigma, prog.plan.sdd, strict=True)]  # fmt: skip
    res = check_sdd(data, level, eps, sigma, list(zip(prog.plan.lam, cand.lam, strict=True)))
    figures.update(check_seconds=round(time.perf_counter() - t0, 3), residual=res.residual,
                   min_pivot=res.min_pivot,
                   peak_mib=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024))  # fmt: skip
    if not res.ok or res.sigma is None or res.lam is None or res.scalings is None:
        return out(Verdict.INCONCLUSIVE, f"SDSOS check failed: {res.reason}", **figures)
    cert = {"sdd": to_json(list(zip(prog.plan.sigma, res.sigma, res.scalings, strict=True)),
                           list(zip(prog.plan.lam, res.lam, strict=True)))}  # fmt: skip
    return out(Verdict.CERTIFIED, f"SDSOS certificate (sign blocks {[len(b) for b in prog.plan.sigma]}"
               f", scaled diagonally dominant {prog.plan.sizes['sdd_blocks']}) checked exactly: "
               f"{res.reason}", certificate=cert, M=np.eye(data.n).tolist(), **figures,
               **res.meta)  # fmt: skip


def sdd_level(data: ExactData, eps_scale: float, solver_options: dict[str, Any] | None) -> Any:
    """The SOS level of the SDSOS program by bisection (an ``SOSResult``), None when it does not
    fit."""
    from roa.search.sos import SOSResult
    from roa.search.sos_certificate import default_eps
    from roa.search.sos_sdd import largest_level

    t0 = time.perf_counter()
    prog, why = program(data, default_eps(data, eps_scale), None, solver_options)
    if prog is None:
        return None
    level, count = largest_level(data, prog)
    sizes = {**prog.plan.sizes, "programs": count}
    secs = time.perf_counter() - t0
    if level is None or not np.isfinite(level):
        return SOSResult(SosStatus.FAILED, None, "bisection", secs, "none (polynomial)", sizes,
                         "SDSOS bisection: no limiting level found")  # fmt: skip
    return SOSResult(SosStatus.SOLVED, float(level), "bisection", secs, "none (polynomial)", sizes,
                     "largest level of the SDSOS program (sign blocks, bisection)")  # fmt: skip
