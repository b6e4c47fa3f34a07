"""The result of :func:`roa.certify`: a verdict on ``{V <= level}`` with its evidence and trace.

:class:`Certificate` keeps its problem (system, V), the validation that decided it, the proposal
the level came from, the refutation just above, and the trace of the pipeline's stages.
:meth:`Certificate.to_dict` is what ``roa certify --json`` prints; :meth:`Certificate.from_dict`
reads it back as a *claim* (the file's status is not believed: :meth:`Certificate.reverify`
proves it again for a system).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov, certificate_fields
from roa.model._fingerprint import system_fingerprint
from roa.model._system import System
from roa.options import IntervalOptions
from roa.progress import step
from roa.proof._validation import Validation
from roa.search._levelset import LevelSearchResult
from roa.search._sos import SOSResult
from roa.status import Verdict

#: The method name of an exact SOS certificate (``roa.SosValidator``).
SOS_EXACT = "sos-exact"


@dataclass(frozen=True)
class Certificate:
    """The verdict on ``{V <= level}``, with the evidence and how the level was chosen.

    Attributes
    ----------
    status : Verdict
        ``certified`` only after interval validation; ``refuted`` with a 50-digit witness;
        ``inconclusive`` otherwise (``message`` says why).
    level : float or None
        The level that was validated (or the SOS candidate with ``method="sos"``).
    method : str
        What produced the verdict: ``"interval"``, ``"sos"`` (an unchecked candidate: never
        certified), ``"level search"`` (no candidate was found) or ``"linearisation"`` (a system
        with uncertain parameters whose V' is not negative definite at the equilibrium for a
        sample point of the box: no level > 0; ``message`` names the parameter values).
    level_source : str or None
        Where the level came from: ``"given"``, ``"sos"``, ``"sampled"``, ``"candidate"``,
        ``"witness"`` (chosen again below a confirmed refutation witness) or ``"backoff"``
        (lowered after the exact SOS check failed at the proposal, every try in the trace and in
        ``meta["backoff"]``, :mod:`roa.certification._backoff`; or, for a system with uncertain
        parameters, after an inconclusive validation, since a level proposed at the box's sample
        points is no bound between them).
    candidate : float or None
        The level before the safety factor (SOS optimum or sampled optimum).
    above : Validation or None
        The validation of ``check_above * candidate`` (expected: refuted).
    """

    status: Verdict
    level: float | None
    method: str
    level_source: str | None
    seconds: float
    message: str = ""
    candidate: float | None = None
    safety_factor: float | None = None
    validation: Validation | None = None
    above: Validation | None = None
    sos: SOSResult | None = None
    search: LevelSearchResult | None = None
    vs: Any = None  # the record of the search of V (VsResult, SampleSearchResult)
    trace: tuple[dict[str, Any], ...] = ()
    system: System | None = field(default=None, repr=False, compare=False)
    V: Lyapunov | None = field(default=None, repr=False, compare=False)

    @property
    def certified(self) -> bool:
        return self.status is Verdict.CERTIFIED

    @property
    def witness(self) -> list[float] | None:
        return None if self.validation is None else self.validation.witness

    def to_dict(self) -> dict[str, Any]:
        """What ``roa certify --json`` prints."""
        out: dict[str, Any] = {}
        if self.system is not None:
            out["system"] = self.system.name
            out["system_fingerprint"] = system_fingerprint(self.system)
            if self.system.parameters:  # the claim holds for every parameter of this box
                out["parameters"] = {k: dict(r._asdict())
                                     for k, r in self.system.parameters.items()}  # fmt: skip
        if self.V is not None:
            out.update(certificate_fields(self.V))
        if self.sos is not None:
            out["sos"] = self.sos.to_json()
        if self.vs is not None:
            out["vs_search"] = self.vs.to_dict()
        if self.search is not None:
            out["level_search"] = {
                "status": self.search.status.value,
                "level": self.search.level,
                "method": self.search.method,
            }
            if self.level_source in ("sampled", "witness"):  # witness: candidate lowered
                out["sampled_level"] = self.search.level
        if self.validation is not None:
            out.update(self.validation.to_json())
        out.update(
            status=self.status.value,
            level=self.level,
            method=self.method,
            level_source=self.level_source,
            candidate=self.candidate,
            safety_factor=self.safety_factor,
            seconds=round(self.seconds, 3),
            message=self.message,
        )
        if self.above is not None:
            out["above"] = self.above.to_json()
        if self.trace:
            out["trace"] = list(self.trace)
        return out

    @classmethod
    def from_dict(cls, data: Any, system: System, *, where: str = "certificate") -> Certificate:
        """The *claim* of a ``roa certify --json`` object for ``system``: its V (``P`` or
        ``candidate_kind``, centred at ``system``'s equilibrium: a file cannot move it), level
        and status as written. Nothing is believed: :meth:`reverify` proves it again.

        Raises :class:`~roa.errors.RoaInputError` naming ``where`` for a malformed object, a
        non-finite or non-positive level, a V of another dimension or centre, or a
        ``system_fingerprint`` that is not ``system``'s.
        """
        from roa.lyapunov import from_json

        if not isinstance(data, dict):
            raise RoaInputError(
                f"{where}: expected the JSON object written by `roa certify --json`"
            )
        missing = [k for k in ("level", "status", "system") if k not in data]
        if "P" not in data and "candidate_kind" not in data:
            missing.insert(0, "P")
        if missing:
            raise RoaInputError(
                f"{where}: missing {', '.join(missing)} (expected the JSON of `roa certify --json`)"
            )
        try:
            status = Verdict(data["status"])
        except ValueError:
            raise RoaInputError(
                f"{where}: status must be one of {[v.value for v in Verdict]}, got "
                f"{data['status']!r}"
            ) from None
        level = data["level"]
        if isinstance(level, bool) or not isinstance(level, int | float):
            raise RoaInputError(f"{where}: level must be a number, got {level!r}")
        try:
            level = float(level)
        except OverflowError:  # an integer beyond the float range
            raise RoaInputError(f"{where}: level must be a finite number > 0, got an integer "
                                f"of {int(level.bit_length() * 0.30103)} digits") from None  # fmt: skip
        if not (np.isfinite(level) and level > 0):
            raise RoaInputError(f"{where}: level must be a finite number > 0, got {level!r}")
        stamp = data.get("system_fingerprint")
        if stamp is not None and stamp != system_fingerprint(system):
            raise RoaInputError(
                f"{where}: the certificate was made for another system than {system.name!r} "
                "as loaded (its system_fingerprint differs: other parameters, field or "
                "equilibrium)"
            )
        kind = data.get("candidate_kind") if "P" not in data else None
        if kind is not None and (
            not isinstance(kind, dict) or kind.get("kind") != "PolynomialLyapunov"
        ):
            what = kind.get("kind") if isinstance(kind, dict) else type(kind).__name__
            raise RoaInputError(
                f"{where}: V is a {what}; a certificate file holds a quadratic or polynomial V "
                "only (a function V cannot be read back from JSON)"
            )
        center = system.x_eq
        try:
            V = from_json(
                {"P": data["P"]} if kind is None else kind,
                center,
                name=str(data.get("lyapunov", "V")),
            )
        except RoaInputError as exc:
            raise RoaInputError(f"{where}: {exc}") from None
        except (TypeError, ValueError, IndexError, OverflowError) as exc:
            raise RoaInputError(
                f"{where}: V cannot be read ({type(exc).__name__}: {exc})"
            ) from None
        if V.n != center.shape[0] or not np.array_equal(V.center, center):
            raise RoaInputError(
                f"{where}: V has {V.n} variables centred at {V.center.tolist()}, the system's "
                f"equilibrium is {center.tolist()}"
            )
        method = str(data.get("method", "interval"))
        stored = None
        if method == SOS_EXACT:  # the exact SOS certificate travels with the claim
            stored = Validation(status, level, 0, 0.0, meta={
                "method": method, "certificate": data.get("certificate"), "eps": data.get("eps")})  # fmt: skip
        return cls(status=status, level=level, method=method, level_source="file", seconds=0.0,
                   message=str(data.get("message", "")), validation=stored, system=system,
                   V=V)  # fmt: skip

    def reverify(self, interval: IntervalOptions | None = None) -> Certificate:
        """This claim proved again on its system: an exact SOS certificate (``method``
        ``"sos-exact"``) by re-checking its stored Gram matrices in exact arithmetic, without any
        solver (:func:`roa.proof._sos_stored.recheck`, block by block for independent blocks);
        any other by interval validation
        (cached by content, :func:`roa.proof.reverify`). ``certified`` only if proved
        here."""
        from roa.proof._reverify import reverify

        if self.system is None or self.V is None or self.level is None:
            raise RoaInputError("reverify: the certificate has no system, V or level")
        if self.method == SOS_EXACT and self.validation is not None:
            from roa.proof._sos_stored import recheck
            from roa.search._outside import domain_witness
            from roa.search._rays import ray_box

            with step(f"re-checking the SOS certificate of {self.V.name} <= {self.level:.6g}"):
                v = recheck(self.system, self.V, self.level, self.validation.meta,
                            find_outside=domain_witness, cover_estimate=ray_box)  # fmt: skip
            return Certificate(status=v.status, level=self.level, method=SOS_EXACT,
                               level_source="reverified", seconds=v.seconds, message=v.message,
                               validation=v, trace=({"stage": "reverify", "by": SOS_EXACT,
                                                     "status": v.status.value},),
                               system=self.system, V=self.V)  # fmt: skip
        from roa.certification._strategies import INTERVAL_ROUTE
        from roa.proof._preconditions import check_preconditions
        from roa.search._outside import domain_witness
        from roa.search._rays import ray_box

        pre = check_preconditions(self.system, self.V, self.level, INTERVAL_ROUTE, recheck=True,
                                  find_outside=domain_witness, cover_estimate=ray_box)  # fmt: skip
        if pre.refusal is not None:
            v = pre.refusal
            return Certificate(status=v.status, level=self.level, method="interval",
                               level_source="reverified", seconds=v.seconds, message=v.message,
                               validation=v, trace=({"stage": "reverify", "by": "preconditions",
                                                     "status": v.status.value},),
                               system=self.system, V=self.V)  # fmt: skip
        with step(f"re-verifying {self.V.name} <= {self.level:.6g} ({self.system.name})"):
            proof = reverify(self.system, self.V, self.level, interval=interval,
                             cover_estimate=ray_box)  # fmt: skip
        record = dict(proof.validation)
        validation = Validation(proof.status, self.level, int(record.get("boxes", 0) or 0),
                                proof.seconds, message=proof.message,
                                meta={k: v for k, v in record.items() if k == "M"})  # fmt: skip
        return Certificate(status=proof.status, level=self.level, method="interval",
                           level_source="reverified", seconds=proof.seconds,
                           message=proof.message, validation=validation,
                           trace=({"stage": "reverify", "cached": proof.cached,
                                   "status": proof.status.value},),
                           system=self.system, V=self.V)  # fmt: skip

    def plot(self, ax: Any = None, *, axes: tuple[int, int] = (0, 1), n: int = 200) -> Any:
        """The level set ``{V <= level}`` on the slice of two states through the equilibrium; the
        legend below the axes (never on the curve), one unit as long on both axes when they share
        their unit, and a new figure laid out so that a plain ``savefig`` keeps it all."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(5, 5), layout="constrained")
        if self.level is None or self.V is None or self.system is None:
            ax.set_title(f"no level ({self.status.value})")
            return ax
        i, j = axes
        c = self.V.center
        style = "-" if self.certified else "--"
        label = f"V <= {self.level:.6g} ({self.status})"
        P = self.V.quadratic_matrix()
        if P is not None:
            Pij = P[np.ix_([i, j], [i, j])]
            t = np.linspace(0, 2 * np.pi, n)
            L = np.linalg.cholesky(Pij)
            pts = np.sqrt(self.level) * np.linalg.solve(L.T, np.stack([np.cos(t), np.sin(t)]))
            ax.plot(c[i] + pts[0], c[j] + pts[1], style, label=label)
        else:
            _contour(ax, self.V, self.level, (i, j), n, style, label)
        from roa.plotting._basin import shared_units, unit_text

        names, units = self.system.state_names, self.system.state_units or ("-",) * self.system.n
        ax.set_xlabel(f"{names[i]} [{unit_text(units[i])}]")
        ax.set_ylabel(f"{names[j]} [{unit_text(units[j])}]")
        if shared_units(self.system, i, j):
            ax.set_aspect("equal", adjustable="datalim")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), frameon=False, fontsize=9)
        return ax


def _contour(ax: Any, V: Lyapunov, level: float, axes: tuple[int, int], n: int, style: str,
             label: str) -> None:  # fmt: skip
    """The curve V = level on the slice of two states through the centre (any candidate)."""
    from roa.search._rays import ray_box

    i, j = axes
    c = V.center
    half = ray_box(V, level)
    half = np.ones(V.n) if half is None else 1.2 * half
    a = np.linspace(c[i] - half[i], c[i] + half[i], n)
    b = np.linspace(c[j] - half[j], c[j] + half[j], n)
    A, B = np.meshgrid(a, b)
    X = np.broadcast_to(c, (*A.shape, V.n)).copy()
    X[..., i], X[..., j] = A, B
    ax.contour(A, B, V.value(X), levels=[level], colors="C0", linestyles=style)
    ax.plot([], [], style, color="C0", label=label)
