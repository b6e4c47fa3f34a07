"""Containment of one sublevel set in another, for any two candidates (interval branch and bound).

Claim proved: the connected component holding the centre of ``{inner <= a}`` (all of it when a
global cover is proved, see :mod:`roa.proof._cover`) lies in ``{outer <= b}``. Steps: a proved box
cover of the inner set (the same as the validation's, :func:`roa.proof.prove_cover`),
then boxes are discarded when the interval ``inner > a`` or ``outer <= b`` on them, and split
otherwise. A box centre with ``inner <= a < outer > b`` in floats is reported as a counterexample
(re-checked at 50 digits). Boxes are in whitened coordinates of ``inner`` when its Hessian at the
centre is definite (:mod:`roa.proof._whiten`). Two quadratics: :func:`roa.proof._containment.
ellipsoid_contains` decides exactly, without boxes.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.model._backend import namespace
from roa.proof._cover import bisect_widest, interval_value, prove_cover
from roa.proof._whiten import Whitened, whitening_for


def sublevel_contains(
    inner: Lyapunov,
    a: float,
    outer: Lyapunov,
    b: float,
    *,
    max_boxes: int = 2_000_000,
    cover_estimate: Any = None,
) -> dict[str, Any]:
    """Decide ``{inner <= a} subset {outer <= b}`` (module docstring); a dict with ``status``
    (``proved`` / ``refuted`` / ``inconclusive``), ``boxes``, ``seconds``, ``witness``.
    ``cover_estimate``: the proposal of a box for an inner V without a Gram matrix
    (:func:`roa.proof.prove_cover`)."""
    import mpmath as mp

    t0 = time.perf_counter()
    if not np.allclose(inner.center, outer.center, rtol=0, atol=0):
        raise RoaInputError("containment needs both candidates centred at the same point")
    if not (a > 0 and b > 0 and np.isfinite(a) and np.isfinite(b)):
        raise RoaInputError(f"levels must be finite and > 0, got {a!r}, {b!r}")
    M = whitening_for(inner)
    if M is not None:
        inner, outer = Whitened(inner, None, M), Whitened(outer, None, M)  # type: ignore[arg-type]

    def out(status: str, boxes: int, **kw: Any) -> dict[str, Any]:
        return {"status": status, "boxes": boxes, "seconds": round(time.perf_counter() - t0, 3),
                "coordinates": "whitened" if M is not None else "x", **kw}  # fmt: skip

    box, info, why = prove_cover(inner, a, None, budget=max_boxes, estimate=cover_estimate)
    if box is None:
        return out("inconclusive", info.get("cover_boxes", 0), message=f"no cover: {why}")
    lo, hi = box[0][None, :], box[1][None, :]
    boxes = 0
    while len(lo):
        boxes += len(lo)
        if boxes > max_boxes:
            return out("inconclusive", boxes, message=f"box budget {max_boxes} exhausted")
        Vi, Vo = interval_value(inner, lo, hi), interval_value(outer, lo, hi)
        und = ~((Vi.lo > a) | (Vo.hi <= b))
        lo, hi = lo[und], hi[und]
        if not len(lo):
            break
        mid = 0.5 * (lo + hi)
        bad = (inner.value(mid) <= a) & (outer.value(mid) > b)
        if bad.any():
            w = mid[np.argmax(bad)]
            x = w if M is None else inner.to_x(w)  # type: ignore[attr-defined]
            ns = namespace("mpmath")
            with mp.workdps(50):
                ys = [mp.mpf(float(v)) for v in w]
                vi, vo = inner.expr(ys, ns), outer.expr(ys, ns)
                ok = bool(vi <= mp.mpf(float(a)) and vo > mp.mpf(float(b)))
            if ok:
                return out("refuted", boxes, witness=[float(v) for v in x],
                           values=[float(vi), float(vo)])  # fmt: skip
        lo, hi = bisect_widest(lo, hi)
    return out("proved", boxes, cover=info.get("cover"))
