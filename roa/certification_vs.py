"""``roa.certify(..., degree=2|4|6|8)``: search a polynomial V by SOS V-s iteration, then prove it.

The search (:func:`roa.proof.vs_search.vs_search`, seeded by the quadratic candidate) proposes one
V per round; they are tried best shape level first: each gets the sampled level search and the
interval validation of :func:`roa.certify` (with ``check_above`` if asked), and the first certified
one is returned with the search's record (``Certificate.vs``). The SDPs prove nothing: only the
interval validation certifies.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import QuadraticLyapunov, as_lyapunov
from roa.options import IntervalOptions, SampledOptions, VsOptions
from roa.progress import step
from roa.status import Verdict
from roa.system import System

DEGREES = (2, 4, 6, 8)


def certify_degree(
    system: System,
    V: Any,
    *,
    degree: int,
    vs: VsOptions | None,
    interval: IntervalOptions | None,
    sampled: SampledOptions | None,
    check_above: float | None,
) -> Any:
    from roa.certification import Certificate, certify
    from roa.proof.vs_search import vs_search

    t0 = time.perf_counter()
    if degree not in DEGREES:
        raise RoaInputError(f"degree must be one of {DEGREES}, got {degree!r}")
    seed = as_lyapunov(system, V)
    if not isinstance(seed, QuadraticLyapunov):
        raise RoaInputError(
            f"degree={degree} searches V from a quadratic seed; V {seed.name!r} is "
            f"{type(seed).__name__}: give a matrix P or a QuadraticLyapunov (or none)"
        )
    vs = VsOptions() if vs is None else vs
    with step(f"SOS V-s iteration, degree {degree}"):
        res = vs_search(
            system,
            seed,
            degree=degree,
            shape=None if vs.shape is None else np.asarray(vs.shape),
            rounds=vs.rounds,
            multiplier_degree=vs.multiplier_degree,
            symmetry=vs.symmetry,
            aux_degree=vs.aux_degree,
            recast_mode=vs.recast,
            tol=vs.tol,
            solver_options=vs.solver_options(),
            solver=vs.solver,
        )
    if not res.candidates:
        return Certificate(status=Verdict.INCONCLUSIVE, level=None, method="sos", level_source=None,
                           seconds=time.perf_counter() - t0,
                           message=f"V-s iteration found no candidate: {res.message}", vs=res,
                           system=system, V=seed)  # fmt: skip
    order = np.argsort(res.betas)[::-1]
    last, tried = None, 0
    for i in order:  # best shape level first; a candidate without a sampled level costs no proof
        cand = res.candidates[int(i)]
        with step(f"validation of {cand.name}"):
            cert = certify(system, cand, method="interval", interval=interval, sampled=sampled,
                           check_above=check_above)  # fmt: skip
        if cert.validation is None and last is not None:
            continue
        last = dataclasses.replace(cert, vs=res, seconds=time.perf_counter() - t0)
        tried += cert.validation is not None
        if cert.certified or tried >= vs.validate:
            return last
    assert last is not None
    return last
