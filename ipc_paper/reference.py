"""Reference values of the IPC study, recomputed by ``roa check`` (stored in results/reference.json).

Add a value with one line in :data:`REGISTRY`, then store it once with
``roa check --update --only KEY`` and commit ``results/reference.json``.
"""

from __future__ import annotations

from roa.studies import Entry

_L = "ipc_paper.estimates:khalil_value"
_K = "IPOPT multi-start min s s.t. V'/s >= 0, witness on V' = 0"
_S = "20000 sampled rays + cap refinement, bisection of the first V' >= 0"

#: key -> Entry. Add yours here (one line each); see the module docstring.
REGISTRY: dict[str, Entry] = {
    "ipc.khalil.ball.casadi": Entry(_L, 1e-6, _K, {"shape": "ball", "method": "casadi"}),
    "ipc.khalil.ball.sampled": Entry(_L, 1e-4, _S, {"shape": "ball", "method": "sampled"}),
    "ipc.khalil.level.casadi": Entry(_L, 1e-6, _K, {"shape": "level", "method": "casadi"}),
    "ipc.khalil.level.sampled": Entry(_L, 1e-4, _S, {"shape": "level", "method": "sampled"}),
    "ipc.bound.corrected.c_tilde": Entry(
        "ipc_paper.bound:corrected_bound",
        1e-12,
        "closed form alpha/(2 kappa)",
        item="c_tilde",
    ),
    "ipc.certify.paper.interval": Entry(
        "ipc_paper.certify_runs:certified_level", 1e-6, "0.999 x IPOPT optimum, interval-certified"
    ),
    "vanderpol.level.casadi": Entry(
        "ipc_paper.reference:vanderpol_level", 1e-6, _K, {"method": "casadi"}
    ),
}


def vanderpol_level(method: str = "casadi") -> float:
    """Largest V-level of the time-reversed Van der Pol benchmark (published 2.3045)."""
    from roa.lyapunov import QuadraticLyapunov
    from roa.search import level_search
    from roa.systems.vanderpol import P_BENCHMARK, vanderpol

    system = vanderpol()
    V = QuadraticLyapunov.for_system(system, P_BENCHMARK)
    res = level_search(system, V, shape="level", method=method)
    if res.level is None:
        raise RuntimeError(f"Van der Pol level search ended {res.status.value}: {res.message}")
    return float(res.level)
