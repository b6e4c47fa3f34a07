"""The verdict of an interval validation, with its evidence (what every prover returns)."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from roa.status import Verdict


class Reason(Enum):
    """Why a validation ended as it did, for the code that acts on it (the message is for
    people: no code reads it)."""

    #: Nothing more specific than the verdict.
    UNSPECIFIED = "unspecified"
    #: The domain containment was not proved, or the set leaves the domain (``meta["domain_level"]``
    #: then holds V at a confirmed point outside it).
    DOMAIN = "domain"
    #: Another precondition of the route failed (``meta["precondition"]`` names it).
    PRECONDITION = "precondition"
    #: No proved box covers the level set.
    NO_COVER = "no cover"


@dataclass(frozen=True)
class Validation:
    """Outcome of an interval validation of ``V' < 0`` on ``{V <= level} \\ {x_eq}``.

    ``witness_parameters``: for a system with uncertain parameters, the parameter values (by
    name) at which the witness has ``V' >= 0``. ``reason``: why it ended so (:class:`Reason`),
    what code branches on (``message`` is for people)."""

    status: Verdict
    level: float
    boxes: int
    seconds: float
    witness: list[float] | None = None
    witness_check: dict[str, Any] | None = None
    message: str = ""
    witness_parameters: dict[str, float] | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    reason: Reason = Reason.UNSPECIFIED

    def to_json(self) -> dict[str, Any]:
        out = {
            "status": self.status.value,
            "level": self.level,
            "method": "interval",
            "boxes": self.boxes,
            "seconds": round(self.seconds, 3),
            "message": self.message,
            **self.meta,
        }
        if self.witness is not None:
            out["witness"] = self.witness
            out["witness_check"] = self.witness_check
            if self.witness_parameters is not None:
                out["witness_parameters"] = self.witness_parameters
        return out
