"""Symbolic derivation of the cart-pole model and of the transformed system (2.3), with sympy.

Used by the errata experiment and by ``ipc_paper/tests/test_symbolic.py``. Nothing here is transcribed from
the paper except :func:`paper_printed`, which holds the paper's formulas *as printed*, to be compared.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

t = sp.Symbol("t", real=True)
delta, u = sp.symbols("delta u", positive=True)
u = sp.Symbol("u", real=True)
q_s, qd_s, th_s, thd_s = sp.symbols("q q_dot theta theta_dot", real=True)
z1, z2, w1, w2 = sp.symbols("z1 z2 w1 w2", real=True)
w = sp.Symbol("w", real=True)
v = sp.Symbol("v", real=True)


def lagrangian_model() -> tuple[sp.Expr, sp.Expr]:
    """Derive ``(q'', theta'')`` from the cart-pole Lagrangian, normalised.

    Lagrangian (units with m = l = g = 1, M = delta)::

        L = (1 + delta) q'^2 / 2 + cos(theta) q' theta' + theta'^2 / 2 - cos(theta)

    with generalised forces (u, 0) on (q, theta).
    """
    q = sp.Function("q")(t)
    th = sp.Function("theta")(t)
    L = (
        (1 + delta) * q.diff(t) ** 2 / 2
        + sp.cos(th) * q.diff(t) * th.diff(t)
        + th.diff(t) ** 2 / 2
        - sp.cos(th)
    )
    eq_q = sp.diff(L.diff(q.diff(t)), t) - L.diff(q) - u
    eq_th = sp.diff(L.diff(th.diff(t)), t) - L.diff(th)
    qdd, thdd = sp.symbols("qdd thdd")
    subs = {q.diff(t, 2): qdd, th.diff(t, 2): thdd}
    eqs = [e.subs(subs) for e in (eq_q, eq_th)]
    sol = sp.solve(eqs, [qdd, thdd], dict=True)[0]
    back = {th.diff(t): thd_s, q.diff(t): qd_s, th: th_s, q: q_s}
    return sp.simplify(sol[qdd].subs(back)), sp.simplify(sol[thdd].subs(back))


def paper_printed() -> dict[str, sp.Expr]:
    """The paper's formulas (2.1), (2.4), (2.5) exactly as printed (with their errors)."""
    s, c = sp.sin(th_s), sp.cos(th_s)
    r = 1 + w**2
    den = delta * r + w**2
    phi2 = (1 + delta) * w / den
    phi1 = 1 / den
    phi3 = w / r**2 * ((-(w**2) - 1) / den + 2 * r)
    return {
        "thdd_2_1": (u + thd_s**2 * s - s * c) / (s**2 + delta),
        "qdd_2_1": (-u * c - thd_s**2 * s * c + (1 + delta) * s) / (s**2 + delta),
        "phi0": w / r ** sp.Rational(3, 2),
        "phi1": phi1,
        "phi2": phi2,
        "phi3": phi3,
        "u_2_5": (v + phi2.subs(w, w1) + w2**2 * phi3.subs(w, w1)) / phi1.subs(w, w1),
    }


@dataclass(frozen=True)
class Transformed:
    """Time derivatives of (z1, z2, w1, w2) under a model, expressed in (z, w, u), simplified."""

    z1_dot: sp.Expr
    z2_dot: sp.Expr
    w1_dot: sp.Expr
    w2_dot: sp.Expr


def transform(qdd: sp.Expr, thdd: sp.Expr) -> Transformed:
    """Push a model ``(q'', theta'')`` through the coordinates (2.2), restricted to |theta| < pi/2.

    Substitutes theta = atan(w1), theta' = w2 / (1 + w1^2) (the inverse of (2.2)), so the results are
    functions of (w1, w2, u) and of z2 for z1'.
    """
    Z1 = q_s + 2 * sp.atanh(sp.tan(th_s / 2))
    Z2 = qd_s + thd_s / sp.cos(th_s)
    W1 = sp.tan(th_s)
    W2 = thd_s / sp.cos(th_s) ** 2

    def ddt(expr: sp.Expr) -> sp.Expr:
        return (
            expr.diff(q_s) * qd_s
            + expr.diff(qd_s) * qdd
            + expr.diff(th_s) * thd_s
            + expr.diff(thd_s) * thdd
        )

    inverse = {thd_s: w2 / (1 + w1**2)}

    def to_flat(expr: sp.Expr) -> sp.Expr:
        e = expr.subs(inverse)
        e = e.subs(th_s, sp.atan(w1))
        return sp.simplify(sp.radsimp(sp.simplify(e)))

    z1d = sp.simplify(ddt(Z1) - Z2)  # should be 0: z1' = z2
    return Transformed(
        z1_dot=sp.simplify(z1d + z2),
        z2_dot=to_flat(ddt(Z2)),
        w1_dot=to_flat(ddt(W1)),
        w2_dot=to_flat(ddt(W2)),
    )


def phi_from_model(tr: Transformed) -> dict[str, sp.Expr]:
    """Read phi0..phi3 off the transformed model: w2' = -u phi1 + phi2 + w2^2 phi3 (as functions of w)."""
    w2d = sp.expand(tr.w2_dot)
    phi1 = sp.simplify(-w2d.diff(u))
    rest = sp.simplify(w2d + u * phi1)
    phi3 = sp.simplify(rest.diff(w2, 2) / 2)
    phi2 = sp.simplify(rest - w2**2 * phi3)
    phi0 = sp.simplify((tr.z2_dot - w1).diff(w2, 2) / 2)
    return {
        k: sp.simplify(e.subs(w1, w))
        for k, e in {"phi0": phi0, "phi1": phi1, "phi2": phi2, "phi3": phi3}.items()
    }


def is_zero(expr: sp.Expr, samples: int = 6, seed: int = 0) -> bool:
    """Exact simplification to 0, or failing that, vanishing at random rational points to 1e-12."""
    if sp.simplify(expr) == 0:
        return True
    import random

    rng = random.Random(seed)
    syms = sorted(expr.free_symbols, key=str)
    for _ in range(samples):
        point = {s: sp.Rational(rng.randint(-900, 900), 1000) for s in syms}
        if delta in point:
            point[delta] = sp.Rational(rng.randint(1, 3000), 1000)
        if abs(complex(sp.N(expr.subs(point), 30))) > 1e-12:
            return False
    return True
