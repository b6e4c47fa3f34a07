"""``roa.certify(..., degree=2|4|6|8)``: search a polynomial V by SOS V-s iteration (or by sampled
cutting planes, ``VsOptions(method="sampled")``, :func:`certify_sampled`), then prove it.

The search (:func:`roa.search.vs_iteration.vs_search`, seeded by the quadratic candidate) proposes one
V per round; they are tried best shape level first: each gets the sampled level search and the
interval validation of :func:`roa.certify` (with ``check_above`` if asked), and the first certified
one is returned with the search's record (``Certificate.vs``). The SDPs prove nothing: only the
interval validation certifies.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import QuadraticLyapunov, as_lyapunov
from roa.options import IntervalOptions, SampledOptions, SampleSearchOptions, VsOptions
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
    from roa.search.vs_iteration import vs_search

    t0 = time.perf_counter()
    if degree not in DEGREES:
        raise RoaInputError(f"degree must be one of {DEGREES}, got {degree!r}")
    seed = _quadratic_seed(system, V, f"degree={degree} searches V from a quadratic seed; V")
    vs = VsOptions() if vs is None else vs
    if vs.method == "sampled":
        o = (SampleSearchOptions() if vs.sampled is None else vs.sampled).replace(degree=degree)
        return certify_sampled(system, seed, options=o, interval=interval,
                               check_above=check_above)  # fmt: skip
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


def certify_sampled(
    system: System,
    V0: Any = None,
    *,
    options: SampleSearchOptions | None = None,
    hard: Any = None,
    soft: Any = None,
    level: float | Callable[[Any, float], float] | None = None,
    interval: IntervalOptions | None = None,
    check_above: float | None = 1.001,
    retries: int = 3,
) -> Any:
    """Search a polynomial V by sampled cutting planes (:mod:`roa.search.cutting_planes`), then
    certify one of its levels with :func:`roa.certify` (interval validation).

    ``V0`` is the quadratic seed (default :func:`roa.default_lyapunov`); ``hard`` / ``soft`` the
    search's target points (system coordinates). The sampled optimum ``c*`` of the candidate is
    found by :func:`roa.level_search`; the validated level is ``level`` if given (a number, or a
    function ``level(V, c*)`` of the candidate, e.g. the least level holding a target), else
    ``min(1, options.level_safety * c*)`` (1 is the search's target level). ``check_above``:
    ``check_above * c*`` is validated too (expected: refuted, with a 50-digit witness; its cover is
    the box reached along rays, proved by ``V > level`` on its faces, without whitening), so the
    report shows how close the certified level is to the best this V allows. A validation
    refuted with a confirmed witness ``w`` (V' >= 0 at 50 digits, in the equilibrium's component)
    proves the true optimum is at most ``V(w)``: up to ``retries`` times, ``c*`` becomes
    ``min(c*, V(w))`` and the level is chosen again, at most ``options.level_safety * c*`` and
    below the refuted one (the message says so; ``check_above`` applies to the new ``c*``, which
    is the returned ``candidate``); ``w`` is first moved to a local minimum of V on ``{V' >= 0}``
    (:func:`_lowest_witness`). The check at ``check_above * c*`` is refuted by such a confirmed
    point when one lies below it (from a retry, or from the level search's witness), else by the
    branch and bound. The returned
    :class:`~roa.certification.Certificate` carries the search record in ``.vs``
    (``SampleSearchResult``).
    """
    from roa.certification import Certificate, certify
    from roa.levelset import level_search
    from roa.search.cutting_planes import sample_search

    t0 = time.perf_counter()
    o = SampleSearchOptions() if options is None else options
    if check_above is not None and not (np.isfinite(check_above) and check_above > 1):
        raise RoaInputError(f"check_above must be a finite number > 1, got {check_above!r}")
    if isinstance(retries, bool) or not isinstance(retries, int) or not 0 <= retries <= 10:
        raise RoaInputError(f"retries must be an integer in [0, 10], got {retries!r}")
    seed = _quadratic_seed(system, V0, "the sampled search starts from a quadratic seed; V0")
    with step(f"sampled search of V, degree {o.degree}"):
        res = sample_search(system, seed, hard=hard, soft=soft, options=o)
    if res.V is None:
        return Certificate(status=Verdict.INCONCLUSIVE, level=None, method="sampled search",
                           level_source=None, seconds=time.perf_counter() - t0,
                           message=f"the sampled search found no candidate: {res.message}",
                           vs=res, system=system, V=seed)  # fmt: skip
    V = res.V
    with step("sampled level search of the candidate"):
        lv = level_search(system, V, shape="level", method="sampled")
    if lv.level is None:
        return Certificate(status=Verdict.INCONCLUSIVE, level=None, method="level search",
                           level_source=None, seconds=time.perf_counter() - t0,
                           message=f"no sampled level for the candidate: {lv.message}",
                           search=lv, vs=res, system=system, V=V)  # fmt: skip
    opt = float(lv.level)
    if level is None:
        value = min(1.0, o.level_safety * opt)
    else:
        value = level(V, opt) if callable(level) else level
        if not (isinstance(value, int | float) and np.isfinite(value) and value > 0):
            raise RoaInputError(f"level must be a finite number > 0, got {value!r}")
        value = float(value)
    with step(f"validation of {V.name} at level {value:.6g}"):
        cert = certify(system, V, level=value, method="interval", interval=interval)
    sampled, notes = opt, []
    proof: tuple[Any, Any, float] | None = None  # a confirmed witness below the optimum
    for _ in range(retries):
        # a confirmed witness (V' >= 0 at 50 digits, in the equilibrium's component) bounds the
        # true optimum by V(witness): retry below it and below the refuted level
        w = cert.validation.witness if cert.validation is not None else None
        ok = cert.validation is not None and (cert.validation.witness_check or {}).get("confirmed")
        if cert.status is not Verdict.REFUTED or w is None or not ok:
            break
        bound, x, check = _lowest_witness(system, V, np.asarray(w, dtype=float))
        if not bound > 0 or x is None:  # only a point proved in the component bounds c*
            break
        if bound <= opt:
            proof = (x, check, bound)  # refutes every level >= V(x)
        opt = min(opt, bound)
        new = level(V, opt) if callable(level) else o.level_safety * opt
        new = min(float(new), o.level_safety * opt)
        if not 0 < new < value:
            break
        notes.append(f"refuted at {value:.7g} (V' >= 0 at V = {bound:.10g}, 50 digits)")
        value = new
        with step(f"validation of {V.name} at level {value:.6g} (below the witness)"):
            cert = certify(system, V, level=value, method="interval", interval=interval)
    if notes:
        cert = dataclasses.replace(
            cert,
            message=f"{cert.message}; retried below confirmed witnesses (sampled optimum "
            f"{sampled:.7g}): " + "; ".join(notes),
        )
    above = None
    if check_above is not None:  # refute just above the optimum
        top = check_above * opt
        # a retry's proof has V(x) = opt = top / check_above, below top; without one, the level
        # search's witness is tried (the test below re-checks either way)
        if proof is None and lv.witness is not None:
            v, x, check = _lowest_witness(system, V, np.asarray(lv.witness, dtype=float))
            if x is not None and v * (1 + 1e-12) <= top:
                proof = (x, check, v)
        if proof is not None and proof[2] * (1 + 1e-12) <= top:  # checked at V(x) (1 + 1e-12)
            how = f"local minimum of V on {{V' >= 0}}, V = {proof[2]:.10g}"
            above = _refuted_by(proof[0], proof[1], top, how)
        else:  # branch and bound, a box from rays as the cover
            from roa.proof.cover import ray_box

            half = ray_box(V, top)
            with step(f"refutation check of {V.name} at level {top:.6g}"):
                above = certify(system, V, level=top, method="interval", interval=interval,
                                bounding_box=None if half is None else 1.3 * half).validation  # fmt: skip
    # "witness": a retry chose the level below a confirmed witness (not the caller's level)
    source = "witness" if notes else "given" if level is not None else "sampled"
    return dataclasses.replace(cert, vs=res, search=lv, candidate=opt, above=above,
                               level_source=source, seconds=time.perf_counter() - t0)  # fmt: skip


def _lowest_witness(
    system: System, V: Any, w: np.ndarray
) -> tuple[float, np.ndarray | None, dict[str, Any] | None]:
    """``(value, x, check)``: a local minimum ``x`` of V on ``{V' >= delta}`` from ``w`` (SLSQP)
    whose ``V' >= 0`` holds at 50 digits (``check``) and that is proved to lie in the
    equilibrium's component of ``{V <= V(x)}``
    (:func:`roa.proof.validate_general.connected_to_center`); ``(V(w), None, None)`` when none is
    found at most ``V(w) (1 + 1e-6)`` (SLSQP may end a hair above a ``w`` that is already a
    local minimum; a confirmed ``x`` is a valid bound whatever its value). A confirmed ``x``
    bounds the true optimum of V by ``V(x)`` (the validation's witness sits on the level it
    refuted, the level search's near the touching point; the minimum is where V' = 0 first
    touches a level surface)."""
    from scipy.optimize import minimize

    from roa.proof.validate_general import connected_to_center, recheck_general

    with np.errstate(all="ignore"):
        best = float(V.value(w[None])[0])

    def vdot(x: np.ndarray) -> float:
        return float(V.derivative(system, x[None])[0])

    for delta in (1e-12, 1e-10, 1e-8):
        with np.errstate(all="ignore"):
            res = minimize(lambda x: float(V.value(x[None])[0]), w, method="SLSQP",
                           constraints=[{"type": "ineq", "fun": lambda x, dl=delta: vdot(x) - dl}],
                           options={"maxiter": 300, "ftol": 1e-15})  # fmt: skip
            x = np.asarray(res.x, dtype=float)
            v = float(V.value(x[None])[0])
        if not (np.isfinite(v) and 0 < v < best * (1 + 1e-6)):
            continue
        if system.margin is not None and not system.inside(x[None])[0]:
            continue
        top = v * (1 + 1e-12)
        check = recheck_general(system, V, x, top)
        if check["confirmed"] and connected_to_center(V, x, top):
            return v, x, check
    return best, None, None


def _refuted_by(x: np.ndarray, check: dict[str, Any], level: float, how: str) -> Any:
    """A refutation of ``level`` by a confirmed witness ``x`` with ``V(x) <= level``."""
    from roa.proof.validate import Validation

    return Validation(Verdict.REFUTED, level, 0, 0.0, witness=[float(v) for v in x],
                      witness_check=check,
                      message=f"V' >= 0 at a point of {{V <= level}} in the equilibrium's "
                      f"component (float and 50 digits; {how})")  # fmt: skip


def _quadratic_seed(system: System, V: Any, what: str) -> QuadraticLyapunov:
    """``V`` as a quadratic Lyapunov function of ``system``, or an error starting with ``what``."""
    given = as_lyapunov(system, V)
    seed = given.as_quadratic()
    if seed is None:
        raise RoaInputError(
            f"{what} {given.name!r} is {type(given).__name__}: give a matrix P or a "
            "QuadraticLyapunov (or none)"
        )
    return seed
