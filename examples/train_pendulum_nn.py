"""Train the neural-network controllers of ``examples/systems/pendulum_nn.py`` (numpy and scipy only).

Plant: the damped pendulum ``theta'' = -sin(theta) - 0.1 theta' + u`` (state ``x = (theta,
omega)``). Target: the LQR law ``u = -K x`` of its linearisation at the origin (``Q = I``,
``R = 1``, ``scipy.linalg.solve_continuous_are``). Networks 2-16-1 (tanh and ReLU hidden layer,
linear output), trained by least squares imitation of ``-K x`` on a 41 x 41 grid of
``[-2.5, 2.5]^2``:

1. the hidden layer is drawn at random (seeded): weights ``N(0, 0.6^2)``, biases uniform in
   ``[-1, 1]`` (no bias is 0: no ReLU unit sits at its kink at the origin);
2. the output layer ``(W2, b2)`` solves the ridge-regularised linear least squares problem
   ``min |H W2' + b2 - u_LQR|^2 + 1e-6 |W2|^2`` over the hidden features ``H``;
3. tanh only: a few damped Gauss-Newton steps on all weights (numpy's ``lstsq`` on the Jacobian
   of the residuals) refine the fit. (For ReLU they drive the fit to an exact linear function by
   shrinking units to ~1e-16 with kinks near the origin: a degenerate network, so the ReLU
   controller keeps its random hidden layer.)

The closed loop uses the network centred at the origin (``u = net(x) - net(0)``,
:meth:`roa.nn.MLP.centred`), so the equilibrium is exact whatever the biases are.

    python examples/train_pendulum_nn.py    # writes examples/systems/pendulum_nn_{tanh,relu}.npz
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.linalg import solve_continuous_are

HERE = Path(__file__).resolve().parent / "systems"
HIDDEN = 16
DAMPING = 0.1


def lqr_gain() -> np.ndarray:
    A = np.array([[0.0, 1.0], [-1.0, -DAMPING]])
    B = np.array([[0.0], [1.0]])
    P = solve_continuous_are(A, B, np.eye(2), np.eye(1))
    return (B.T @ P).ravel()  # u = -K x


def _act(name: str, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Activation and its derivative."""
    if name == "tanh":
        t = np.tanh(z)
        return t, 1.0 - t * t
    return np.maximum(z, 0.0), (z > 0).astype(float)


def train(activation: str, seed: int = 36, steps: int = 8) -> dict[str, np.ndarray]:
    """The weights (W0, b0, W1, b1) of a 2-16-1 network imitating the LQR law (module doc)."""
    rng = np.random.default_rng(seed)
    g = np.linspace(-2.5, 2.5, 41)
    X = np.array(np.meshgrid(g, g)).reshape(2, -1).T  # (N, 2)
    target = -X @ lqr_gain()
    W0 = rng.normal(0.0, 0.6, (HIDDEN, 2))
    b0 = rng.uniform(-1.0, 1.0, HIDDEN)
    H, _ = _act(activation, X @ W0.T + b0)
    F = np.hstack([H, np.ones((len(X), 1))])
    sol = np.linalg.solve(F.T @ F + 1e-6 * np.eye(HIDDEN + 1), F.T @ target)
    W1, b1 = sol[:HIDDEN], sol[HIDDEN]
    for _ in range(steps):  # Gauss-Newton on all weights, damped
        Z = X @ W0.T + b0
        H, dH = _act(activation, Z)
        r = H @ W1 + b1 - target
        J0 = ((dH * W1)[:, :, None] * X[:, None, :]).reshape(len(X), -1)  # d r / d W0
        Jb0 = dH * W1  # d r / d b0
        J = np.hstack([J0, Jb0, H, np.ones((len(X), 1))])
        step = np.linalg.lstsq(np.vstack([J, 1e-3 * np.eye(J.shape[1])]),
                               np.concatenate([-r, np.zeros(J.shape[1])]), rcond=None)[0]  # fmt: skip
        k = 2 * HIDDEN
        W0 = W0 + step[:k].reshape(HIDDEN, 2)
        b0 = b0 + step[k : k + HIDDEN]
        W1 = W1 + step[k + HIDDEN : k + 2 * HIDDEN]
        b1 = b1 + step[-1]
    Z = X @ W0.T + b0
    rms = float(np.sqrt(np.mean((_act(activation, Z)[0] @ W1 + b1 - target) ** 2)))
    print(f"{activation}: rms imitation error {rms:.3g} on [-2.5, 2.5]^2 "
          f"(|u_LQR| up to {np.abs(target).max():.3g})")  # fmt: skip
    return {"W0": W0, "b0": b0, "W1": W1[None, :], "b1": np.array([b1])}


def main(argv: list[str] | None = None) -> int:
    from roa.nn import MLP

    for name in ("tanh", "relu"):
        w = train(name, steps=8 if name == "tanh" else 0)
        net = MLP([(w["W0"], w["b0"]), (w["W1"], w["b1"])], [name, None])
        path = HERE / f"pendulum_nn_{name}.npz"
        net.save(path)
        print(f"wrote {path} ({net})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
