"""Reading a feed-forward network from a PyTorch ``nn.Sequential`` (the ``torch`` extra).

:func:`read_torch` accepts a ``torch.nn.Sequential`` (nested ``Sequential`` blocks are
flattened) whose modules are, in order of application:

* ``Linear`` -> the affine map ``W = weight``, ``b = bias`` (``0`` without a bias);
* ``ReLU``, ``Tanh``, ``Sigmoid``;
* ``LeakyReLU(negative_slope)`` -> ``leaky_relu``;
* ``Hardtanh(min_val, max_val)`` (``ReLU6`` is ``Hardtanh(0, 6)``) -> ``clip``;
* ``Softplus`` with ``beta = 1`` -> ``softplus``, the exact ``log(1 + exp(z))`` (PyTorch returns
  ``z`` itself where ``z > threshold``, a difference below ``log(1 + exp(-threshold))``; the
  certificate is about the exact function);
* ``Identity``, ``Flatten``, ``Dropout`` (no effect on the evaluated network) are skipped.

Any other module is refused by name (:class:`roa.RoaInputError`). Parameters are read as float64
(float32 and float16 values are doubles exactly), so the network certified is the one PyTorch
evaluates, up to PyTorch's own rounding of its float32 arithmetic.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.nn._ops import Activation, Affine, Op

#: PyTorch modules read by :func:`read_torch`.
SUPPORTED_MODULES = (
    "Linear",
    "ReLU",
    "Tanh",
    "Sigmoid",
    "LeakyReLU",
    "Hardtanh",
    "ReLU6",
    "Softplus",
    "Identity",
    "Flatten",
    "Dropout",
)
_SIMPLE = {"ReLU": "relu", "Tanh": "tanh", "Sigmoid": "sigmoid"}
_SKIPPED = ("Identity", "Flatten", "Dropout")


def _array(tensor: Any, what: str) -> np.ndarray:
    try:
        return np.array(tensor.detach().cpu().double().numpy(), dtype=np.float64)
    except AttributeError:
        raise RoaInputError(f"MLP.from_torch: {what} is not a tensor") from None


def _modules(module: Any) -> list[tuple[str, Any]]:
    """The modules of a (nested) ``Sequential`` in order, with dotted names."""
    try:
        import torch
    except ImportError:
        raise RoaInputError(
            "MLP.from_torch needs PyTorch: pip install torch (in a checkout of roa: pip install -e '.[torch]')"
        ) from None
    if not isinstance(module, torch.nn.Sequential):
        raise RoaInputError(
            f"MLP.from_torch: expected a torch.nn.Sequential, got {type(module).__name__}; "
            "write the network as nn.Sequential(Linear, activation, ..., Linear) or export it "
            "to ONNX (MLP.from_onnx)"
        )
    out: list[tuple[str, Any]] = []
    for name, child in module.named_children():
        if isinstance(child, torch.nn.Sequential):
            out.extend((f"{name}.{n}", c) for n, c in _modules(child))
        else:
            out.append((name, child))
    return out


def read_torch(module: Any) -> list[Op]:
    """The chain of affine maps and activations of the ``nn.Sequential`` ``module`` (module
    doc)."""
    ops: list[Op] = []
    for name, child in _modules(module):
        kind = type(child).__name__
        where = f"module {name!r} ({kind})"
        if kind not in SUPPORTED_MODULES:
            raise RoaInputError(
                f"MLP.from_torch: unsupported {where}; supported: {', '.join(SUPPORTED_MODULES)}"
            )
        if kind == "Linear":
            W = _array(child.weight, f"{where} weight")
            b = (
                _array(child.bias, f"{where} bias")
                if child.bias is not None
                else np.zeros(W.shape[0])
            )
            ops.append(Affine(W, b))
        elif kind in _SIMPLE:
            ops.append(Activation(_SIMPLE[kind]))
        elif kind == "LeakyReLU":
            ops.append(Activation("leaky_relu", (float(child.negative_slope),)))
        elif kind in ("Hardtanh", "ReLU6"):
            ops.append(Activation("clip", (float(child.min_val), float(child.max_val))))
        elif kind == "Softplus":
            if float(child.beta) != 1.0:
                raise RoaInputError(
                    f"MLP.from_torch: {where} has beta = {child.beta}; only beta = 1 is read"
                )
            ops.append(Activation("softplus"))
    if not any(isinstance(op, Affine) for op in ops):
        raise RoaInputError("MLP.from_torch: the Sequential holds no Linear layer")
    return ops
