"""Robust validation of a level: ``V' < 0`` on ``{V <= level} \\ {x_eq}`` for every parameter of a box.

**Claim.** For a system with uncertain parameters ``p`` in a box ``P``, the certificate states:
for every ``p`` in ``P``, ``V'_p(x) = grad V(x) . f(x, p) < 0`` on ``{V <= level}`` minus ``x_eq``
(``V`` does not depend on ``p``), so ``{V <= level}`` lies in the region of attraction of ``x_eq``
for every fixed parameter value of the box (LaSalle, as for one parameter value).

**Proof.** One interval branch and bound (:func:`roa.proof.validate_level` with
``parameters``) over boxes of states *and* parameters, on the system of
:func:`roa.model._parameters.over`: the uncertain parameters enter the second-order jets as variables, so
the enclosures of ``V'`` (natural extension, centred and Taylor forms over all ``n + k`` columns)
hold for every ``(x, p)`` of a box, and a box is split along a parameter where ``|dV'/dp|`` times
its width is the largest score. The cover of ``{V <= level}`` depends on ``V`` only. Near ``x_eq``:
``f(x_eq, p) = 0`` as an exact identity in the parameter symbols and a negative definite Hessian
of ``V'`` enclosed over each piece of the parameter box (halves where the whole box does not
pass), the intersection of the pieces' boxes kept.

**Refutation.** A witness ``(x, p)``: ``p`` a sample point of ``P`` (nominal value or vertex, where
the float searches run), ``x`` with ``V(x) <= level`` and ``V'_p(x) >= 0`` re-checked at 50 digits
with ``p`` taken exactly, in the equilibrium's component.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.model._parameters import ParameterBox, describe_point, over, sample_points
from roa.model._system import System
from roa.proof._validate import validate_level
from roa.proof._validation import Validation
from roa.status import Verdict


def validate_robust(
    system: System,
    lyap: Lyapunov,
    level: float,
    *,
    max_boxes: int = 3_000_000,
    batch: int = 100_000,
    bounding_box: Any = None,
    time_limit: float | None = None,
    proposal: tuple[Any, dict[str, float]] | None = None,
    cover_estimate: Any = None,
) -> Validation:
    """Decide ``V'_p < 0`` on ``{V <= level} \\ {x_eq}`` for every ``p`` of the system's box (module
    doc). ``max_boxes`` is the budget of boxes (states and parameters). ``proposal`` ``(x, p)``:
    a proposed refutation ``x`` (or None) at the sample point ``p`` of the box found by a search
    (:func:`roa.search._robust_witness.sampled_witness`); ``p`` also hosts the branch and bound's
    float searches (default: the nominal value, no point). A proposal proves nothing: its point
    counts once re-checked here at 50 digits, in the equilibrium's component.
    ``cover_estimate``: see :func:`roa.proof.validate_level`."""
    t0 = time.perf_counter()
    level = float(level)
    if not (np.isfinite(level) and level > 0):
        raise RoaInputError(f"level must be a finite number > 0, got {level!r}")
    full = ParameterBox.of(system)

    def out(status: Verdict, boxes: int, message: str, **kw: Any) -> Validation:
        meta = {"parameter_box": {k: [a, b] for k, a, b in zip(full.names, full.lo, full.hi,
                                                               strict=True)}, **kw.pop("meta", {})}  # fmt: skip
        return Validation(status, level, boxes, time.perf_counter() - t0, message=message,
                          meta=meta, **kw)  # fmt: skip

    w, worst = (None, sample_points(system)[0]) if proposal is None else proposal
    check = None
    if w is not None:  # the search's point, proved here
        from roa.proof._cover import connected_to_center
        from roa.proof._witness import recheck_witness

        w = np.asarray(w, dtype=float)
        check = recheck_witness(system.at(**worst), lyap, w, level)
        if not (check["confirmed"] and connected_to_center(lyap, w, level)):
            w = None
    if w is not None:
        return out(Verdict.REFUTED, 0,
                   f"V' >= 0 at a point of {{V <= level}} for {describe_point(worst)} (sampled "
                   "search at the box's vertices and nominal value; float and 50 digits)",
                   witness=[float(v) for v in w], witness_check=check,
                   witness_parameters=dict(worst))  # fmt: skip
    # one branch and bound over states and parameters; its float searches run at the worst
    # sample point
    res = validate_level(over(system, full, point=worst), lyap, level, max_boxes=max_boxes,
                         batch=batch, bounding_box=bounding_box, time_limit=time_limit,
                         parameters=(np.asarray(full.lo), np.asarray(full.hi)),
                         cover_estimate=cover_estimate)  # fmt: skip
    meta = {**res.meta, "witness_search_parameters": worst}
    if res.status is Verdict.REFUTED:
        return out(Verdict.REFUTED, res.boxes, f"{res.message} for {describe_point(worst)}",
                   witness=res.witness, witness_check=res.witness_check,
                   witness_parameters=dict(worst), meta=meta, reason=res.reason)  # fmt: skip
    if res.status is Verdict.CERTIFIED:
        return out(Verdict.CERTIFIED, res.boxes,
                   f"V' < 0 proved for every parameter of the box ({full.describe()}): "
                   f"{res.message}", meta=meta)  # fmt: skip
    return out(res.status, res.boxes, f"not decided for {full.describe()}: {res.message}",
               meta=meta, reason=res.reason)  # fmt: skip
