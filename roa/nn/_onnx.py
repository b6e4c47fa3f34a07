"""Reading a feed-forward network from an ONNX file (the ``onnx`` package: the ``nn`` extra).

:func:`read_onnx` accepts a graph with one input and one output whose nodes form a chain, each
consuming the previous node's output (and constant tensors: initializers or ``Constant`` nodes):

* ``Gemm`` (``alpha = beta = 1``, ``transA = 0``, any ``transB``): ``y = x B + C`` (rows of
  states) -> the affine map ``W = B^T``, ``b = C``;
* ``MatMul`` with a constant right operand: ``y = x B`` -> ``W = B^T``, ``b = 0``;
* ``Add`` with a constant operand: the bias of the preceding affine map when it has none (a
  ``MatMul``), else a new affine map with ``W = I`` (no float sum of biases);
* ``Relu``, ``Tanh``, ``Sigmoid``, ``Clip`` (bounds from inputs or, before opset 11,
  attributes; absent bounds are infinite).

Any other operator is refused by name (:class:`roa.RoaInputError`), as is a graph that is not
such a chain. Weights are converted to float64 exactly (float32 values are doubles).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.nn._ops import Activation, Affine, Op

#: ONNX operators read by :func:`read_onnx` (``Constant`` only supplies data).
SUPPORTED_OPS = ("Gemm", "MatMul", "Add", "Relu", "Tanh", "Sigmoid", "Clip")
_ACT = {"Relu": "relu", "Tanh": "tanh", "Sigmoid": "sigmoid"}


def _onnx() -> Any:
    try:
        import onnx
    except ImportError:
        raise RoaInputError(
            "MLP.from_onnx needs the onnx package: pip install onnx (in a checkout of roa: pip install -e '.[nn]')"
        ) from None
    return onnx


def read_onnx(path: str | Path) -> list[Op]:
    """The chain of affine maps and activations of the ONNX file ``path`` (module doc)."""
    onnx = _onnx()
    from onnx import numpy_helper

    where = f"ONNX file {path}"
    try:
        model = onnx.load(str(path))
    except FileNotFoundError:
        raise RoaInputError(f"{where}: no such file") from None
    except Exception as exc:  # noqa: BLE001 - protobuf decode errors of a damaged file
        raise RoaInputError(
            f"{where}: cannot be read as ONNX ({type(exc).__name__}: {exc})"
        ) from None
    graph = model.graph
    for node in graph.node:  # refuse unsupported operators first, by name
        if node.op_type not in (*SUPPORTED_OPS, "Constant"):
            raise RoaInputError(
                f"{where}: unsupported operator {node.op_type!r} (node {node.name!r}); "
                f"supported: {', '.join(SUPPORTED_OPS)}"
            )
    consts: dict[str, np.ndarray] = {
        t.name: numpy_helper.to_array(t).astype(np.float64) for t in graph.initializer
    }
    inputs = [i.name for i in graph.input if i.name not in consts]
    if len(inputs) != 1 or len(graph.output) != 1:
        raise RoaInputError(
            f"{where}: the graph must have one input and one output, "
            f"got inputs {inputs} and {len(graph.output)} outputs"
        )
    current = inputs[0]
    ops: list[Op] = []

    def const(name: str, node: Any) -> np.ndarray:
        if name not in consts:
            raise RoaInputError(
                f"{where}: node {node.name!r} ({node.op_type}): operand {name!r} is not a constant"
            )
        return consts[name]

    for node in graph.node:
        attrs = {a.name: onnx.helper.get_attribute_value(a) for a in node.attribute}
        if node.op_type == "Constant":
            if "value" not in attrs:
                raise RoaInputError(f"{where}: Constant node {node.name!r} without a tensor value")
            consts[node.output[0]] = numpy_helper.to_array(attrs["value"]).astype(np.float64)
            continue
        data_in = [i for i in node.input if i and i not in consts]
        if data_in != [current]:
            raise RoaInputError(
                f"{where}: node {node.name!r} ({node.op_type}) does not continue the chain from "
                f"{current!r} (inputs {list(node.input)}): only sequential networks are read"
            )
        op = node.op_type
        if op == "Gemm":
            alpha, beta = float(attrs.get("alpha", 1.0)), float(attrs.get("beta", 1.0))
            if alpha != 1.0 or beta != 1.0 or attrs.get("transA", 0):
                raise RoaInputError(
                    f"{where}: Gemm node {node.name!r} with alpha={alpha}, beta={beta}, "
                    f"transA={attrs.get('transA', 0)}: only alpha = beta = 1, transA = 0"
                )
            if node.input[0] != current:
                raise RoaInputError(f"{where}: Gemm node {node.name!r}: the state must be A")
            B = const(node.input[1], node)
            B = B.T if attrs.get("transB", 0) else B
            C = const(node.input[2], node) if len(node.input) > 2 and node.input[2] else None
            b = np.zeros(B.shape[1]) if C is None else np.broadcast_to(C, (B.shape[1],))
            ops.append(Affine(B.T, np.array(b, dtype=np.float64)))
        elif op == "MatMul":
            if node.input[0] != current:
                raise RoaInputError(f"{where}: MatMul node {node.name!r}: the state must be first")
            B = const(node.input[1], node)
            if B.ndim != 2:
                raise RoaInputError(
                    f"{where}: MatMul node {node.name!r}: weight of shape {B.shape}"
                )
            ops.append(Affine(B.T, np.zeros(B.shape[1])))
        elif op == "Add":
            other = next(i for i in node.input if i != current)
            c = const(other, node).reshape(-1)
            last = ops[-1] if ops else None
            if isinstance(last, Affine) and not np.any(last.b) and c.size in (1, last.b.size):
                ops[-1] = Affine(last.W, np.broadcast_to(c, last.b.shape).copy())  # 0 + c: exact
            else:
                ops.append(Affine(np.eye(c.size), c.copy()))
        elif op == "Clip":
            lo = attrs.get("min", -np.inf)
            hi = attrs.get("max", np.inf)
            if len(node.input) > 1 and node.input[1]:
                lo = float(const(node.input[1], node).reshape(()))
            if len(node.input) > 2 and node.input[2]:
                hi = float(const(node.input[2], node).reshape(()))
            ops.append(Activation("clip", (float(lo), float(hi))))
        else:
            ops.append(Activation(_ACT[op]))
        current = node.output[0]
    if current != graph.output[0].name:
        raise RoaInputError(f"{where}: the chain ends at {current!r}, not at the graph's output")
    return ops
