"""The IPC paper's estimates: Khalil's search (3.15) for both shapes, the sector, the regions.

:func:`khalil` runs :func:`roa.level_search` for the two shapes (the paper's ball
``||q||^2 = xi' T'T xi`` and the level sets of ``V``); :func:`ipc_regions` returns the estimates as
:class:`roa.lyapunov.Region` objects in flat coordinates with ``coords = physical_to_flat_or_inf``,
so they can be drawn over physical basin maps.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from ipc_paper.system.lyapunov import (
    PAPER_C_STAR_SQ,
    Phi,
    flat_system,
    paper_lyapunov,
    shape_matrix,
    to_q,
)
from roa.errors import RoaInputError
from roa.lyapunov import Region, symmetric_extent
from roa.search import inner_level, level_search


@functools.lru_cache(maxsize=8)
def khalil(shape: str = "ball", method: str = "both") -> dict[str, Any]:
    """Khalil's search (3.15) for the IPC with shape ``ball`` (||q||^2) or ``level`` (V).

    Returns :meth:`roa.LevelSearchResult.to_dict`, plus the witness in q and physical
    coordinates and Phi(q) at the witness. Cached; do not mutate the result.
    """
    from ipc_paper.system import from_flat

    res = level_search(
        flat_system(), paper_lyapunov(), shape=shape_matrix(shape), method=method
    ).to_dict()
    res["shape"] = shape
    for per in res.get("per_method", {}).values():
        per["shape"] = shape
    if res["witness"] is not None:
        xi = np.asarray(res["witness"])
        res["witness_q"] = to_q(xi).tolist()
        res["witness_physical"] = from_flat(xi).tolist()
        res["Phi_witness"] = float(Phi(to_q(xi)))
    return res


def sector_theta(region: Region, *, t_max: float = np.pi / 2 - 1e-9) -> float:
    """Largest theta in (0, pi/2) with (0, 0, th, 0) in ``region`` for all 0 <= th <= theta (rad).

    Scans a fine grid then bisects the first exit; the same for -theta by the symmetry of the sets
    (checked: the returned value is the minimum of both signs).
    """

    def inside_at(th: np.ndarray) -> np.ndarray:
        X = np.zeros((th.size, 4))
        X[:, 2] = th
        return region.contains(X)

    return symmetric_extent(inside_at, t_max, n_grid=4001, n_bisect=60)


@functools.lru_cache(maxsize=1)
def _regions() -> tuple[Region, ...]:
    from ipc_paper.bound import corrected_bound, paper_bound
    from ipc_paper.system import physical_to_flat_or_inf as coords

    ball = khalil("ball")
    level = khalil("level")
    S_ball, S_level = shape_matrix("ball"), shape_matrix("level")
    c_ball, c_level = float(ball["value"]), float(level["value"])
    paper, corr = paper_bound(), corrected_bound()
    # the hand proof is not taken on trust: the level is validated with interval arithmetic
    from roa.proof import validate_level

    verdict = validate_level(flat_system(), paper_lyapunov(), corr["V_level_in_slab"])
    return (
        paper_ball(),
        Region(
            "paper (3.16) literal: ||Tx||^2 <= c* = 2.211",
            S_ball,
            float(np.sqrt(PAPER_C_STAR_SQ)),
            "claimed",
            coords,
            {
                "source": "paper (3.16) as printed",
                "invariant": False,
                "label": "paper's (3.16) as printed: ||T x||^2 <= 2.211",
            },
        ),
        Region(
            f"ours: ||Tx||^2 <= c*^2 = {c_ball:.4f} (Phi <= 0)",
            S_ball,
            c_ball,
            "sampled",
            coords,
            {
                "source": "Khalil search, ball shape",
                "invariant": False,
                "note": "V' < 0 on this ball, but a ball is not invariant: not an ROA estimate",
                "label": f"our sampled largest ball with V' <= 0: ||T x||^2 <= {c_ball:.3f}",
            },
        ),
        Region(
            f"ours: V <= {c_level:.4f} (V' < 0 on it)",
            S_level,
            c_level,
            "sampled",
            coords,
            {
                "source": "Khalil search, V-level shape",
                "invariant": True,
                "label": f"our sampled level set of the paper's V: V <= {c_level:.4f}",
            },
        ),
        Region(
            f"ours: ball inside V <= {c_level:.4f}: ||Tx||^2 <= "
            f"{inner_level(S_level, c_level, S_ball):.4f}",
            S_ball,
            inner_level(S_level, c_level, S_ball),
            "sampled",
            coords,
            {
                "source": "largest ball inside the sound V-level set",
                "invariant": False,
                "label": "our sampled ball inside that level set: ||T x||^2 <= "
                f"{inner_level(S_level, c_level, S_ball):.3f}",
            },
        ),
        Region(
            "paper bound (3.14): ||Tx||^2 <= 2.25",
            S_ball,
            paper["c_tilde"],
            "claimed",
            coords,
            {
                "source": "paper c~ = 2.25",
                "invariant": False,
                "label": "paper's bound (3.14): ||T x||^2 <= 2.25",
            },
        ),
        Region(
            f"corrected bound: V < {corr['V_level_in_slab']:.5f}",
            S_level,
            corr["V_level_in_slab"],
            verdict.status,
            coords,
            {
                "source": "corrected analytic bound (3.14), proof by hand, re-checked by interval "
                f"validation: {verdict.message}",
                "invariant": True,
                "label": f"corrected bound (3.14), by hand: V <= {corr['V_level_in_slab']:.4f}",
            },
        ),
        Region(
            f"corrected bound: ||Tx||^2 < {corr['ball_in_V_level']:.5f}",
            S_ball,
            corr["ball_in_V_level"],
            verdict.status,
            coords,
            {
                "source": "ball inside the corrected-bound V-level set (lambda_max(P_q) bound)",
                "invariant": False,
                "label": f"ball inside the corrected bound: ||T x||^2 <= {corr['ball_in_V_level']:.4f}",
            },
        ),
    )


def paper_ball() -> Region:
    """The paper's estimate (3.15)-(3.16), ``||T xi||^2 <= 4.89`` in flat coordinates (claimed)."""
    from ipc_paper.system import physical_to_flat_or_inf

    return Region(
        "paper (3.15): ||Tx||^2 <= 4.89",
        shape_matrix("ball"),
        PAPER_C_STAR_SQ,
        "claimed",
        physical_to_flat_or_inf,
        {
            "source": "paper c*^2 = 4.89",
            "invariant": False,
            "label": "paper's ball ||T x||^2 <= 4.89",
        },
    )


def ipc_regions() -> list[Region]:
    """The IPC's estimates as :class:`roa.lyapunov.Region` objects (flat coordinates, physical coords).

    Names say what each is; ``meta["invariant"]`` tells whether the set is a sublevel set of V
    (forward invariant, hence an ROA estimate) or a ball. Values are computed once and cached.
    """
    return list(_regions())


def khalil_value(shape: str = "ball", method: str = "casadi") -> float:
    """c* of :func:`khalil` for one shape and one method (``sampled`` or ``casadi``)."""
    if method not in ("sampled", "casadi"):
        raise RoaInputError(f"method {method!r}: allowed sampled, casadi")
    return float(khalil(shape, "both")["per_method"][method]["value"])
