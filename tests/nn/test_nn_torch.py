"""PyTorch ``nn.Sequential`` networks read by :meth:`roa.MLP.from_torch`.

The tests marked ``torch`` need PyTorch (the ``torch`` extra, not installed by the ``test``
extra: its wheel is about 0.5 GB); they are deselected by default and run with
``pytest -m torch``. The test without the mark runs everywhere.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from roa.errors import RoaInputError
from roa.model._backend import namespace
from roa.nn import MLP


def test_without_pytorch_the_importer_says_what_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "torch", None)  # import torch raises ImportError
    with pytest.raises(RoaInputError, match=r"pip install torch"):
        MLP.from_torch(object())


def _network(torch):
    torch.manual_seed(7)
    nn = torch.nn
    return nn.Sequential(
        nn.Linear(3, 8),
        nn.Tanh(),
        nn.Sequential(nn.Linear(8, 8), nn.LeakyReLU(0.05), nn.Dropout(0.1)),
        nn.Linear(8, 6),
        nn.Hardtanh(-0.4, 0.3),
        nn.Linear(6, 5, bias=False),
        nn.ReLU6(),
        nn.Linear(5, 4),
        nn.Softplus(),
        nn.Linear(4, 4),
        nn.Sigmoid(),
        nn.Linear(4, 2),
        nn.ReLU(),
        nn.Identity(),
    ).eval()


@pytest.mark.torch
def test_the_network_read_evaluates_as_pytorch_does_in_float64():
    """Every supported module: the MLP's numpy evaluation against PyTorch's own evaluation of
    the same weights in float64 (the Softplus inputs stay below PyTorch's threshold 20, where
    both are log(1 + exp(z)))."""
    torch = pytest.importorskip("torch")  # the mark deselects this test where torch is absent
    net = _network(torch)
    mlp = MLP.from_torch(net)
    rng = np.random.default_rng(3)
    X = rng.uniform(-3.0, 3.0, size=(500, 3))
    with torch.no_grad():
        ref = net.double()(torch.tensor(X, dtype=torch.float64)).numpy()
    got = np.array(mlp([X[:, i] for i in range(3)], namespace("numpy"))).T
    assert got.shape == ref.shape == (500, 2)
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-14)
    assert np.ptp(ref[:, 0]) > 0 or np.ptp(ref[:, 1]) > 0  # not a constant network


@pytest.mark.torch
def test_interval_evaluation_of_the_read_network_encloses_pytorch_outputs():
    torch = pytest.importorskip("torch")
    from roa.proof._interval import INTERVAL, Interval

    net = _network(torch).double()
    mlp = MLP.from_torch(net)
    lo, hi = np.array([-0.5, 0.1, -1.0]), np.array([0.5, 0.4, -0.2])
    out = mlp([Interval(np.array([a]), np.array([b])) for a, b in zip(lo, hi, strict=True)],
              INTERVAL)  # fmt: skip
    rng = np.random.default_rng(5)
    X = lo + (hi - lo) * rng.random((2000, 3))
    with torch.no_grad():
        ref = net(torch.tensor(X, dtype=torch.float64)).numpy()
    for k, iv in enumerate(out):
        iv = Interval.of(iv)
        assert np.all(iv.lo <= ref[:, k]) and np.all(ref[:, k] <= iv.hi)


@pytest.mark.torch
@pytest.mark.parametrize(
    "build, named",
    [
        (lambda nn: nn.Sequential(nn.Linear(2, 2), nn.GELU()), "GELU"),
        (lambda nn: nn.Sequential(nn.Linear(2, 2), nn.Softplus(beta=2.0)), "beta"),
        (lambda nn: nn.Linear(2, 2), "nn.Sequential"),
        (lambda nn: nn.Sequential(nn.Tanh()), "no Linear"),
        (lambda nn: nn.Sequential(nn.Linear(2, 2), nn.LeakyReLU(-0.1)), "slope"),
    ],
)
def test_unsupported_modules_are_refused_by_name(build, named):
    torch = pytest.importorskip("torch")
    with pytest.raises(RoaInputError, match=named):
        MLP.from_torch(build(torch.nn))


@pytest.mark.torch
def test_a_network_from_pytorch_certifies_the_same_closed_loop(tmp_path):
    """The committed tanh pendulum network copied into a PyTorch Sequential and read back: the
    same weights bit for bit, and the closed loop certified at 0.99 x the level search's
    optimum of the committed example and refuted at 1.01 x it."""
    torch = pytest.importorskip("torch")
    import importlib.util
    from pathlib import Path

    import roa

    where = Path(__file__).parents[2] / "examples" / "systems" / "pendulum_nn.py"
    spec = importlib.util.spec_from_file_location("pendulum_nn", where)
    pendulum_nn = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(pendulum_nn)

    ref = MLP.load(pendulum_nn.HERE / "pendulum_nn_tanh.npz")
    (W0, b0), (W1, b1) = ref.layers
    nn = torch.nn
    seq = nn.Sequential(nn.Linear(2, W0.shape[0]), nn.Tanh(), nn.Linear(W0.shape[0], 1)).double()
    with torch.no_grad():
        for layer, (W, b) in zip((seq[0], seq[2]), ((W0, b0), (W1, b1)), strict=True):
            layer.weight.copy_(torch.tensor(W))
            layer.bias.copy_(torch.tensor(b))
    net = MLP.from_torch(seq)
    for (a, b), (c, d) in zip(net.layers, ref.layers, strict=True):
        assert np.array_equal(a, c) and np.array_equal(b, d)
    net.save(tmp_path / "from_torch.npz")
    system = pendulum_nn.load("tanh", path=tmp_path / "from_torch.npz")
    c = roa.level_search(pendulum_nn.SYSTEM).level
    assert roa.certify(system, level=0.99 * c).certified
    assert roa.certify(system, level=1.01 * c).status == "refuted"
