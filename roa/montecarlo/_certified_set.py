"""Terminal sets from certificate files: read, bound to the system as loaded, proved again.

:func:`terminal_from_certificate` takes the JSON of ``roa certify --json`` (a file or its dict):
the claim is read by :meth:`roa.certification.Certificate.from_dict` for the system the
certificate is about (``system`` itself, or analysis coordinates it declares), re-verified by
interval validation (:meth:`~roa.certification.Certificate.reverify`, cached by content), and only
then turned into a :class:`~roa.integration.TerminalSet` (an ellipsoid for a quadratic V,
else the proved component box in the re-verification's frame).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, cast

import numpy as np

from roa.certification._files import read_certificate_json
from roa.certification._result import Certificate
from roa.errors import RoaInputError
from roa.integration._terminal import TerminalSet
from roa.lyapunov import Lyapunov, PolynomialLyapunov
from roa.model._system import System
from roa.status import Verdict


def terminal_from_certificate(source: str | Path | dict[str, Any], system: System) -> TerminalSet:
    """The certified set of a ``roa certify --json`` certificate for ``system``, re-verified.

    Refused (:class:`roa.errors.RoaInputError`, with the reason) unless its status is
    ``certified``, it names ``system`` (or analysis coordinates ``system`` declares), its
    ``system_fingerprint`` (when present) is that system's, and the re-verification proves it.
    """
    where = "terminal set" if isinstance(source, dict) else f"terminal set {source}"
    data = read_certificate_json(source, where)
    if data.get("status") != "certified":
        raise RoaInputError(
            f"{where}: status {data.get('status')!r}, not 'certified': only an "
            "interval-validated level set may finish trajectories"
        )
    cert_system = str(data.get("system"))
    analysis, coords = system, None  # the system the certificate's V and level are about
    if "system" in data and cert_system != system.name:
        provider = system.analysis_coords
        declared = getattr(provider, "systems", {}) or {}
        if cert_system not in declared:
            raise RoaInputError(
                f"{where}: the certificate is for system {cert_system!r}, not {system.name!r}"
                + (f" (allowed: {', '.join([system.name, *declared])})" if declared else "")
            )
        coords = declared[cert_system]
        analysis = provider.system(coords)
    claim = Certificate.from_dict(data, analysis, where=where)
    proof = claim.reverify()
    if proof.status is not Verdict.CERTIFIED:
        raise RoaInputError(
            f"{where}: re-verification failed for system {analysis.name!r} at level "
            f"{claim.level:.6g}: {proof.status.value}"
            + (f" ({proof.message})" if proof.message else "")
            + "; only a level set proved for the system as loaded may finish trajectories"
        )
    assert claim.V is not None and claim.level is not None and proof.validation is not None
    center = claim.V.center  # the centre proved (bind() checks the mapped equilibrium is inside)
    name = f"{data.get('lyapunov', 'V')} <= {claim.level:.6g} ({cert_system})"
    return terminal_of(claim.V, claim.level, center, coords, name,
                       frame=proof.validation.meta.get("M"))  # fmt: skip


def terminal_of(
    V: Lyapunov,
    level: float,
    center: np.ndarray,
    coords: str | None,
    name: str,
    *,
    frame: Any = None,
) -> TerminalSet:
    """The terminal set ``{V <= level}`` of a *proved* certificate: an ellipsoid for a quadratic
    (or degree-2 polynomial) V, else the component box in the validation's ``frame``."""
    P = V.quadratic_matrix()
    if P is None and V.degree == 2:  # an ellipsoid: the quadratic fast path (exactly H / 2)
        P = 0.5 * V.hessian_at_center()
    if P is not None:
        return TerminalSet(P, center, level, coords, name)
    if not V.is_polynomial:
        raise RoaInputError(f"terminal set: V is a {type(V).__name__}, not a polynomial")
    if frame is None:
        raise RoaInputError(
            "terminal set: a polynomial V needs the frame of its validation (re-verify it)"
        )
    from roa.search._rays import component_candidates

    return TerminalSet.polynomial(cast(PolynomialLyapunov, V), float(level), coords, name,
                                  frame=frame, propose=component_candidates)  # fmt: skip
