"""How much of the basin is certified: the share of converged initial conditions inside each region.

For a basin run over ``n`` initial conditions, of which ``m`` converged, and a region ``R`` (a
certified set ``{V <= level}``: a ``--lyapunov-level`` validated by :func:`roa.certify`, or the
run's certified terminal set), ``k`` of the converged ones lie in ``R``. The share is ``k / m``.

**What it estimates.** On a :func:`~roa.montecarlo.box_sample` (seeded uniform samples
of an n-dimensional box), the ``m`` converged samples are, given ``m``, independent uniform draws
from the sampled basin's part of the box, so ``k`` is binomial(``m``, ``s``) with ``s`` the share of
that part's volume inside ``R``: the Clopper-Pearson interval below covers ``s`` with probability at
least 95 % (exact; conservative). On a :func:`~roa.montecarlo.grid_slice` the points are
a deterministic grid: ``k / m`` is the share of the slice's converged grid points (an area share
up to the grid's resolution), and the same interval treats the grid as a sample, an approximation
that says how much the count could move on another grid of that size, not a probability.

**Clopper-Pearson, derived.** For ``k`` successes in ``m`` trials the exact two-sided interval at
level ``1 - alpha`` has lower end the ``p`` with ``P(X >= k | p) = alpha / 2`` and upper end the
``p`` with ``P(X <= k | p) = alpha / 2``. Since ``P(X >= k | p) = I_p(k, m - k + 1)`` (the
regularised incomplete beta function: the k-th order statistic of ``m`` uniforms is
Beta(k, m - k + 1)), the ends are the beta quantiles ``lo = I^-1_{alpha/2}(k, m - k + 1)`` and
``hi = I^-1_{1 - alpha/2}(k + 1, m - k)``, with ``lo = 0`` for ``k = 0`` and ``hi = 1`` for
``k = m``; ``m = 0`` gives ``[0, 1]`` and no share.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from roa.integration import _integrator as I  # noqa: N812

#: Confidence of the intervals.
CONFIDENCE = 0.95
CI_METHOD = "Clopper-Pearson (exact binomial), 95 %"
#: Initial conditions tested for membership at a time.
CHUNK = 200_000


def clopper_pearson(k: int, m: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The exact two-sided interval of a binomial proportion ``k / m`` (module doc)."""
    from scipy.special import betaincinv

    k, m = int(k), int(m)
    if m <= 0:
        return (0.0, 1.0)
    if not 0 <= k <= m:
        raise ValueError(f"need 0 <= k <= m, got k = {k}, m = {m}")
    alpha = 1.0 - confidence
    lo = 0.0 if k == 0 else float(betaincinv(k, m - k + 1, alpha / 2))
    hi = 1.0 if k == m else float(betaincinv(k + 1, m - k, 1 - alpha / 2))
    return (lo, hi)


def over_of(sampler: Any) -> str:
    """What the share is measured over: ``slice`` (a grid slice), ``box`` (uniform samples of an
    n-dimensional box) or ``samples`` (any other sampler)."""
    from roa.montecarlo._sampling import BoxSample, GridSlice

    if isinstance(sampler, GridSlice):
        return "slice"
    if isinstance(sampler, BoxSample):
        return "box"
    return "samples"


def _members(region: Any, system: Any, X: np.ndarray) -> np.ndarray:
    """Rows of ``X`` (simulated coordinates) inside ``region``: a :class:`roa.lyapunov.Region` or a
    :class:`roa.integration.TerminalSet` (bound to ``system``, with its margin)."""
    from roa.integration._terminal import TerminalSet

    if isinstance(region, TerminalSet):
        return region.bind(system).inside(X)
    return np.asarray(region.contains(X), dtype=bool)


def certified_share(region: Any, system: Any, sampler: Any, code: np.ndarray) -> dict[str, Any]:
    """The share of the converged initial conditions of ``sampler`` (statuses ``code``) inside
    ``region``, with its Clopper-Pearson interval (module doc)."""
    from roa.integration._terminal import TerminalSet

    code = np.asarray(code)
    converged = code == I.CONVERGED
    m = int(converged.sum())
    k = 0
    for start in range(0, sampler.n, CHUNK):
        stop = min(start + CHUNK, sampler.n)
        conv = converged[start:stop]
        if not conv.any():
            continue
        X = np.asarray(sampler.points(start, stop), dtype=float)[conv]
        k += int(_members(region, system, X).sum())
    if isinstance(region, TerminalSet):
        name, level, status = f"terminal set {region.name}", float(region.level), "certified"
    else:
        name, level, status = region.name, float(region.level), region.status
    return {
        "region": name,
        "level": level,
        "status": status,
        "over": over_of(sampler),
        "converged": m,
        "converged_in_region": k,
        "share": k / m if m else None,
        "ci95": list(clopper_pearson(k, m)),
        "ci_method": CI_METHOD,
    }


def certified_shares(
    regions: Sequence[Any], terminal: Any, system: Any, sampler: Any, code: np.ndarray
) -> tuple[dict[str, Any], ...]:
    """:func:`certified_share` of each region (a ``--lyapunov-level``'s, whatever its verdict,
    which the entry's ``status`` says) and of the terminal set, in that order."""
    items = list(regions) + ([terminal] if terminal is not None else [])
    return tuple(certified_share(r, system, sampler, code) for r in items)


def share_line(entry: dict[str, Any]) -> str:
    """One line of text for an entry of :func:`certified_shares`."""
    from roa.shares import interval, percent

    where = {"slice": "of the slice", "box": "of the box (uniform samples)"}.get(
        entry["over"], "of the samples"
    )
    lo, hi = entry["ci95"]
    if entry["share"] is None:
        return f"{entry['region']} [{entry['status']}]: no converged point {where}"
    return (
        f"{entry['region']} [{entry['status']}]: holds {percent(entry['share'])} of the "
        f"converged points {where} ({entry['converged_in_region']} of {entry['converged']}; "
        f"95 % CI {interval(lo, hi, 2, scale=100, unit=' %')}, Clopper-Pearson)"
    )
