"""The steps of a network: affine maps and elementwise activations, checked when built.

:class:`Affine` and :class:`Activation` are what :class:`roa.nn.MLP` chains, what the readers of
ONNX files and PyTorch modules produce, and what the proof namespaces evaluate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.model._backend import ACTIVATIONS, LEAKY_SLOPE

#: Activation names accepted by :class:`MLP` (``None``/``"identity"``: no activation).
ACTIVATION_NAMES = (*ACTIVATIONS, "clip", "identity")


@dataclass(frozen=True, eq=False)
class Affine:
    """``y = W x + b``: ``W`` of shape ``(outputs, inputs)``, ``b`` of shape ``(outputs,)``."""

    W: np.ndarray
    b: np.ndarray


@dataclass(frozen=True)
class Activation:
    """An elementwise activation ``name`` with its parameters (``leaky_relu``: ``(alpha,)``;
    ``clip``: ``(lo, hi)``)."""

    name: str
    args: tuple[float, ...] = ()


Op = Affine | Activation


def matrix(a: Any, what: str, ndim: int) -> np.ndarray:
    """``a`` as a read-only float64 array of ``ndim`` dimensions with finite entries; an input
    error naming ``what`` otherwise."""
    try:
        arr = np.array(a, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise RoaInputError(f"MLP: {what} is not an array of numbers ({exc})") from None
    if arr.ndim != ndim:
        raise RoaInputError(f"MLP: {what} must have {ndim} dimensions, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise RoaInputError(f"MLP: {what} has non-finite entries")
    arr.setflags(write=False)
    return arr


def activation(spec: Any, where: str) -> Activation | None:
    """The activation of ``spec``: ``None`` / ``"identity"`` (none), a name, or a tuple
    ``(name, *args)``; an input error naming ``where`` for an unknown name or bad parameters."""
    if spec is None or spec == "identity" or spec == "linear":
        return None
    name, args = (spec, ()) if isinstance(spec, str) else (spec[0], tuple(spec[1:]))
    if name in ("identity", "linear") and not args:  # also as a step of from_ops: no activation
        return None
    if name not in ACTIVATION_NAMES:
        raise RoaInputError(
            f"MLP: {where}: unknown activation {name!r}; allowed: {', '.join(ACTIVATION_NAMES)}"
        )
    try:
        vals = tuple(float(a) for a in args)
    except (TypeError, ValueError):
        raise RoaInputError(
            f"MLP: {where}: parameters of {name} must be numbers: {args!r}"
        ) from None
    if name == "leaky_relu":
        if len(vals) > 1:
            raise RoaInputError(f"MLP: {where}: leaky_relu takes one slope, got {args!r}")
        vals = vals or (LEAKY_SLOPE,)
        if not (np.isfinite(vals[0]) and vals[0] >= 0):
            raise RoaInputError(f"MLP: {where}: the leaky_relu slope must be >= 0, got {vals[0]}")
    elif name == "clip":
        if len(vals) != 2 or not vals[0] <= vals[1] or np.isnan(vals).any():
            raise RoaInputError(f"MLP: {where}: clip takes (lo, hi) with lo <= hi, got {args!r}")
    elif vals:
        raise RoaInputError(f"MLP: {where}: {name} takes no parameters, got {args!r}")
    return Activation(name, vals)
