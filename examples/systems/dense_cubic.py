"""A dense coupled cubic system: every state coupled to every other, linearly and cubically.

    x' = (-I + S) x + (x'Bx) x + (x'Cx) T x,        V = |x|^2,

with ``S``, ``T`` skew-symmetric, ``B`` symmetric positive definite and ``C`` symmetric, all dense
(seeded, entries on a dyadic grid so that they are exact in binary). The skew parts do not
change ``V``: ``x'Sx = x'Tx = 0``, so ``V' = -2 |x|^2 + 2 (x'Bx) |x|^2``, which vanishes at
``x != 0`` exactly where ``x'Bx = 1``: the largest level is ``1 / lambda_max(B)`` (the closed form
the benchmark checks against a multistart SLSQP). ``V'`` has every monomial ``x_i x_j x_k^2``:
the variables' interaction graph is complete (no decoupled blocks, no chordal sparsity), and the
dense SOS program has one Gram block over the 230 monomials of degree 1 and 2 (231 with the
constant) at 20 states. ``V'`` is even: ``x -> -x`` splits it into 20 odd and 210 even monomials.
"""

import numpy as np

from roa import System


def matrices(n: int, seed: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(S, B, C, T)`` of the ``n``-state system (dyadic entries; B positive definite)."""
    rng = np.random.default_rng(seed)

    def grid(M: np.ndarray, step: float) -> np.ndarray:
        return np.round(M / step) * step

    H = rng.standard_normal((n, n))
    S = grid((H - H.T) / (2 * np.sqrt(n)), 2.0**-8)
    G = rng.standard_normal((n, n))
    B0 = G @ G.T + n * np.eye(n) / 2
    B = grid(0.8 * B0 / np.linalg.eigvalsh(B0)[-1], 2.0**-12)  # lambda_max(B) about 0.8
    K = rng.standard_normal((n, n))
    C = grid((K + K.T) / (4 * n), 2.0**-10)
    L = rng.standard_normal((n, n))
    T = grid((L - L.T) / (4 * np.sqrt(n)), 2.0**-8)
    return S, B, C, T


def dense_cubic(n: int, seed: int = 3) -> System:
    """The ``n``-state system of the module docstring."""
    S, B, C, T = (M.tolist() for M in matrices(n, seed))

    def field(t, x, xp):
        def quad(M):
            return sum(M[i][j] * x[i] * x[j] for i in range(n) for j in range(n) if M[i][j])

        b, c = quad(B), quad(C)
        lin = [sum(S[i][j] * x[j] for j in range(n) if S[i][j]) for i in range(n)]
        rot = [sum(T[i][j] * x[j] for j in range(n) if T[i][j]) for i in range(n)]
        return tuple(-x[i] + lin[i] + b * x[i] + c * rot[i] for i in range(n))

    eye = [[float(i == j) for j in range(n)] for i in range(n)]
    return System(name=f"dense-cubic-{n}", field=field, equilibrium=(0.0,) * n,
                  state_names=tuple(f"x{i + 1}" for i in range(n)),
                  state_units=("1",) * n, lyapunov=eye)  # fmt: skip


def optimum(n: int, seed: int = 3) -> float:
    """The largest level of ``V = |x|^2``: ``1 / lambda_max(B)`` (module docstring)."""
    return float(1.0 / np.linalg.eigvalsh(matrices(n, seed)[1])[-1])


SYSTEM = dense_cubic(6)
SYSTEM_20 = dense_cubic(20)
