"""Multilayer perceptrons as parts of a vector field, in every namespace of :mod:`roa.model._backend`.

An :class:`MLP` is a chain of affine maps ``y = W x + b`` and elementwise activations
(:data:`roa.model._backend.ACTIVATIONS`, and ``clip``), with float64 weights taken as the exact real
numbers they are. A field written against ``xp`` calls it like a function of the namespace::

    net = MLP([(W1, b1), (W2, b2)], ["tanh", None])

    def field(t, x, xp):
        u = net([x[0], x[1]], xp)[0]
        return (x[1], -xp.sin(x[0]) - 0.1 * x[1] + u)

What it computes in each namespace (``net(x, xp)`` returns a list, one entry per output):

* ``numpy``: matrix products on the stacked inputs (any common shape: one product per layer for
  a whole batch of states);
* ``interval`` (:data:`roa.proof.INTERVAL`): the interval matrix-vector product
  :func:`roa.proof.interval_affine` (positive and negative parts of ``W``, an a priori
  bound of the float dot products' error subtracted / added with outward rounding) and the
  interval activations -- an enclosure of the real network over the boxes, under the libm
  assumption of :data:`roa.proof.LIBM_ULPS` (``tanh``, ``exp``, ``log1p``);
* ``linear`` (:data:`roa.proof._relax.LINEAR`): affine lower and upper bounds of the outputs
  over boxes by CROWN back-substitution with outward rounding (:func:`roa.proof.crown`);
* every other namespace (CasADi, sympy, mpmath, the interval jets of :mod:`roa.proof._jet`):
  neuron by neuron, ``sum_j W_ij x_j + b_i`` with the weights as Python floats (exact), then
  the namespace's activation. In sympy the network becomes one expression per output (so traced
  fields compile to Monte Carlo kernels and exact checks see the exact weights).

**Zero at the equilibrium.** :meth:`MLP.centred` gives the network ``x -> net(x) - net(x0)``,
evaluated as the same network at ``x`` and at the constant ``x0`` in the namespace at hand: in
sympy the two expressions are identical at ``x = x0``, so the closed loop's equilibrium is exact
(:func:`roa.proof.exact_equilibrium`) whatever the biases are; in intervals the
difference of the two enclosures encloses it.

The certificate is about the real-valued network with these weights (float32 weights of an ONNX
file are exact doubles), not about a float32 inference engine's rounding.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.nn._ops import Activation, Affine, Op, activation, matrix


class MLP:
    """A feed-forward network: affine layers and elementwise activations (module doc).

    Parameters
    ----------
    layers : sequence of (W, b)
        Weight matrices ``W`` of shape ``(outputs, inputs)`` and biases ``b`` of shape
        ``(outputs,)``, taken as float64 (exact real numbers from then on).
    activations : str or sequence, optional
        One per layer, applied after it: a name of :data:`roa.nn.ACTIVATION_NAMES`, ``None`` (none), or a
        tuple ``("leaky_relu", alpha)`` / ``("clip", lo, hi)``. A sequence one shorter than
        ``layers`` leaves the output layer linear; a single name applies to every hidden layer.
    """

    def __init__(self, layers: Sequence[Any], activations: Any = "tanh") -> None:
        layers = list(layers)
        if not layers:
            raise RoaInputError("MLP: layers is empty")
        if isinstance(activations, str) or activations is None:
            acts: list[Any] = [activations] * (len(layers) - 1)
        else:
            acts = list(activations)
        if len(acts) == len(layers) - 1:
            acts.append(None)
        if len(acts) != len(layers):
            raise RoaInputError(
                f"MLP: {len(acts)} activations for {len(layers)} layers "
                f"(one per layer, or one per hidden layer)"
            )
        ops: list[Op] = []
        for k, (layer, act) in enumerate(zip(layers, acts, strict=True)):
            try:
                W, b = layer
            except (TypeError, ValueError):
                raise RoaInputError(f"MLP: layer {k} must be a pair (W, b)") from None
            ops.append(Affine(matrix(W, f"layer {k} W", 2), matrix(b, f"layer {k} b", 1)))
            a = activation(act, f"layer {k}")
            if a is not None:
                ops.append(a)
        self._init(tuple(ops), None)

    def _init(self, ops: tuple[Op, ...], centre: tuple[float, ...] | None) -> None:
        width: int | None = None
        for k, op in enumerate(ops):
            if isinstance(op, Affine):
                out, inp = op.W.shape
                if op.b.shape != (out,):
                    raise RoaInputError(
                        f"MLP: affine map {k}: W has {out} rows but b has shape {op.b.shape}"
                    )
                if width is not None and inp != width:
                    raise RoaInputError(
                        f"MLP: affine map {k} takes {inp} inputs, the previous layer gives {width}"
                    )
                width = out
        first = next((op for op in ops if isinstance(op, Affine)), None)
        if first is None:
            raise RoaInputError("MLP: the network has no affine layer")
        self.ops = ops
        self.n_in = int(first.W.shape[1])
        self.n_out = int(width) if width is not None else self.n_in
        self.centre = centre

    @classmethod
    def from_ops(cls, ops: Sequence[Op]) -> MLP:
        """A network from a chain of :class:`Affine` and :class:`Activation` steps."""
        net = cls.__new__(cls)
        checked: list[Op] = []
        for k, op in enumerate(ops):
            if isinstance(op, Affine):
                checked.append(
                    Affine(matrix(op.W, f"step {k} W", 2), matrix(op.b, f"step {k} b", 1))
                )
            elif isinstance(op, Activation):
                a = activation((op.name, *op.args), f"step {k}")
                if a is not None:
                    checked.append(a)
            else:
                raise RoaInputError(f"MLP: step {k} is {type(op).__name__}, not Affine/Activation")
        net._init(tuple(checked), None)
        return net

    @classmethod
    def from_onnx(cls, path: str | Path) -> MLP:
        """A network from an ONNX file (:func:`roa.nn._onnx.read_onnx`; needs the ``onnx`` package,
        the ``nn`` extra). Operators other than Gemm, MatMul, Add, Relu, Tanh, Sigmoid, Clip (and
        Constant data) are refused by name."""
        from roa.nn._onnx import read_onnx

        return cls.from_ops(read_onnx(path))

    @classmethod
    def from_torch(cls, module: Any) -> MLP:
        """A network from a PyTorch ``nn.Sequential`` (:func:`roa.nn._pytorch.read_torch`; needs
        PyTorch, the ``torch`` extra). Modules other than Linear, ReLU, Tanh, Sigmoid, LeakyReLU,
        Hardtanh/ReLU6, Softplus (and Identity, Flatten, Dropout, skipped) are refused by name."""
        from roa.nn._pytorch import read_torch

        return cls.from_ops(read_torch(module))

    @classmethod
    def load(cls, path: str | Path) -> MLP:
        """A network saved by :meth:`save` (an ``.npz``: ``W0, b0, W1, ...`` and ``activations``)."""
        import json

        with np.load(Path(path), allow_pickle=False) as data:
            acts = json.loads(str(data["activations"]))
            k = sum(1 for key in data.files if key.startswith("W"))
            layers = [(data[f"W{i}"], data[f"b{i}"]) for i in range(k)]
        return cls(layers, [a if a is None or isinstance(a, str) else tuple(a) for a in acts])

    def save(self, path: str | Path) -> None:
        """Write the layers and activations as an ``.npz`` (networks of alternating affine maps and
        at most one activation each, as :class:`MLP` builds them)."""
        import json

        arrays: dict[str, Any] = {}
        acts: list[Any] = []
        for op in self.ops:
            if isinstance(op, Affine):
                k = len(acts)
                arrays[f"W{k}"], arrays[f"b{k}"] = op.W, op.b
                acts.append(None)
            elif acts and acts[-1] is None:
                acts[-1] = op.name if not op.args else [op.name, *op.args]
            else:
                raise RoaInputError("MLP.save: two activations in a row cannot be stored")
        np.savez(Path(path), activations=np.array(json.dumps(acts)), **arrays)

    def centred(self, x0: Sequence[float]) -> MLP:
        """The network ``x -> net(x) - net(x0)``: zero at ``x0`` exactly (module doc)."""
        c = tuple(float(v) for v in x0)
        if len(c) != self.n_in or not all(np.isfinite(c)):
            raise RoaInputError(f"MLP.centred: x0 must be {self.n_in} finite numbers, got {x0!r}")
        net = MLP.__new__(MLP)
        net._init(self.ops, c)
        return net

    @property
    def layers(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The affine maps ``(W, b)`` in order."""
        return [(op.W, op.b) for op in self.ops if isinstance(op, Affine)]

    def __repr__(self) -> str:
        parts = []
        for op in self.ops:
            if isinstance(op, Affine):
                parts.append(f"{op.W.shape[1]}->{op.W.shape[0]}")
            else:
                parts.append(op.name + (f"{op.args}" if op.args else ""))
        centre = f", centred at {list(self.centre)}" if self.centre is not None else ""
        return f"MLP({', '.join(parts)}{centre})"

    def __getstate__(self) -> dict[str, Any]:
        return {"ops": self.ops, "centre": self.centre}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self._init(state["ops"], state["centre"])

    # -- evaluation --------------------------------------------------------------------------------
    def __call__(self, x: Sequence[Any], xp: Any) -> list[Any]:
        """The outputs (a list of ``n_out``) at the inputs ``x`` (``n_in`` entries) in ``xp``."""
        x = list(x)
        if len(x) != self.n_in:
            raise RoaInputError(f"MLP: {len(x)} inputs given, the network takes {self.n_in}")
        out = self._raw(x, xp)
        if self.centre is None:
            return out
        at = self._raw(self._centre_in(xp), xp)
        return [a - b for a, b in zip(out, at, strict=True)]

    def _centre_in(self, xp: Any) -> list[Any]:
        """The centre as constants of ``xp`` that its arithmetic does not round before the
        network's own operations: sympy Floats (exact doubles, made exact rationals by the exact
        checks, so ``net(x0)`` is term by term the expression of ``net(x)`` at ``x = x0``), mpmath
        numbers, point intervals; plain floats elsewhere."""
        assert self.centre is not None
        name = getattr(xp, "name", "")
        if name == "sympy":
            import sympy as sp

            return [sp.Float(v, 53) for v in self.centre]
        if name == "mpmath":
            import mpmath as mp

            return [mp.mpf(v) for v in self.centre]
        if name in ("interval", "interval-jet"):
            return [xp.interval(v) for v in self.centre]  # point intervals
        return list(self.centre)

    def _raw(self, x: list[Any], xp: Any) -> list[Any]:
        name = getattr(xp, "name", "")
        if name == "numpy":
            try:
                arrays = [np.asarray(v, dtype=np.float64) for v in x]
            except (TypeError, ValueError):
                return self._elementwise(x, xp)
            return self._numpy(arrays, xp)
        network = getattr(xp, "network", None)  # a proof namespace's own evaluation
        if network is not None:
            out = network(self, x)
            if out is not None:
                return out
        return self._elementwise(x, xp)

    def _numpy(self, x: list[np.ndarray], xp: Any) -> list[Any]:
        stacked = np.stack(np.broadcast_arrays(*x))
        shape = stacked.shape[1:]
        h = stacked.reshape(self.n_in, -1)
        for op in self.ops:
            if isinstance(op, Affine):
                h = op.W @ h + op.b[:, None]
            else:
                h = getattr(xp, op.name)(h, *op.args)
        return list(h.reshape((h.shape[0], *shape)))

    def _elementwise(self, x: list[Any], xp: Any) -> list[Any]:
        h = x
        for op in self.ops:
            if isinstance(op, Affine):
                out = []
                for i in range(op.W.shape[0]):
                    acc: Any = None
                    for j, w in enumerate(op.W[i].tolist()):
                        if w != 0.0:  # an exact zero weight contributes exactly nothing
                            term = h[j] if w == 1.0 else w * h[j]
                            acc = term if acc is None else acc + term
                    bias = float(op.b[i])
                    if acc is None:
                        acc = bias
                    elif bias != 0.0:
                        acc = acc + bias
                    out.append(acc)
                h = out
            else:
                fn = getattr(xp, op.name)
                h = [fn(v, *op.args) for v in h]
        return h
