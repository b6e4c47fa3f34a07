"""The one stored form of an exact SOS certificate, and its re-check without any solver.

**The form** (``certificate`` of a ``sos-exact`` validation; ``docs/certificates.rst``)::

    {"parts": [{"variables": [i, ...], "eps": "p/q", "grams": [{"multiplies": k, "basis": [[...]],
                "Q": [["p/q"]]}], "free": [{"basis": [[...]], "coeffs": ["p/q"]}]}, ...],
     "scale": ["p/q", ...], "taylor": m, "parameters": {...}, "domain": {...}}

Each part is a Putinar certificate (:class:`roa.proof._putinar.Certificate`) of the variables it
names: one part over every variable (dense: one block per factor; correlative cliques: several
blocks per factor), or several parts partitioning the variables (independent blocks,
:mod:`roa.proof._reductions`). ``eps`` may sit at the top level of the validation instead (one
value for every part; both present must agree). ``scale`` (optional): the identity is in ``y``
with ``d = diag(scale) y``. ``taylor`` marks a recast field or a parameter box: the recast
(:func:`roa.proof._recast.recast_exact`) is recomputed from the system with this Taylor order and
``scale``, and its box must equal the stored ``parameters``.

**Old forms** (``basis0``/``Q0``/``basis1``/``Q1``; ``sum``; ``blocks``; ``putinar``), as stored
by earlier versions, are converted on load (:func:`parts_of`) into this one and checked the same
way.

:func:`recheck` is the one dispatcher: the preconditions of :mod:`roa.proof._preconditions` (the
domain by the stored ``domain`` part or by intervals), then every part by
:func:`roa.proof._putinar.check_level`, exactly as stored (nothing rounded or projected).
"""

from __future__ import annotations

import time
from dataclasses import replace
from fractions import Fraction
from typing import Any

import numpy as np

from roa.proof._preconditions import Route, check_preconditions
from roa.proof._putinar import Certificate, check_level
from roa.proof._recast import Recast
from roa.proof._reductions import IndependentBlocks, Rescale, box_json, check_partition
from roa.proof._sos_check import (
    NotPolynomial,
    objects,
    parse_rational,
    preconditions,
    stored_scale,
)
from roa.proof._validation import Validation
from roa.status import Verdict

#: Bound on the number of stored parts (beyond it a file is refused before any arithmetic).
MAX_PARTS = 50_000


def part_json(variables: list[int], cert: Certificate, eps: Fraction | None = None,
              **extra: Any) -> dict[str, Any]:  # fmt: skip
    """One stored part: ``variables``, ``eps`` (omitted: the top level's) and the certificate."""
    return {"variables": list(variables), **({} if eps is None else {"eps": str(eps)}),
            **cert.to_json(), **extra}  # fmt: skip


def _grams(items: Any, what: str, factor: int | None = None) -> list[dict[str, Any]]:
    """Old-form Gram blocks as ``grams`` entries, each multiplying ``factor`` (None: its index)."""
    return [{"multiplies": k if factor is None else factor, "basis": g.get("basis"),
             "Q": g.get("Q")} for k, g in enumerate(objects(items, what))]  # fmt: skip


def _old_part(raw: dict[str, Any], variables: Any) -> dict[str, Any]:
    """A dense or sum certificate of the old forms as a part."""
    if "sum" in raw:
        s = raw["sum"]
        if not isinstance(s, dict):
            raise ValueError("the sum certificate must be an object with 'sigma' and 'lambda'")
        grams = _grams(s.get("sigma"), "sigma", 0) + _grams(s.get("lambda"), "lambda", 1)
    else:  # dense: basis0/Q0, basis1/Q1
        grams = [{"multiplies": 0, "basis": raw.get("basis0"), "Q": raw.get("Q0")}]
        if raw.get("basis1"):
            grams.append({"multiplies": 1, "basis": raw.get("basis1"), "Q": raw.get("Q1") or []})
    return {"variables": variables, "grams": grams, "free": [],
            **({"eps": raw["eps"]} if "eps" in raw else {})}  # fmt: skip


def parts_of(cert: Any, n: int) -> dict[str, Any]:
    """The certificate in the one stored form (module docstring), old forms converted; a
    ValueError names what is malformed."""
    if not isinstance(cert, dict):
        raise ValueError("no certificate (Gram blocks) in the file")
    everything = list(range(n))
    out = {k: cert[k] for k in ("scale", "taylor", "parameters", "domain") if k in cert}
    if "parts" in cert:
        out["parts"] = cert["parts"]
    elif "putinar" in cert:  # recast fields and parameter boxes
        p = cert["putinar"]
        if not isinstance(p, dict):
            raise ValueError("no constrained certificate in the file")
        out["parts"] = [{"variables": everything, "free": p.get("free", []),
                         "grams": _grams(p.get("grams", []), "putinar.grams")}]  # fmt: skip
        if "taylor" not in out:
            raise ValueError("taylor (an odd integer) and scale (rationals) are required")
    elif "blocks" in cert:  # independent blocks of variables
        blocks = cert["blocks"]
        if not isinstance(blocks, list) or len(blocks) > MAX_PARTS:
            raise ValueError("blocks must be a non-empty list of variable lists")
        out["parts"] = [_old_part(b, b.get("variables")) if isinstance(b, dict) else b
                        for b in blocks]  # fmt: skip
    else:
        out["parts"] = [_old_part(cert, everything)]
    objects(out["parts"], "parts", MAX_PARTS, empty=False)
    return out


def _eps(part: dict[str, Any], top: Any) -> Fraction:
    """A part's ``eps``: its own or the top level's (both present: they must agree)."""
    own = part.get("eps")
    if own is None:
        return parse_rational(top, "eps")
    eps = parse_rational(own, "eps")
    if top is not None and parse_rational(top, "eps") != eps:
        raise ValueError("eps differs between the certificate and its part")
    return eps


def recheck(system: Any, V: Any, level: float, meta: dict[str, Any], *,
            find_outside: Any = None, cover_estimate: Any = None) -> Validation:  # fmt: skip
    """Re-check a stored exact SOS certificate (``meta``: ``certificate`` and ``eps``) of
    ``{V <= level}`` for ``system`` without any solver: ``certified`` only if every
    precondition holds (:func:`roa.proof._preconditions.check_preconditions`, the domain by the
    stored ``domain`` part or by intervals) and every part passes
    :func:`roa.proof._putinar.check_level` exactly as stored (parts over several blocks must
    partition the variables, no monomial of ``V`` or ``V'`` coupling two of them).
    ``find_outside``: the search of a point of the set outside the domain
    (:func:`roa.search._outside.domain_witness`) and ``cover_estimate`` the proposal of a box
    (:func:`roa.search.ray_box`): see :func:`~roa.proof._preconditions.check_preconditions`."""
    cert = meta.get("certificate")
    pre = check_preconditions(system, V, level, Route("sos-exact", parameters=True),
                              stored_domain=cert.get("domain") if isinstance(cert, dict) else None,
                              recheck=True, find_outside=find_outside,
                              cover_estimate=cover_estimate)  # fmt: skip
    if pre.refusal is not None:
        return pre.refusal
    v = _recheck(system, V, level, meta)
    if v.status is Verdict.CERTIFIED and pre.notes.get("domain"):
        return replace(v, message=f"{v.message}; domain: {pre.notes['domain']}")
    return v


def _recheck(system: Any, V: Any, level: float, meta: dict[str, Any]) -> Validation:
    """:func:`recheck` once the preconditions hold."""
    t0 = time.perf_counter()
    n = int(V.n)

    def out(status: Verdict, message: str, **extra: Any) -> Validation:
        m = {"method": "sos-exact", "M": np.eye(n).tolist(), **extra}
        return Validation(status, float(level), 0, time.perf_counter() - t0, message=message,
                          meta=m)  # fmt: skip

    try:
        form = parts_of(meta.get("certificate"), n)
        parts = form["parts"]
        what = "sparse " if "cliques" in parts[0] else ""
        if "taylor" in form:  # a recast field or a parameter box: one part, every state
            taylor, scale = form.get("taylor"), stored_scale(form, n, chars=100)
            if type(taylor) is not int or scale is None:
                raise ValueError("taylor (an odd integer) and scale (rationals) are required")
            if len(parts) != 1 or parts[0].get("variables") != list(range(n)):
                raise ValueError("a recast certificate has one part over every state")
            try:
                (rdata,), _ = Recast(taylor, scale).apply(system, V, level)
            except NotPolynomial as exc:
                return out(Verdict.INCONCLUSIVE, str(exc))
            stored_box = form.get("parameters")
            if (stored_box or None) != (box_json(rdata.parameters) or None):
                return out(Verdict.INCONCLUSIVE, f"stored SOS certificate refused: the "
                           f"certificate was made for the parameter box {stored_box}, the "
                           f"system's is {box_json(rdata.parameters) or 'none'}")  # fmt: skip
            blocks, subs, what = [tuple(range(n))], [rdata], f"{what}SOS certificate (recast field)"
        else:
            data, why = preconditions(system, V, level)
            if data is None:
                return out(Verdict.INCONCLUSIVE, why)
            scale_ = stored_scale(form, n)
            if scale_ is not None:
                (data,), _ = Rescale(scale_).apply(data)
            blocks = check_partition([p.get("variables") for p in parts], n)
            subs, _ = IndependentBlocks(tuple(blocks)).apply(data)
            what = f"{what}SOS certificate"
        checks = []
        for block, sub, part in zip(blocks, subs, parts, strict=True):
            res = check_level(sub, level, _eps(part, meta.get("eps")),
                              Certificate.parse(part, sub.nv), rounded=True)  # fmt: skip
            if not res.ok:
                where = "" if len(blocks) == 1 else f" of block {list(block)}"
                return out(Verdict.INCONCLUSIVE, f"stored SOS certificate{where} refused: "
                           f"{res.reason}", residual=res.residual, min_pivot=res.min_pivot)  # fmt: skip
            checks.append(res)
    except (ValueError, TypeError, ZeroDivisionError, AttributeError, KeyError) as exc:
        return out(Verdict.INCONCLUSIVE, f"malformed SOS certificate: {exc}")
    if len(blocks) > 1:
        return out(Verdict.CERTIFIED, f"stored SOS certificates of {len(blocks)} independent "
                   "blocks re-checked exactly", blocks=[list(b) for b in blocks])  # fmt: skip
    res = checks[0]
    return out(Verdict.CERTIFIED, f"stored {what} re-checked exactly: {res.reason}",
               residual=res.residual, min_pivot=res.min_pivot, **res.meta)  # fmt: skip
