"""The preconditions of a certificate of ``{V <= c}``, listed once and checked on every route.

A validator proves ``V' < 0`` on ``{V <= c}`` minus the equilibrium; that makes ``{V <= c}`` part
of the region of attraction only when, in addition (:data:`PRECONDITIONS`):

* ``autonomous``: the field does not depend on time;
* ``equilibrium``: the system has an equilibrium and V is centred at it (that the field vanishes
  there is each route's own proof: exactly for the SOS routes, by the local proof for the
  branch and bound);
* ``level``: the level is a finite number > 0;
* ``parameters``: a system with uncertain parameters is proved for its whole box (a route that
  proves one field refuses it);
* ``bounded``: ``{V <= c}`` is compact (V positive definite: ``V >= mu |d|^2`` from V's Gram
  matrix in exact rationals, :func:`roa.proof.gram_cover`), or, for a route that proves its
  own cover of the equilibrium's component (the branch and bound), that cover;
* ``invariant`` (discrete-time systems ``x+ = F(x)``): the certified set is the *whole*
  sublevel set ``{V <= c}`` (the global cover of ``V >= mu |d|^2``, above). Then
  ``Delta V = V(F(x)) - V(x) < 0`` on it minus the fixed point ``x_eq`` gives
  ``V(F(x)) <= V(x) <= c``: ``F`` maps ``{V <= c}`` into itself, so the set is invariant, and
  ``V`` decreases strictly along every orbit in it, which therefore converges to ``x_eq``
  (``V(x_k)`` decreases to a limit; the limit points form an invariant set on which
  ``Delta V = 0``, that is ``{x_eq}``; ``F`` and ``V`` continuous, the set compact). For a flow
  the equilibrium's connected component of the set is enough (a trajectory cannot leave it
  without crossing its boundary); a map can *jump* from that component into another one where
  nothing is proved, so a route's cover of the component alone (the branch and bound's box with
  ``V > c`` on its faces) is refused for a map: it is the whole set only when the set is
  connected, which this module does not prove for a non-convex ``V``;
* ``domain``: ``{V <= c}`` lies inside the system's declared domain ``{margin > 0}``, proved by a
  Putinar certificate (exact check, stored with the certificate and re-checked with it) or by
  interval branch and bound (:mod:`roa.proof._domain`), or by the route's own boxes (the branch
  and bound proves ``margin > 0`` on every box it keeps). A point of ``{V <= c}`` outside the
  domain, confirmed at 50 digits, **refutes** the level; a containment not proved leaves it
  inconclusive: a level is never certified, and a verdict never handed to another validator,
  without this proof.

:func:`check_preconditions` is called by every validator (:mod:`roa.certification._strategies`)
and every re-check of a stored certificate (:func:`roa.proof._sos_stored.recheck`). It proves
nothing numerical itself beyond the domain; the search of a Putinar candidate is injected
(``propose``) so that this module, like all of :mod:`roa.proof`, calls no solver.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roa.lyapunov import Lyapunov
from roa.model._system import System
from roa.proof._validation import Reason, Validation
from roa.status import Verdict

#: Every precondition of a certificate, by name (module docstring).
PRECONDITIONS = (
    "autonomous",
    "equilibrium",
    "level",
    "parameters",
    "bounded",
    "invariant",
    "domain",
)


@dataclass(frozen=True)
class Route:
    """What a route proves by itself: ``parameters`` (the whole box of uncertain parameters),
    ``cover`` (its own proved cover of the set: the branch and bound) and ``domain_by_boxes``
    (``margin > 0`` on every box it keeps)."""

    name: str
    parameters: bool = False
    cover: bool = False
    domain_by_boxes: bool = False


@dataclass(frozen=True)
class Preconditions:
    """Outcome of :func:`check_preconditions`: ``refusal`` None when every precondition holds
    (or is left to the route, as :class:`Route` says), else the verdict to return; ``domain``
    the evidence of the domain containment (stored with a certificate)."""

    refusal: Validation | None
    domain: dict[str, Any] | None = None
    notes: dict[str, str] = field(default_factory=dict)


def _refuse(level: float, t0: float, status: Verdict, precondition: str, message: str,
            route: Route, **meta: Any) -> Preconditions:  # fmt: skip
    why = Reason.DOMAIN if precondition == "domain" else Reason.PRECONDITION
    v = Validation(status, float(level), 0, time.perf_counter() - t0, message=message,
                   meta={"method": route.name, "precondition": precondition, **meta},
                   reason=why)  # fmt: skip
    return Preconditions(v)


def check_preconditions(
    system: System,
    V: Lyapunov,
    level: Any,
    route: Route,
    *,
    stored_domain: Any = None,
    propose: Callable[..., Any] | None = None,
    recheck: bool = False,
    find_outside: Callable[[System, Lyapunov], Any] | None = None,
    cover_estimate: Callable[[Lyapunov, float], Any] | None = None,
) -> Preconditions:
    """Check every precondition of :data:`PRECONDITIONS` for ``{V <= level}`` on ``route``.

    ``stored_domain``: the domain evidence stored with a certificate (a Putinar certificate,
    re-checked exactly as stored); ``recheck``: a stored certificate is being re-checked (no
    solver: without a stored domain certificate the containment is proved by intervals);
    ``propose(margin, Vq, n, level)``: the search of a Putinar candidate
    (:func:`roa.search._sos_program.propose_domain_certificate`) for a fresh certificate;
    ``find_outside(system, V) -> (value, x, check) | None``: the search of a point of the set
    outside the domain (:func:`roa.search._outside.domain_witness`), whose ``x`` refutes the
    levels from ``V(x)`` up once proved here (:func:`roa.proof._domain.confirmed_outside`);
    without it no level is refuted for leaving the domain (its containment is proved or not);
    ``cover_estimate``: the proposal of a box holding the set for the interval containment
    (:func:`roa.proof.prove_cover`)."""
    from roa.proof._cover import gram_cover

    t0 = time.perf_counter()

    def refuse(name: str, message: str, status: Verdict = Verdict.INCONCLUSIVE,
               **meta: Any) -> Preconditions:  # fmt: skip
        return _refuse(lvl, t0, status, name, f"precondition '{name}' not met: {message}", route,
                       **meta)  # fmt: skip

    lvl = float(level) if isinstance(level, int | float) and np.isfinite(level) else float("nan")
    if system.time_varying:
        return refuse("autonomous", "the system is time-varying; a sublevel set of V is "
                      "certified for an autonomous field only")  # fmt: skip
    if system.equilibrium is None:
        return refuse("equilibrium", "the system declares no equilibrium")
    if V.n != system.n or not np.array_equal(np.asarray(V.center, float), system.x_eq):
        return refuse("equilibrium", f"V is centred at {np.asarray(V.center).tolist()}, the "
                      f"system's equilibrium is {system.x_eq.tolist()}")  # fmt: skip
    if not (np.isfinite(lvl) and lvl > 0):
        return refuse("level", f"the level must be a finite number > 0, got {level!r}")
    if system.parameters and not route.parameters:
        return refuse("parameters", f"the system has uncertain parameters and route "
                      f"{route.name!r} proves one field, not the whole box")  # fmt: skip
    whole = gram_cover(V, lvl) is not None
    if not whole and system.time == "discrete":
        return refuse("invariant", "for a map x+ = F(x) the certified set must be the whole "
                      "sublevel set {V <= level} (V >= mu |d|^2 from a positive definite Gram "
                      "matrix, e.g. a quadratic V): a cover of the equilibrium's component alone "
                      "does not prove F maps it into itself (an orbit may jump to another "
                      "component)")  # fmt: skip
    if not whole and not route.cover:
        return refuse("bounded", "V >= mu |d|^2 not proved (no positive definite Gram matrix "
                      "over the linear monomials): {V <= level} may be unbounded")  # fmt: skip
    if system.margin is None:
        return Preconditions(None)
    return _domain(system, V, lvl, route, stored_domain, propose, recheck, refuse, find_outside,
                   cover_estimate)  # fmt: skip


def _domain(system: System, V: Lyapunov, level: float, route: Route, stored: Any,
            propose: Any, recheck: bool, refuse: Callable[..., Preconditions],
            find_outside: Any = None, cover_estimate: Any = None
            ) -> Preconditions:  # fmt: skip
    """The ``domain`` precondition (module docstring)."""
    from roa.proof._domain import (
        check_domain_certificate,
        confirmed_outside,
        interval_containment,
        margin_poly,
    )
    from roa.proof._putinar import Certificate
    from roa.proof._sos_check import (
        NotPolynomial,
        exact_terms,
        parse_basis,
        parse_matrix,
        parse_rational,
    )

    where = system.domain_description
    try:
        if not system.inside(np.asarray(V.center, float)[None])[0]:
            return refuse("domain", f"the equilibrium is not inside the domain ({where})")
    except (ValueError, TypeError, ArithmeticError) as exc:
        return refuse("domain", f"the margin cannot be evaluated ({exc})")
    found = None if find_outside is None else find_outside(system, V)
    if found is not None:  # the search's point, proved here
        proved = confirmed_outside(system, V, found[1])
        found = None if proved is None else (proved[0], found[1], proved[1])
    if found is not None and found[0] * (1 + 1e-12) <= level:
        value, x, check = found
        return refuse("domain", f"the level set leaves the domain ({where}): V = {value:.10g} "
                      f"<= level at a point outside it (float and 50 digits); every level from "
                      f"{value:.10g} up is refuted", Verdict.REFUTED,
                      domain_witness=[float(v) for v in x], domain_check=check,
                      domain_level=value)  # fmt: skip
    bound: dict[str, Any] = {} if found is None else {"domain_level": found[0]}
    if stored is not None:  # a stored Putinar certificate: checked exactly as stored, or refused
        try:
            if not isinstance(stored, dict):
                raise ValueError("the domain certificate must be an object")
            n = V.n
            b0 = parse_basis(stored.get("basis0"), n, "domain basis0")
            b1 = parse_basis(stored.get("basis1"), n, "domain basis1")
            Q0 = parse_matrix(stored.get("Q0"), len(b0), "domain Q0")
            Q1 = parse_matrix(stored.get("Q1"), len(b1), "domain Q1")
            eps = parse_rational(stored.get("eps"), "eps")
            grams = ((0, b0, Q0), (1, b1, Q1)) if b1 else ((0, b0, Q0),)
            res = check_domain_certificate(margin_poly(system, V), exact_terms(V), n, level, eps,
                                           Certificate(grams), stored=True)  # fmt: skip
        except (ValueError, TypeError, ZeroDivisionError, NotPolynomial) as exc:
            return refuse("domain", f"malformed domain certificate: {exc}")
        if not res.ok:
            return refuse("domain", f"stored domain certificate refused: {res.reason}")
        return Preconditions(None, {"method": "putinar", **(res.certificate or {})},
                             {"domain": res.reason})  # fmt: skip
    if route.domain_by_boxes:
        return Preconditions(None, None, {"domain": "proved box by box by the route"})
    why = ""
    if propose is not None and not recheck and V.is_polynomial:
        try:
            mq = margin_poly(system, V)
            cand = propose(mq, exact_terms(V), V.n, level)
            if cand.certificate is None:
                why = f"Putinar candidate not found ({cand.solver_status})"
            else:
                res = check_domain_certificate(mq, exact_terms(V), V.n, level, cand.eps,
                                               cand.certificate)  # fmt: skip
                if res.ok:
                    return Preconditions(None, {"method": "putinar", **(res.certificate or {})},
                                         {"domain": res.reason})  # fmt: skip
                why = res.reason
        except NotPolynomial as exc:
            why = str(exc)
    box = interval_containment(system, V, level, cover_estimate=cover_estimate)
    if box.status == "proved":
        return Preconditions(None, {"method": "interval", "boxes": box.boxes},
                             {"domain": box.message})  # fmt: skip
    detail = f"{why}; {box.message}" if why else box.message
    return refuse(
        "domain", f"{{V <= level}} not proved inside the domain ({where}): {detail}", **bound
    )
