"""Neural networks as parts of vector fields: :class:`MLP` (numpy arrays, ONNX files).

See :mod:`roa.nn.mlp` for what a network computes in each namespace and what a certificate of a
closed loop with a network controller claims.
"""

from __future__ import annotations

from roa.nn.mlp import MLP
from roa.nn.ops import ACTIVATION_NAMES, Activation, Affine

__all__ = ["ACTIVATION_NAMES", "MLP", "Activation", "Affine"]
