"""Train the neural-network controllers of ``examples/systems/quadrotor_nn.py`` (numpy and scipy only).

Plant: the planar quadrotor of ``examples/systems/quadrotor2d.py`` (states ``(x, y, theta, x',
y', theta')``, inputs ``u1`` thrust beyond hover and ``u2`` torque). Target: the LQR law
``u = -K x`` of its linearisation at hover (``Q = I``, ``R = I``,
``scipy.linalg.solve_continuous_are``). Networks 6-16-16-2 (tanh or ReLU hidden layers, linear
output), trained by full-batch Adam on the mean squared imitation error over 4096 states drawn
uniformly from ``[-1, 1]^6`` (seeded), from a seeded initialisation. After each step the hidden biases are projected so that every
unit's pre-activation at the origin is at least 0.1 away from 0: no ReLU unit sits at its kink
there, so the closed loop is affine on a neighbourhood of the equilibrium (the local proof
needs it). The training is deterministic, so the committed weights are reproduced.

The closed loop uses the network centred at the origin (``u = net(x) - net(0)``,
:meth:`roa.nn.MLP.centred`), so hover is an exact equilibrium whatever the biases are.

    python examples/train_quadrotor_nn.py    # writes examples/systems/quadrotor_nn_{tanh,relu}.npz
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.linalg import solve_continuous_are

HERE = Path(__file__).resolve().parent / "systems"
G = 9.81
HIDDEN = (16, 16)


def lqr_gain() -> np.ndarray:
    """``K`` (2 x 6) of the LQR law ``u = -K x`` of the linearisation at hover."""
    A = np.zeros((6, 6))
    A[0, 3] = A[1, 4] = A[2, 5] = 1.0
    A[3, 2] = G  # x'' = g sin(theta) + u1 sin(theta) ~ g theta
    B = np.zeros((6, 2))
    B[4, 0] = 1.0  # y'' ~ u1
    B[5, 1] = 1.0  # theta'' = u2
    P = solve_continuous_are(A, B, np.eye(6), np.eye(2))
    return B.T @ P


def _act(name: str, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if name == "tanh":
        t = np.tanh(z)
        return t, 1.0 - t * t
    return np.maximum(z, 0.0), (z > 0).astype(float)


def _forward(params: list[np.ndarray], activation: str, X: np.ndarray):
    W0, b0, W1, b1, W2, b2 = params
    Z0 = X @ W0.T + b0
    H0, D0 = _act(activation, Z0)
    Z1 = H0 @ W1.T + b1
    H1, D1 = _act(activation, Z1)
    return H1 @ W2.T + b2, (H0, D0, H1, D1)


#: Smallest |pre-activation| of a hidden unit at the origin (the training keeps it so).
KINK_MARGIN = 0.1


def _keep_off_kinks(params: list[np.ndarray], activation: str) -> None:
    """Move the hidden biases so that every unit's pre-activation at the origin is at least
    :data:`KINK_MARGIN` away from 0 (a projection after each step; keeps its sign)."""
    W0, b0, W1, b1 = params[:4]
    small = np.abs(b0) < KINK_MARGIN
    b0[small] = np.where(b0[small] < 0, -KINK_MARGIN, KINK_MARGIN)
    pre1 = W1 @ _act(activation, b0)[0] + b1
    small = np.abs(pre1) < KINK_MARGIN
    b1[small] += np.where(pre1[small] < 0, -KINK_MARGIN, KINK_MARGIN) - pre1[small]


def train(activation: str, seed: int = 36, steps: int = 3000) -> dict[str, np.ndarray]:
    """The weights of a 6-16-16-2 network imitating the LQR law (module doc)."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1.0, 1.0, (4096, 6))
    target = -X @ lqr_gain().T
    h0, h1 = HIDDEN
    params = [rng.normal(0.0, 1.0 / np.sqrt(6), (h0, 6)),
              rng.choice([-1.0, 1.0], h0) * rng.uniform(0.2, 0.6, h0),
              rng.normal(0.0, 1.0 / np.sqrt(h0), (h1, h0)),
              rng.choice([-1.0, 1.0], h1) * rng.uniform(0.2, 0.6, h1),
              rng.normal(0.0, 1.0 / np.sqrt(h1), (2, h1)), np.zeros(2)]  # fmt: skip
    m = [np.zeros_like(p) for p in params]
    v = [np.zeros_like(p) for p in params]
    lr, beta1, beta2 = 3e-3, 0.9, 0.999
    for t in range(1, steps + 1):
        out, (H0, D0, H1, D1) = _forward(params, activation, X)
        R = 2.0 * (out - target) / len(X)  # d loss / d out
        W0, b0, W1, b1, W2, b2 = params
        gW2, gb2 = R.T @ H1, R.sum(0)
        S1 = (R @ W2) * D1
        gW1, gb1 = S1.T @ H0, S1.sum(0)
        S0 = (S1 @ W1) * D0
        gW0, gb0 = S0.T @ X, S0.sum(0)
        grads = [gW0, gb0, gW1, gb1, gW2, gb2]
        for k, g in enumerate(grads):
            m[k] = beta1 * m[k] + (1 - beta1) * g
            v[k] = beta2 * v[k] + (1 - beta2) * g * g
            step = lr * (m[k] / (1 - beta1**t)) / (np.sqrt(v[k] / (1 - beta2**t)) + 1e-8)
            params[k] = params[k] - step
        _keep_off_kinks(params, activation)
    out, _ = _forward(params, activation, X)
    rms = float(np.sqrt(np.mean((out - target) ** 2)))
    W0, b0, W1, b1, W2, b2 = params
    pre0 = b0
    pre1 = W1 @ _act(activation, b0)[0] + b1
    kink = float(min(np.min(np.abs(pre0)), np.min(np.abs(pre1))))
    print(f"{activation}: rms imitation error {rms:.3g} on [-1, 1]^6; "
          f"min |pre-activation at 0| {kink:.3g}")  # fmt: skip
    assert kink >= KINK_MARGIN * (1 - 1e-9)
    return {"W0": W0, "b0": b0, "W1": W1, "b1": b1, "W2": W2, "b2": b2}


def main(argv: list[str] | None = None) -> int:
    import json

    for activation in ("tanh", "relu"):
        w = train(activation)
        acts = json.dumps([activation, activation, None])
        np.savez(HERE / f"quadrotor_nn_{activation}.npz", activations=np.array(acts), **w)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
