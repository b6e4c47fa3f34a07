"""Exact symbolic tools for Lyapunov candidates: sympy expressions evaluated in any namespace.

:func:`symbolic_gradient` differentiates a candidate's ``expr`` exactly (every float taken as the
exact rational of the double, :func:`roa.model.exact_rationals`); :func:`roa.model.sympy_eval` evaluates the result in
any namespace of :mod:`roa.model._backend`, in the interval namespace and jets of
:mod:`roa.proof._interval` (rational constants enclosed), or in mpmath.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from roa.errors import RoaInputError
from roa.model._sympy_eval import exact_rationals, sympy_eval

if TYPE_CHECKING:
    from roa.lyapunov._base import Lyapunov


def symbolic_gradient(lyap: Lyapunov) -> Any:
    """A function ``(x, xp) -> [dV/dx_i]`` from an exact sympy differentiation of ``lyap.expr``."""
    cached = getattr(lyap, "_gradient_cache", None)
    if cached is not None:
        return cached
    import sympy as sp

    from roa.model._backend import namespace

    xs = sp.symbols(f"x0:{lyap.n}", real=True)
    try:
        V = exact_rationals(sp.sympify(lyap.expr(list(xs), namespace("sympy"))))
    except (TypeError, ValueError, AttributeError) as exc:
        raise RoaInputError(
            f"V {lyap.name!r} must be written against the array namespace xp (sympy failed: {exc})"
        ) from None
    grads = [sp.diff(V, s) for s in xs]
    if any(g.has(sp.sign, sp.Heaviside, sp.DiracDelta, sp.Derivative) for g in grads):
        raise RoaInputError(f"V {lyap.name!r} is not differentiable (abs or a kink): no gradient")

    def fn(x: Any, xp: Any) -> list[Any]:
        env = dict(zip(xs, [x[i] for i in range(lyap.n)], strict=True))
        return [sympy_eval(g, env, xp) for g in grads]

    object.__setattr__(lyap, "_gradient_cache", fn)
    return fn
