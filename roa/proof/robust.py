"""Robust validation of a level: ``V' < 0`` on ``{V <= level} \\ {x_eq}`` for every parameter of a box.

**Claim.** For a system with uncertain parameters ``p`` in a box ``P``, the certificate states:
for every ``p`` in ``P``, ``V'_p(x) = grad V(x) . f(x, p) < 0`` on ``{V <= level}`` minus ``x_eq``
(``V`` does not depend on ``p``), so ``{V <= level}`` lies in the region of attraction of ``x_eq``
for every fixed parameter value of the box (LaSalle, as for one parameter value).

**Proof.** ``P`` is covered by pieces ``P_1, ..., P_k`` (the box, split in halves where a piece is
not decided). On each piece the interval branch and bound of :func:`roa.proof.validate.validate_level`
runs on the system of :func:`roa.parameters.over`, whose field sees the uncertain parameters as the
intervals of the piece: every enclosure of ``V'`` on a state box then holds for every ``p`` of the
piece, and the local proof near ``x_eq`` needs ``f(x_eq, p) = 0`` as an exact identity in the
parameter symbols and a negative definite Hessian of ``V'`` enclosed over the piece. The cover of
``{V <= level}`` depends on ``V`` only. A level is certified when every piece is.

**Refutation.** A witness ``(x, p)``: ``p`` a point of ``P`` (a sample point of the box, or a
piece's midpoint, where the float searches run), ``x`` with ``V(x) <= level`` and
``V'_p(x) >= 0`` re-checked at 50 digits with ``p`` taken exactly, in the equilibrium's component.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.parameters import ParameterBox, describe_point, over, sample_points
from roa.proof.validate import validate_level
from roa.proof.validation import Validation
from roa.status import Verdict
from roa.system import System

#: Pieces of the parameter box at most (a piece is split in two when undecided).
MAX_PIECES = 64
#: Directions of the sampled witness search at each sample point of the box.
WITNESS_DIRECTIONS = 4000


def sampled_witness(
    system: System, lyap: Lyapunov, level: float, *, directions: int = WITNESS_DIRECTIONS
) -> tuple[np.ndarray, dict[str, float], dict[str, Any]] | None:
    """A confirmed witness ``(x, p, check)`` of ``V'_p(x) >= 0`` inside ``{V <= level}`` at one of
    the box's sample points (:func:`roa.parameters.sample_points`), or None. A search: None
    proves nothing."""
    from roa.levelset import level_search
    from roa.options import SampledOptions
    from roa.proof.cover import connected_to_center
    from roa.proof.witness import recheck_witness

    best: tuple[float, np.ndarray, dict[str, float], System] | None = None
    opts = SampledOptions(n_directions=directions)
    for p in sample_points(system):
        fixed = system.at(**p)
        near = _near_equilibrium(fixed, lyap, level)
        if near is not None:
            return near[0], p, near[1]
        res = level_search(fixed, lyap, shape="level", method="sampled", sampled=opts)
        if res.level is None or res.witness is None or not res.level < level:
            continue
        if best is None or res.level < best[0]:
            best = (float(res.level), np.asarray(res.witness, dtype=float), p, fixed)
    if best is None:
        return None
    _, w, p, fixed = best
    check = recheck_witness(fixed, lyap, w, level)
    if check["confirmed"] and connected_to_center(lyap, w, level):
        return w, p, check
    return None


def _near_equilibrium(
    system: System, lyap: Lyapunov, level: float
) -> tuple[np.ndarray, dict[str, Any]] | None:
    """Where ``V'`` is not negative definite to second order at the equilibrium (``A'H + HA`` has
    an eigenvalue > 0, ``H`` half the Hessian of V): a confirmed witness ``x_eq + t u`` along its
    eigenvector ``u`` inside ``{V <= level}`` (``t`` halved until ``V' >= 0`` holds at 50 digits),
    or None. A search."""
    from roa.linearisation import linearise
    from roa.proof.cover import connected_to_center
    from roa.proof.witness import recheck_witness

    H = 0.5 * lyap.hessian_at_center()
    A = linearise(system).A
    w, U = np.linalg.eigh(A.T @ H + H @ A)
    if not w[-1] > 0:
        return None
    u, c = U[:, -1], np.asarray(lyap.center, dtype=float)
    t = 1.0
    for _ in range(60):  # down to V(c + t u) < level
        if float(lyap.value((c + t * u)[None])[0]) < level:
            break
        t *= 0.5
    for _ in range(40):
        x = c + t * u
        check = recheck_witness(system, lyap, x, level)
        if check["confirmed"] and connected_to_center(lyap, x, level):
            return x, check
        t *= 0.5
    return None


def validate_robust(
    system: System,
    lyap: Lyapunov,
    level: float,
    *,
    max_boxes: int = 3_000_000,
    batch: int = 100_000,
    bounding_box: Any = None,
    max_pieces: int = MAX_PIECES,
) -> Validation:
    """Decide ``V'_p < 0`` on ``{V <= level} \\ {x_eq}`` for every ``p`` of the system's box (module
    doc). ``max_boxes`` is the budget of state boxes over all pieces; ``max_pieces`` bounds the
    pieces of the parameter box."""
    t0 = time.perf_counter()
    level = float(level)
    if not (np.isfinite(level) and level > 0):
        raise RoaInputError(f"level must be a finite number > 0, got {level!r}")
    if isinstance(max_pieces, bool) or not isinstance(max_pieces, int) or max_pieces < 1:
        raise RoaInputError(f"max_pieces must be an integer >= 1, got {max_pieces!r}")
    full = ParameterBox.of(system)
    widths = [b - a for a, b in zip(full.lo, full.hi, strict=True)]

    def out(status: Verdict, boxes: int, message: str, **kw: Any) -> Validation:
        meta = {"parameter_box": {k: [a, b] for k, a, b in zip(full.names, full.lo, full.hi,
                                                               strict=True)}, **kw.pop("meta", {})}  # fmt: skip
        return Validation(status, level, boxes, time.perf_counter() - t0, message=message,
                          meta=meta, **kw)  # fmt: skip

    found = sampled_witness(system, lyap, level)
    if found is not None:
        w, p, check = found
        return out(Verdict.REFUTED, 0,
                   f"V' >= 0 at a point of {{V <= level}} for {describe_point(p)} (sampled search "
                   "at the box's vertices and nominal value; float and 50 digits)",
                   witness=[float(v) for v in w], witness_check=check,
                   witness_parameters=dict(p))  # fmt: skip
    queue, boxes, done = [full], 0, 0
    frame: dict[str, Any] = {}  # the frame of the boxes (V's alone: the same for every piece)
    while queue:
        piece = queue.pop(0)
        remaining = max_boxes - boxes
        share = max(min(remaining, max_boxes // 4), min(remaining, 10_000))
        if share <= 0:
            return out(Verdict.INCONCLUSIVE, boxes,
                       f"box budget {max_boxes} exhausted with {len(queue) + 1} pieces of the "
                       f"parameter box undecided (first: {piece.describe()}); {done} pieces "
                       "certified", meta={"pieces_certified": done})  # fmt: skip
        res = validate_level(over(system, piece), lyap, level, max_boxes=share, batch=batch,
                             bounding_box=bounding_box)  # fmt: skip
        boxes += res.boxes
        frame = {k: res.meta[k] for k in ("M", "coordinates", "cover") if k in res.meta}
        if res.status is Verdict.CERTIFIED:
            done += 1
            continue
        if res.status is Verdict.REFUTED:
            p = piece.midpoint
            return dataclasses.replace(
                out(Verdict.REFUTED, boxes, f"{res.message} for {describe_point(p)}",
                    witness=res.witness, witness_check=res.witness_check,
                    witness_parameters=p, meta=res.meta))  # fmt: skip
        # V's cover and a reach past the domain do not depend on the parameters: no split helps
        splittable = "domain_witness" not in res.meta and "box cover" not in res.message
        if not splittable or done + len(queue) + 2 > max_pieces:
            why = "" if splittable else " (splitting the parameter box does not help)"
            return out(Verdict.INCONCLUSIVE, boxes,
                       f"not decided for {piece.describe()}{why}: {res.message}",
                       meta={**res.meta, "pieces_certified": done})  # fmt: skip
        queue += list(piece.split(widths))
    return out(Verdict.CERTIFIED, boxes,
               f"V' < 0 proved for every parameter of the box ({full.describe()}) on {done} "
               "piece(s) of it", meta={"pieces": done, **frame})  # fmt: skip
