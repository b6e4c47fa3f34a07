"""Checks of a system before any analysis: a malformed system gets a clear error, not a wrong answer.

:func:`check_system` evaluates the field at the equilibrium (right number of finite components),
checks that the equilibrium is one (``|f(x_eq)|`` small relative to the field's scale near it),
that it lies inside the domain, and classifies the linearisation (Hurwitz / degenerate /
unstable). The analyses call it: :func:`roa.level_search` and :func:`roa.certify` refuse an
unstable linearisation; a degenerate one gets a note (higher-order terms decide).

The field is also evaluated once on probe values (:mod:`roa.model._field_probe`): a state-dependent
integer power above ``MAX_POWER`` (100) or more than ``MAX_OPS`` operations is refused by every
check; for an analysis (``analysis=True``: certify, level search), so is a numpy function applied
to a state, named (the analyses evaluate the field in namespaces numpy's functions do not know).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from roa.errors import RoaInputError, SystemDefinitionError
from roa.model._field_probe import check_functions
from roa.model._linearisation import Linearisation, linearise
from roa.model._system import System

#: |f(x_eq)| must be below this times the field's scale near the equilibrium.
RESIDUAL_RTOL = 1e-8


@dataclass(frozen=True)
class SystemCheck:
    """What :func:`check_system` found: the residual at the equilibrium and the linearisation."""

    residual: float
    scale: float
    linearisation: Linearisation | None
    notes: tuple[str, ...] = ()


def evaluate(system: System, x: np.ndarray) -> np.ndarray:
    """The field at one state (``F(x) - x`` for a map: zero at a fixed point) with a clear
    error when it is malformed (wrong size, not finite)."""
    try:
        out = system.residual_expr([float(v) for v in x], _np())
        values = np.asarray([float(np.asarray(v)) for v in out], dtype=float)
    except (TypeError, ValueError, IndexError, OverflowError) as exc:
        raise SystemDefinitionError(
            f"system {system.name!r}: the field cannot be evaluated at {np.asarray(x).tolist()} "
            f"({type(exc).__name__}: {exc}); it must return {system.n} numbers, one per state "
            f"{system.state_names}"
        ) from None
    if values.shape != (system.n,):
        raise SystemDefinitionError(
            f"system {system.name!r}: the field returns {values.size} components, expected "
            f"{system.n} (one per state {', '.join(system.state_names)})"
        )
    return values


def _np():  # noqa: ANN202 - the numpy namespace
    from roa.model._backend import NP

    return NP


#: Times at which an autonomous field must give what it gives at t = 0.
PROBE_TIMES = (0.7, 13.1, -2.9)


def _check_autonomous(system: System, X: np.ndarray, F0: np.ndarray) -> None:
    """A field that changes with ``t`` must be declared ``time_varying=True``: an equilibrium
    analysis of it would be about the field frozen at ``t = 0``."""
    for t in PROBE_TIMES:
        with np.errstate(all="ignore"):
            try:
                Ft = system.evaluate(X, t)
            except Exception:  # noqa: BLE001 - a field that fails at t != 0 depends on t
                Ft = np.full_like(F0, np.nan)
        same = np.isclose(Ft, F0, rtol=1e-12, atol=0.0, equal_nan=True)
        if not same.all():
            k = int(np.argwhere(~same.all(axis=1))[0, 0])
            raise RoaInputError(
                f"system {system.name!r}: the field depends on t (at x = "
                f"{np.array2string(X[k], precision=4)}: f = {np.array2string(F0[k], precision=6)} "
                f"at t = 0, {np.array2string(Ft[k], precision=6)} at t = {t}) but the system is "
                "not declared time_varying=True; an equilibrium analysis needs an autonomous "
                "field (remove t from the field, or declare time_varying=True to simulate it)"
            )


#: Interior points per uncertain parameter where the equilibrium and linearisation are checked.
BOX_POINTS_PER_AXIS = 3


def _check_box(system: System, analysis: bool) -> None:
    """The equilibrium stays one, inside the domain, with a stable linearisation, at the sample
    points of the parameter box (its vertices, nominal value and a few points along each axis);
    an error names the parameter values where it fails. (Proofs check the equilibrium exactly
    over the whole box, :func:`roa.proof.exact_equilibrium`.)"""
    from roa.model._parameters import describe_point, sample_points

    for p in sample_points(system, per_axis=BOX_POINTS_PER_AXIS):
        try:
            check_system(system.at(**p), analysis=analysis)
        except RoaInputError as exc:
            raise type(exc)(
                f"for the parameter values {describe_point(p)} of the box of {system.name!r}: {exc}"
            ) from None


@functools.lru_cache(maxsize=64)
def check_system(system: System, *, analysis: bool = False) -> SystemCheck:
    """Check ``system`` at its equilibrium; with ``analysis`` also classify its linearisation.

    Raises
    ------
    SystemDefinitionError
        The field is malformed (wrong number of components, not finite at the equilibrium).
    RoaInputError
        The equilibrium is not one (``f(x_eq) != 0``), lies outside the domain, or (with
        ``analysis``) its linearisation is unstable.

    Examples
    --------
    >>> from roa.systems.vanderpol import vanderpol
    >>> check_system(vanderpol(), analysis=True).linearisation.kind
    'hurwitz'
    """
    if system.equilibrium is None or system.time_varying:
        return SystemCheck(0.0, 0.0, None)
    x_eq = system.x_eq
    if x_eq.shape != (system.n,):
        raise SystemDefinitionError(
            f"system {system.name!r}: equilibrium has {x_eq.size} components, expected {system.n}"
        )
    check_functions(system, strict=analysis)
    f_eq = evaluate(system, x_eq)
    if not np.all(np.isfinite(f_eq)):
        raise SystemDefinitionError(
            f"system {system.name!r}: the field is not finite at the equilibrium {x_eq.tolist()} "
            f"(f = {f_eq.tolist()})"
        )
    rng = np.random.default_rng(0)
    r = 1e-2 * (1.0 + float(np.linalg.norm(x_eq)))
    U = rng.standard_normal((16, system.n))
    U /= np.linalg.norm(U, axis=1, keepdims=True)
    with np.errstate(all="ignore"):
        near = system.residual(x_eq + r * U)
    scale = float(np.nanmax(np.linalg.norm(near, axis=1))) if np.isfinite(near).any() else 1.0
    _check_autonomous(system, x_eq + r * U, system.evaluate(x_eq + r * U))
    residual = float(np.linalg.norm(f_eq))
    if residual > RESIDUAL_RTOL * max(scale, 1.0):
        raise RoaInputError(
            f"system {system.name!r}: equilibrium {x_eq.tolist()} is not an equilibrium: "
            f"{'F(x_eq) - x_eq' if system.time == 'discrete' else 'f(x_eq)'} = "
            f"{np.array2string(f_eq, precision=6)} (norm {residual:.3g}, scale near it "
            f"{scale:.3g}); give the point where the "
            f"{'map has a fixed point' if system.time == 'discrete' else 'field vanishes'}"
        )
    if system.margin is not None and not bool(system.inside(x_eq)):
        raise RoaInputError(
            f"system {system.name!r}: equilibrium {x_eq.tolist()} lies outside the domain "
            f"({system.domain_description}): margin(x_eq) must be > 0"
        )
    if system.parameters:
        _check_box(system, analysis)
    if not analysis:
        return SystemCheck(residual, scale, None)
    lin = linearise(system)
    discrete = system.time == "discrete"
    if lin.kind == "unstable":
        eig = lin.eigenvalues
        k = int(np.argmax(np.abs(eig) if discrete else eig.real))
        how = "of modulus > 1" if discrete else "with positive real part"
        raise RoaInputError(
            f"system {system.name!r}: the linearisation at {x_eq.tolist()} is unstable "
            f"(eigenvalue {eig[k]:.4g} {how}): the equilibrium is "
            "not asymptotically stable, so it has no region of attraction to estimate"
        )
    notes: tuple[str, ...] = ()
    if lin.kind == "degenerate":
        where = "on the unit circle" if discrete else "on the imaginary axis"
        notes = (
            f"the linearisation is degenerate (an eigenvalue {where}): stability is "
            "decided by higher-order terms; V' is checked near the equilibrium by sampling",
        )
    return SystemCheck(residual, scale, lin, notes)
