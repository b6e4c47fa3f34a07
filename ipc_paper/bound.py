"""The analytic bound (3.13)-(3.14) of the seed paper, as printed and corrected, step by step.

With ``kappa = max |phi0| = 2 / 3^(3/2)`` (at w^2 = 1/2) and Young's inequality with ``alpha > 0``,
(3.13) ``|(3 q1 + q2) beta| <= (2 kappa / alpha) q4^4 + (3 alpha kappa / 2) q1^2 + (alpha kappa / 2) q2^2``
is correct. With ``-q'Mq <= -lambda_min(M) q'q = -q'q/2`` (printed with the wrong sign) and
``-q3^2/2 + q3 q4 - q4^2/2 = -(q3 - q4)^2/2``, (3.12) gives the corrected (3.14)::

    V' <= -(1 - 3 alpha kappa) q1^2/2 - (1 - alpha kappa) q2^2/2 - (q3 - q4)^2/2
          - q4^2 (1 - (2 kappa / alpha) q4^2)

(the paper prints ``1 - 3 alpha kappa/2`` and ``1 - alpha kappa/2``). The q1 factor needs
``alpha <= 1/(3 kappa) = sqrt(3)/2`` (paper: ``2/(3 kappa) = sqrt(3)``), the last term
``q4^2 < alpha / (2 kappa)``: ``c~ = 9/8`` (paper: ``9/4 = 2.25``). With ``alpha = sqrt(3)/2``,
V' < 0 on the open slab ``{q4^2 < 9/8}`` minus the origin (for q4 = 0, beta = 0 and
V' = -q'Mq < 0). A slab is not invariant: the bound certifies the largest V-sublevel set inside
it, ``V < c~ / (e4' P_q^-1 e4) = 3 c~ / 4``, and the balls inside that, ``||q||^2 < c~ / 2``.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from ipc_paper.system.lyapunov import P_Q, M, Phi
from ipc_paper.system.model import phi0

KAPPA = 2 / 3**1.5


def kappa_numeric() -> dict[str, float]:
    """max |phi0(w)| on a fine grid, refined: an independent check of kappa = 2/3^(3/2)."""
    from scipy.optimize import minimize_scalar

    res = minimize_scalar(
        lambda w: -phi0(w), bounds=(0.0, 5.0), method="bounded", options={"xatol": 1e-12}
    )
    return {
        "kappa": float(-res.fun),
        "w_at_max": float(res.x),
        "closed_form": KAPPA,
        "w_closed_form": float(np.sqrt(0.5)),
    }


def _implied_sets(c_tilde: float) -> dict[str, float]:
    """The sets the slab argument would give: largest V-level inside it, largest ball inside that."""
    e4 = np.array([0.0, 0, 0, 1])
    v_level = c_tilde / float(e4 @ np.linalg.solve(P_Q, e4))  # min V on q4^2 = c~
    ball = v_level / float(np.linalg.eigvalsh(P_Q)[-1])  # largest ball inside {V < v_level}
    return {"V_level_in_slab": v_level, "ball_in_V_level": ball, "slab": c_tilde}


def analytic_bound(*, printed: bool) -> dict[str, Any]:
    """The steps of (3.13)-(3.14), with the printed factors or the corrected ones.

    Printed: (1 - 3 alpha kappa/2), (1 - alpha kappa/2), so alpha <= 2/(3 kappa) = sqrt(3) and
    c~ = alpha/(2 kappa) = 9/4. Corrected: (1 - 3 alpha kappa), (1 - alpha kappa), so
    alpha <= 1/(3 kappa) = sqrt(3)/2 and c~ = 9/8 (open slab).
    """
    alpha = (2 if printed else 1) / (3 * KAPPA)
    c_tilde = alpha / (2 * KAPPA)
    steps: dict[str, Any] = {
        "kappa": KAPPA,
        "lambda_min_M": float(np.linalg.eigvalsh(M)[0]),
        "alpha_max": alpha,
        "c_tilde": c_tilde,
        "argument_valid": not printed,
    }
    if printed:
        steps |= {
            "q1_factor": "1 - 3 alpha kappa / 2 (printed)",
            "alpha_max_expr": "2 / (3 kappa) = sqrt(3)",
            "c_tilde_expr": "alpha / (2 kappa) = 9/4",
            "paper_printed_c_tilde": 2.25,
            "claimed_set": "||q(0)||^2 <= c~ (a ball; the paper's conclusion)",
            "status": "claimed: the printed (3.14) does not hold (erratum E6), so these sets are not proved",
        }
    else:
        steps |= {
            "q1_factor": "1 - 3 alpha kappa",
            "alpha_max_expr": "1 / (3 kappa) = sqrt(3)/2",
            "c_tilde_expr": "alpha / (2 kappa) = 9/8 (open slab q4^2 < 9/8)",
            "strict": "V' < 0 on {0 < ||q||, q4^2 < 9/8}; not on the closed slab in general",
            "status": "proved by hand; the V-level is re-checked by interval validation in ipc_regions()",
        }
    return steps | _implied_sets(c_tilde)


def paper_bound() -> dict[str, Any]:
    """The paper's steps with its printed factors (see :func:`analytic_bound`)."""
    return analytic_bound(printed=True)


def corrected_bound() -> dict[str, Any]:
    """The corrected steps (see :func:`analytic_bound`)."""
    return analytic_bound(printed=False)


def rhs_314(q: np.ndarray, alpha: float, *, printed: bool) -> np.ndarray:
    """Right-hand side of (3.14), printed (``printed=True``) or corrected, on arrays ``(..., 4)``."""
    q = np.asarray(q, dtype=float)
    k = KAPPA
    f1, f2 = (
        (1 - 1.5 * alpha * k, 1 - 0.5 * alpha * k)
        if printed
        else (1 - 3 * alpha * k, 1 - alpha * k)
    )
    q1, q2, q3, q4 = (q[..., i] for i in range(4))
    return (
        -f1 * q1**2 / 2 - f2 * q2**2 / 2 - (q3 - q4) ** 2 / 2 - q4**2 * (1 - 2 * k / alpha * q4**2)
    )


@functools.lru_cache(maxsize=1)
def check_against_phi(n: int = 200000, seed: int = 0) -> dict[str, Any]:
    """Test both versions of (3.14) against the exact Phi of (3.12) on random points of ||q||^2 <= 2.25.

    Returns the largest violation ``Phi - rhs`` of each (corrected must be <= 0 up to rounding;
    the printed one is violated) with the worst point, and the largest Phi on the open slab
    ``q4^2 < 9/8`` (must be < 0).
    """
    rng = np.random.default_rng(seed)
    U = rng.standard_normal((n, 4))
    U /= np.linalg.norm(U, axis=1, keepdims=True)
    Q = (
        U * 1.5 * rng.uniform(0.0, 1.0, (n, 1)) ** 0.25
    )  # uniform in the paper's ball ||q||^2 <= 2.25
    out: dict[str, Any] = {"n_points": n, "seed": seed}
    for name, alpha, printed in (
        ("paper", 2 / (3 * KAPPA), True),
        ("corrected", 1 / (3 * KAPPA), False),
    ):
        gap = Phi(Q) - rhs_314(Q, alpha, printed=printed)
        i = int(np.argmax(gap))
        out[name] = {
            "max_Phi_minus_rhs": float(gap[i]),
            "worst_q": Q[i].tolist(),
            "holds": bool(gap[i] <= 1e-12 * max(1.0, float(np.abs(Phi(Q[i]))))),
        }
    slab = Q[Q[:, 3] ** 2 < 9 / 8]
    ph = Phi(slab)
    j = int(np.argmax(ph / np.einsum("ij,ij->i", slab, slab)))
    out["max_Phi_over_qq_on_slab"] = float(ph[j] / (slab[j] @ slab[j]))
    out["slab_worst_q"] = slab[j].tolist()
    return out
