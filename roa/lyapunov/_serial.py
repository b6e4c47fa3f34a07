"""One JSON form of a Lyapunov candidate, read wherever a V comes from a file.

:func:`from_json` reads every form the toolkit writes: ``{"P": rows}`` (quadratic), a polynomial's
``describe()`` (``{"monomials": [...], "coefficients": [...]}`` in ``d = x - center``), or an
object holding one of those under ``"V"`` (a region) or ``"candidate_kind"`` (``roa certify
--json`` of a non-quadratic V). :func:`certificate_fields` writes the certificate's form.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov._base import Lyapunov
from roa.lyapunov._polynomial import PolynomialLyapunov, QuadraticLyapunov


def certificate_fields(V: Lyapunov) -> dict[str, Any]:
    """V as ``roa certify --json`` writes it: its name and ``P`` for a quadratic form, else its
    ``describe()`` under ``candidate_kind``."""
    if V.P is not None:
        return {"lyapunov": V.name, "P": np.asarray(V.P).tolist()}
    return {"lyapunov": V.name, "candidate_kind": V.describe()}


def from_json(data: Mapping[str, Any], center: Any, *, name: str = "V") -> Lyapunov:
    """A Lyapunov candidate from its JSON form, centred at ``center`` unless the JSON says.

    Accepts ``{"P": rows}`` (quadratic), ``{"monomials": [...], "coefficients": [...]}``
    (:class:`~roa.lyapunov.PolynomialLyapunov` in ``d = x - center``, as its
    ``describe()`` writes it), or an object holding one of those under ``"V"`` (a
    :meth:`Region.to_json`) or ``"candidate_kind"`` (``roa certify --json`` for a non-quadratic V).
    """
    if not isinstance(data, Mapping):
        raise RoaInputError(f"V: expected a JSON object, got {type(data).__name__}")
    for key in ("V", "candidate_kind"):
        if "P" not in data and "monomials" not in data and isinstance(data.get(key), Mapping):
            return from_json(data[key], data.get("center", center), name=name)
    try:
        c = np.asarray(data.get("center", center), dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise RoaInputError("V: center must be a list of numbers") from None
    name = str(data.get("lyapunov", name))
    if "P" in data:
        try:
            P = np.asarray(data["P"], dtype=float)
        except (TypeError, ValueError):
            raise RoaInputError("V: P must be a list of rows of numbers") from None
        n = P.shape[0] if P.ndim == 2 else 0
        return QuadraticLyapunov(P, c if c.size else np.zeros(n), name)
    if "monomials" in data and "coefficients" in data:
        mono = data["monomials"]
        n = len(mono[0]) if isinstance(mono, list) and mono and isinstance(mono[0], list) else 0
        V = PolynomialLyapunov(mono, data["coefficients"], c if c.size else np.zeros(n), name)
        if "gram" in data:
            V.with_gram(_gram(data["gram"], V.n))
        return V
    kind = data.get("kind")
    raise RoaInputError(
        "V: the JSON holds neither P nor polynomial monomials and coefficients"
        + (f" (a {kind} cannot be rebuilt from JSON: give it as file.py:NAME)" if kind else "")
    )


def _gram(raw: Any, n: int) -> tuple[list[tuple[int, ...]], np.ndarray]:
    """A stored Gram matrix ``{"basis": [[exponents]...], "Q": rows}`` of a polynomial V in ``n``
    variables (only its shapes are checked here: :func:`roa.proof.gram_cover` proves it)."""
    try:
        basis = [tuple(int(e) for e in b) for b in raw["basis"]]
        Q = np.asarray(raw["Q"], dtype=float)
    except (TypeError, ValueError, KeyError):
        raise RoaInputError("V: gram must be {'basis': [[exponents]...], 'Q': rows}") from None
    m = len(basis)
    if any(len(b) != n or min(b, default=0) < 0 for b in basis):
        raise RoaInputError(f"V: gram basis must hold {n} non-negative exponents per monomial")
    if Q.shape != (m, m) or not np.all(np.isfinite(Q)):
        raise RoaInputError(f"V: gram Q must be a finite {m}x{m} matrix, got shape {Q.shape}")
    return basis, Q
