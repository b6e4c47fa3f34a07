"""Proofs that ``V' < 0`` near the equilibrium (minus the point itself), for any candidate.

The validation (:func:`roa.proof.validate_level`) discards the boxes inside a box ``L``
around the equilibrium ``x_eq`` proved here (:func:`local_box`), by one of two arguments:

1. **Hessian** (:func:`local_box_proof`): with ``f(x_eq) = 0`` exactly
   (:func:`roa.proof.exact_equilibrium`) and ``grad V(x_eq) = 0`` (:func:`gradient_vanishes`),
   ``V'(x_eq) = 0`` and ``grad V'(x_eq) = 0``, so by Taylor with integral remainder
   ``V'(x) = d' H~ d`` on ``L`` with ``d = x - x_eq`` and ``H~`` in the convex hull of the Hessians
   of ``V'`` on ``L``. Their enclosure ``[H]`` comes from second-order interval jets; every matrix in
   it is negative definite (:func:`hessian_negative_definite`: ``-H_mid - t I`` positive definite
   with ``t >= ||rad H||_F``, exact rationals), so ``V' < 0`` on ``L \\ {x_eq}``. ``L`` is the
   largest ``x_eq + 2^-k (B - x_eq)`` of the cover ``B`` that passes.
2. **Lowest-order homogeneous part** (:func:`higher_order_cube`), when the linearisation is
   degenerate (e.g. a zero Jacobian) and the Hessian of ``V'`` at the equilibrium is not negative
   definite. For a field whose V' is a polynomial in ``d = x - x_eq``, write
   ``V'(d) = h_m(d) + R(d)`` with ``h_m`` homogeneous of the lowest (even) degree ``m`` and ``R``
   the terms of degree > m. Then, with ``|d| = max_i |d_i|``:

   * ``h_m(d) = |d|^m h_m(d / |d|) <= -mu |d|^m`` where ``-mu`` bounds ``h_m`` on the faces of the
     cube ``[-1, 1]^n`` (interval branch and bound, outward rounding);
   * ``|R(d)| <= |d|^(m+1) K`` for ``|d| <= rho0 <= 1`` with ``K = sum |r_a| rho0^(|a| - m - 1)``
     (exact rationals);

   so ``V' < 0`` for ``0 < |d| < min(rho0, mu / K)``: that cube is ``L``. ``V' = grad V . f`` is
   formed from the exact sympy gradient (``2 P d`` for a quadratic V) and the coefficients are the
   exact rationals of the float data (sympy), so the argument is a proof, not an estimate.
3. **Contraction around an enclosed f(x_eq)** (:func:`contraction_box`), for a quadratic
   ``V = d' P d`` when neither argument applies because ``f(x_eq) = 0`` is not exact: a field
   written with rounded constants (``sin(x1 + pi/3) - math.sin(pi/3)``, ``math.pi`` a double) is
   0 at ``x_eq`` in floats but, its constants taken as the exact rationals they are, vanishes
   ``O(ulp)`` away, and its interval enclosure at ``x_eq`` is a small interval around 0. On a box
   ``X`` around ``x_eq`` let ``[J]`` enclose the Jacobians ``Df`` (first-order jets), ``[f0]`` the
   value ``f(x_eq)`` (interval evaluation at the point) and ``mu > 0`` with
   ``P J + J' P <= -mu I`` for every ``J`` in ``[J]`` (exact rationals,
   :func:`roa.proof._exact.interval_negative_definite`). For ``x, z`` in ``X``,
   ``f(x) - f(z) = J~ (x - z)`` with ``J~`` the mean of ``Df`` on the segment, in ``[J]``
   (Clarke's mean value theorem for a Lipschitz field with kinks). Hence, with ``d = x - x_eq``,
   ``beta >= |P f(x_eq)|_2`` and ``lam >= lambda_max(P)`` (both exact bounds):

   * ``V'(x) = 2 d' P f(x_eq) + d' (P J~ + J~' P) d <= 2 beta |d| - mu |d|^2 < 0`` for
     ``|d| > r0 = 2 beta / mu``, so ``V' < 0`` on ``X`` wherever ``V > c0 = lam r0^2``;
   * ``K = {V <= 2 c0}`` lies inside the box ``L`` the branch and bound discards (checked, exact),
     ``V' < 0`` on its boundary, so it is compact, convex and positively invariant, and on it
     ``d/dt (x - z)' P (x - z) = (x - z)' (P J~ + J~' P) (x - z) <= -mu |x - z|^2`` for any two
     solutions: the flow contracts ``K`` (in the metric ``P``), which therefore holds exactly one
     equilibrium ``x*`` of the field, and every solution in ``K`` converges to it exponentially.

   Every solution from the level set outside ``K`` has ``V' < 0`` (the branch and bound outside
   ``L``, the first point inside it), so it enters ``K`` and converges to ``x*``. **The claim is
   then convergence to the field's unique zero ``x*`` in ``K``**, within ``equilibrium_radius``
   of ``x_eq`` (``x* = x_eq`` when ``f(x_eq) = 0``; with ``beta = 0`` the interval proves that,
   ``K = {x_eq}`` and the claim is the usual ``V' < 0`` on ``L`` minus ``x_eq``). ``V`` is the
   system's quadratic form in ``x``; in the whitened frame of the branch and bound (``x = x_eq + M
   y``) the box ``L`` in ``y`` is mapped to its exact rational hull ``X`` in ``x`` and ``K`` is
   checked in ``y`` with ``W = y' M' P M y`` (the same function), so the float ``M^-1`` of the
   whitened field is never used.

**Discrete time** (``x+ = F(x)``, :attr:`roa.System.time`): ``V'`` above is the decrease
``Delta V(x) = V(F(x)) - V(x)`` (:meth:`roa.System.decrease_expr`) and arguments 1 and 2 hold
unchanged for it: with ``F(x_eq) = x_eq`` exactly (the residual ``F(x) - x`` vanishes,
:func:`roa.proof.exact_equilibrium`) and ``grad V(x_eq) = 0``, ``Delta V(x_eq) = 0`` and
``grad Delta V(x_eq) = DF(x_eq)' grad V(x_eq) - grad V(x_eq) = 0``. The Hessian of ``Delta V``
at ``x_eq`` is ``2 (A'PA - P)`` for ``V = d'Pd`` and ``A = DF(x_eq)``: negative definite when
``P`` solves the discrete Lyapunov equation ``A'PA - P = -Q`` with ``Q > 0`` (a Schur ``A``,
:func:`roa.model.lyapunov_matrix`). The interval enclosure of the Hessians of
``Delta V`` over ``L`` (second-order jets of ``V(F(x))``, outward rounded) bounds the remainder,
so ``Delta V < 0`` on all of ``L`` minus ``x_eq``: no hole at the equilibrium. Argument 3 is
about a flow and is not used for a map.
"""

from __future__ import annotations

import itertools
from fractions import Fraction
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Lyapunov
from roa.model._system import System
from roa.proof._exact import exact_equilibrium, interval_negative_definite
from roa.proof._interval import Interval
from roa.proof._jet import Jet
from roa.proof._jet_net import JET


def hessian_negative_definite(vd: Jet, n: int) -> bool:
    """Every matrix in the interval Hessian of the second-order jet ``vd`` (one box) is negative
    definite (exact rationals)."""
    h = vd.h
    assert h is not None, "a second-order jet is needed"

    def bound(e: Any, side: str) -> float:
        return float(np.atleast_1d(getattr(Interval.of(e), side))[0])

    H_lo = np.array([[bound(h[min(i, j)][max(i, j)], "lo") for j in range(n)] for i in range(n)])
    H_hi = np.array([[bound(h[min(i, j)][max(i, j)], "hi") for j in range(n)] for i in range(n)])
    return interval_negative_definite(H_lo, H_hi)


def gradient_vanishes(lyap: Lyapunov) -> bool:
    """``grad V(x_eq) = 0`` exactly (sympy, the float centre and constants as exact rationals)."""
    cached = getattr(lyap, "_gradient_vanishes", None)
    if cached is not None:
        return bool(cached)
    import sympy as sp

    from roa.model._backend import namespace
    from roa.model._sympy_eval import exact_rationals

    if lyap.is_polynomial:
        ok = True  # every term has degree >= 2 in d = x - x_eq
    else:
        x = [sp.Rational(float(c)) for c in lyap.center]
        try:
            g = lyap.gradient_expr(x, namespace("sympy"))
            ok = all(sp.simplify(exact_rationals(sp.sympify(gi))) == 0 for gi in g)
        except (TypeError, ValueError, RoaInputError):
            ok = False
    try:
        object.__setattr__(lyap, "_gradient_vanishes", ok)
    except AttributeError:
        pass
    return ok


def local_box_proof(
    system: System, lyap: Lyapunov, lo: np.ndarray, hi: np.ndarray, *, exact: bool | None = None
) -> bool:
    """Prove ``V' < 0`` on the box ``[lo, hi]`` (holding ``x_eq``) minus the equilibrium.
    ``exact``: the result of :func:`hessian_preconditions` when the caller has it."""
    if exact is None:
        exact = hessian_preconditions(system, lyap)
    if not exact:
        return False
    # centred: a network's units take their ranges from the centred form (roa.proof._jet_net)
    X = Jet.variables(lo[None, :], hi[None, :], order=2, centred=True)
    vd = lyap.vdot_expr(system, X, JET)
    return hessian_negative_definite(vd, lyap.n)


def hessian_preconditions(system: System, lyap: Lyapunov) -> bool:
    """``grad V(x_eq) = 0`` and ``f(x_eq) = 0`` exactly (the Hessian argument's premises;
    ``F(x_eq) = x_eq`` for a map). For a whitened candidate the residual is checked on the
    system in ``x``: ``x(0) = x_eq`` exactly, so the whitened field (``M^-1 f``, or
    ``M^-1 (F - x_eq)``) vanishes at ``y = 0`` exactly when it does at ``x_eq``."""
    frame = lyap.unwhitened()
    if frame is not None:
        base_sys, center = frame[1], frame[0].center
    else:
        base_sys, center = system, lyap.center
    return gradient_vanishes(lyap) and exact_equilibrium(base_sys, center)


def local_box(
    system: System,
    lyap: Lyapunov,
    lo0: np.ndarray,
    hi0: np.ndarray,
    *,
    exact: bool | None = None,
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]] | None:
    """``(lo, hi, info)``: a box around the equilibrium inside ``[lo0, hi0]`` (or the cube of the
    lowest-order part, which may reach past it) on which ``V' < 0`` is proved minus the
    equilibrium (module doc), or None. ``info`` names the proof (``local_proof``); ``exact``: the
    result of :func:`hessian_preconditions` when the caller has it (checked here otherwise)."""
    c = np.asarray(lyap.center, dtype=float)
    if exact is None:
        exact = hessian_preconditions(system, lyap)
    for k in range(1, 41 if exact else 1):
        a, b = c + (lo0 - c) / 2.0**k, c + (hi0 - c) / 2.0**k
        if local_box_proof(system, lyap, a, b, exact=True):
            return a, b, {"local_proof": "hessian", "local_scale": 2.0**-k}
    found = higher_order_cube(system, lyap)
    if found is None:
        return contraction_box(system, lyap, lo0, hi0)
    rho, info = found
    return c - rho, c + rho, {"local_proof": "lowest-order homogeneous part", **info}


# -- contraction around an enclosed f(x_eq) (module doc, 3.) -----------------------------------------
def _down(q: Fraction) -> float:
    """The largest double <= ``q``."""
    f = float(q)
    return float(np.nextafter(f, -np.inf)) if Fraction(f) > q else f


def _up(q: Fraction) -> float:
    """The smallest double >= ``q``."""
    f = float(q)
    return float(np.nextafter(f, np.inf)) if Fraction(f) < q else f


def _ivals(e: Any) -> tuple[Fraction, Fraction] | None:
    """A scalar enclosure (float or one-box Interval) as exact bounds, or None if not finite."""
    if type(e) is float or isinstance(e, int | np.floating):
        v = float(e)
        return (Fraction(v), Fraction(v)) if np.isfinite(v) else None
    iv = Interval.of(e)
    lo, hi = np.ravel(iv.lo), np.ravel(iv.hi)
    if lo.size != 1 or not (np.isfinite(lo[0]) and np.isfinite(hi[0])):
        return None
    return Fraction(float(lo[0])), Fraction(float(hi[0]))


def _quadratic_matrix(lyap: Lyapunov) -> list[list[Fraction]] | None:
    """``P`` of ``V = d' P d`` as exact rationals (from the float terms), or None."""
    terms = lyap.polynomial_view()
    if terms is None or not terms or any(sum(a) != 2 for a in terms):
        return None
    n = lyap.n
    P = [[Fraction(0)] * n for _ in range(n)]
    for a, q in terms.items():
        idx = [i for i, k in enumerate(a) for _ in range(k)]
        i, j = idx
        if i == j:
            P[i][i] = Fraction(float(q))
        else:
            P[i][j] = P[j][i] = Fraction(float(q)) / 2
    return P


def _lower_eig(A: list[list[Fraction]]) -> Fraction | None:
    """A rational ``t > 0`` with ``A - t I`` positive definite (exact), or None."""
    from roa.proof._exact import exact_positive_definite

    n = len(A)
    w = float(np.linalg.eigvalsh(np.array([[float(v) for v in r] for r in A]))[0])
    if not w > 0:
        return None
    t = Fraction(w / 2)
    ok, _ = exact_positive_definite([[A[i][j] - (t if i == j else 0) for j in range(n)]
                                     for i in range(n)])  # fmt: skip
    return t if ok else None


def contraction_box(
    system: System, lyap: Lyapunov, lo0: np.ndarray, hi0: np.ndarray, *, halvings: int = 40
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]] | None:
    """``(lo, hi, info)``: the largest ``x_eq + 2^-k ([lo0, hi0] - x_eq)`` (``k >= 1``) on which
    the contraction argument of the module doc (3.) holds, or None (V not quadratic, ``f(x_eq)``
    or the Jacobians not enclosed finitely, ``0`` not in the enclosure of ``f(x_eq)`` (``x_eq``
    is then proved not to be an equilibrium: no claim about it), ``P J + J' P`` not proved
    negative definite, or ``K`` not inside the box). ``lyap`` may be whitened (:class:`roa.proof.Whitened`): the
    argument then runs in ``x`` on the base V and system (module doc). ``info`` holds
    ``equilibrium_radius`` (a bound of ``|x* - x_eq|_2``), ``equilibrium_level`` (``2 c0``,
    ``x*`` in ``{V <= 2 c0}``) and ``contraction_rate`` (``mu``)."""
    from roa.proof._exact import interval_negative_definite
    from roa.proof._interval import INTERVAL

    if system.time == "discrete":
        return None  # an argument about a flow; a map has the Hessian and lowest-order ones
    base_sys, base = system, lyap
    n = lyap.n
    M = [[Fraction(int(i == j)) for j in range(n)] for i in range(n)]
    frame = lyap.unwhitened()
    if frame is not None:
        base, base_sys = frame[0], frame[1]
        M = [[Fraction(float(v)) for v in row] for row in np.asarray(frame[2])]
    P = _quadratic_matrix(base)
    if P is None:
        return None
    x_eq = [Fraction(float(v)) for v in base.center]
    c = np.asarray(lyap.center, dtype=float)  # the frame's centre (0 when whitened)
    # W = z' Q z in the frame, Q = M' P M (exact); K = {V <= 2 c0} inside the frame's ball
    Q = [[sum((M[k][i] * P[k][l] * M[l][j] for k in range(n) for l in range(n)), Fraction(0))
          for j in range(n)] for i in range(n)]  # fmt: skip
    tQ, lamP_lo = _lower_eig(Q), _lower_eig(P)
    if tQ is None or lamP_lo is None:
        return None
    lam = max(sum(abs(v) for v in row) for row in P)  # >= lambda_max(P) (Gershgorin)
    try:
        with np.errstate(all="ignore"):
            f0 = base_sys.field(0.0, [Interval(np.array([float(v)])) for v in x_eq], INTERVAL)
    except (ArithmeticError, ValueError, TypeError):
        return None
    f0b = [_ivals(e) for e in f0]
    if any(b is None or not b[0] <= 0 <= b[1] for b in f0b):
        return None  # not enclosed, or x_eq proved not to be an equilibrium
    # beta^2 >= |P f(x_eq)|^2, exact
    beta2 = Fraction(0)
    for i in range(n):
        ends = [(P[i][k] * b[0], P[i][k] * b[1]) for k, b in enumerate(f0b) if b is not None]
        lo_i = sum((min(e) for e in ends), Fraction(0))
        hi_i = sum((max(e) for e in ends), Fraction(0))
        beta2 += max(abs(lo_i), abs(hi_i)) ** 2
    for k in range(1, halvings + 1):
        a, b = c + (lo0 - c) / 2.0**k, c + (hi0 - c) / 2.0**k
        # the exact hull X of x_eq + M [a, b]
        aq, bq = [Fraction(float(v)) for v in a], [Fraction(float(v)) for v in b]
        X_lo = [_down(x_eq[i] + sum((min(M[i][j] * aq[j], M[i][j] * bq[j]) for j in range(n)),
                                    Fraction(0))) for i in range(n)]  # fmt: skip
        X_hi = [_up(x_eq[i] + sum((max(M[i][j] * aq[j], M[i][j] * bq[j]) for j in range(n)),
                                  Fraction(0))) for i in range(n)]  # fmt: skip
        mu = _contraction_rate(base_sys, P, np.array(X_lo), np.array(X_hi),
                               interval_negative_definite)  # fmt: skip
        if mu is None:
            continue
        c0 = lam * 4 * beta2 / (mu * mu)  # lam r0^2, r0 = 2 beta / mu
        c1 = 2 * c0
        # K in the frame: z' Q z <= c1 gives |z|^2 <= c1 / tQ; inside [a, b] with room to spare
        room = min(min((c[i] - Fraction(float(a[i]))) ** 2, (Fraction(float(b[i])) - c[i]) ** 2)
                   for i in range(n))  # fmt: skip
        if not c1 / tQ < room:
            continue
        return a, b, {"local_proof": "contraction (f(x_eq) enclosed)", "local_scale": 2.0**-k,
                      "contraction_rate": float(mu), "equilibrium_level": _up(c1),
                      "equilibrium_radius": float(np.nextafter(np.sqrt(_up(c1 / lamP_lo)), np.inf))}  # fmt: skip
    return None


def _contraction_rate(
    system: System, P: list[list[Fraction]], lo: np.ndarray, hi: np.ndarray, negdef: Any
) -> Fraction | None:
    """A rational ``mu > 0`` with ``P J + J' P + mu I`` negative definite for every ``J`` in the
    interval Jacobian of the field on ``[lo, hi]`` (first-order jets, exact rational sums), or
    None."""
    n = len(P)
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        return None
    try:
        with np.errstate(all="ignore"):
            f = system.field(0.0, Jet.variables(lo[None, :], hi[None, :], order=1), JET)
    except (ArithmeticError, ValueError, TypeError):
        return None
    J: list[list[tuple[Fraction, Fraction]]] = []
    for fi in f:
        if isinstance(fi, Jet):
            row = [_ivals(g) for g in fi.g]
        elif _ivals(fi) is not None:
            row = [(Fraction(0), Fraction(0))] * n  # a constant component
        else:
            return None
        if any(r is None for r in row):
            return None
        J.append(row)  # type: ignore[arg-type]

    def prod(p: Fraction, iv: tuple[Fraction, Fraction]) -> tuple[Fraction, Fraction]:
        u, v = p * iv[0], p * iv[1]
        return (u, v) if u <= v else (v, u)

    S_lo = np.empty((n, n))
    S_hi = np.empty((n, n))
    S: list[list[tuple[Fraction, Fraction]]] = []
    for i in range(n):
        row_s = []
        for j in range(n):
            lo_ij, hi_ij = Fraction(0), Fraction(0)
            for k in range(n):  # (P J)_ij + (J' P)_ij = P_ik J_kj + J_ki P_kj
                for p, iv in ((P[i][k], J[k][j]), (P[k][j], J[k][i])):
                    if p:
                        u, v = prod(p, iv)
                        lo_ij, hi_ij = lo_ij + u, hi_ij + v
            row_s.append((lo_ij, hi_ij))
        S.append(row_s)
    mid = np.array([[float((S[i][j][0] + S[i][j][1]) / 2) for j in range(n)] for i in range(n)])
    w = float(np.linalg.eigvalsh(-0.5 * (mid + mid.T))[0])
    if not w > 0:
        return None
    mu = Fraction(w / 2)
    for i in range(n):
        for j in range(n):
            shift = mu if i == j else Fraction(0)
            S_lo[i, j] = _down(S[i][j][0] + shift)
            S_hi[i, j] = _up(S[i][j][1] + shift)
    return mu if negdef(S_lo, S_hi) else None


def _poly(system: System, lyap: Lyapunov) -> tuple[Any, list[Any]] | None:
    """V' as a sympy Poly in d (exact rational coefficients), or None if it is not polynomial."""
    import sympy as sp

    from roa.model._backend import namespace

    n = lyap.n
    d = sp.symbols(f"d0:{n}")
    c = [sp.Rational(float(v)) for v in lyap.center]
    x = [c[i] + d[i] for i in range(n)]
    try:
        Pq = lyap.quadratic_matrix()
        if Pq is not None and system.time == "continuous":
            f = system.field(0.0, x, namespace("sympy"))
            P = [[sp.Rational(float(Pq[i, j])) for j in range(n)] for i in range(n)]
            vd = 2 * sum(d[i] * P[i][j] * f[j] for i in range(n) for j in range(n))
        else:
            from roa.model._sympy_eval import exact_rationals

            # V' (or V(F(x)) - V(x) for a map) as the candidate writes it (a whitened V: grad V . f at x = c + M y with the
            # system's own field, never the float inverse of M)
            vd = exact_rationals(sp.sympify(lyap.vdot_expr(system, x, namespace("sympy"))))
        poly = sp.Poly(sp.expand(vd), *d)
    except (sp.PolynomialError, TypeError, ValueError):
        return None
    if not poly.domain.is_QQ and not poly.domain.is_ZZ:
        return None
    return poly, list(d)


def _face_max(terms: list[tuple[tuple[int, ...], Fraction]], n: int, budget: int) -> float | None:
    """An upper bound of max h(u) over the faces of [-1, 1]^n (None if the budget runs out
    before it is proved negative); h = sum c_a u^a."""
    coeffs = [(a, float(cf), cf) for a, cf in terms]

    def upper(lo: np.ndarray, hi: np.ndarray) -> float:
        total = Interval(0.0)
        for a, _cf_float, cf in coeffs:
            term = Interval.of(cf)
            for i, k in enumerate(a):
                if k:
                    term = term * Interval(lo[i], hi[i]) ** k
            total = total + term
        return float(np.atleast_1d(total.hi)[0])

    worst = -np.inf
    boxes = 0
    for k, sign in itertools.product(range(n), (-1.0, 1.0)):
        lo0, hi0 = -np.ones(n), np.ones(n)
        lo0[k] = hi0[k] = sign
        stack = [(lo0, hi0)]
        while stack:
            lo, hi = stack.pop()
            boxes += 1
            if boxes > budget:
                return None
            ub = upper(lo, hi)
            if ub < 0:
                worst = max(worst, ub)
                continue
            widths = np.where(np.arange(n) == k, 0.0, hi - lo)
            j = int(np.argmax(widths))
            if widths[j] < 1e-6:
                return None  # h_m >= 0 somewhere on the sphere (or too close to 0 to tell)
            mid = 0.5 * (lo[j] + hi[j])
            a_hi, b_lo = hi.copy(), lo.copy()
            a_hi[j] = mid
            b_lo[j] = mid
            stack += [(lo, a_hi), (b_lo, hi)]
    return worst


def higher_order_cube(
    system: System, lyap: Lyapunov, *, rho0: float = 0.5, budget: int = 20000
) -> tuple[float, dict[str, Any]] | None:
    """A cube radius ``rho`` (exact, rounded down) with ``V' < 0`` proved for
    ``0 < max_i |x_i - x_eq_i| <= rho``, or None. Returns ``(rho, info)``."""
    found = _cube(system, lyap, rho0=rho0, budget=budget)
    if found is None:
        return None
    rho, info = found
    r = float(rho)
    if Fraction(r) > rho:
        r = float(np.nextafter(r, 0.0))
    return r, info


def _cube(
    system: System, lyap: Lyapunov, *, rho0: float, budget: int
) -> tuple[Fraction, dict[str, Any]] | None:
    out = _poly(system, lyap)
    if out is None:
        return None
    poly, _ = out
    terms = [(tuple(int(v) for v in a), Fraction(int(c.p), int(c.q))) for a, c in poly.terms()]
    if not terms:
        return None
    m = min(sum(a) for a, _ in terms)
    if m < 2 or m % 2:
        return None  # a linear term (f(x_eq) != 0) or an odd lowest order: not negative definite
    low = [(a, c) for a, c in terms if sum(a) == m]
    high = [(a, c) for a, c in terms if sum(a) > m]
    top = _face_max(low, lyap.n, budget)
    if top is None or not top < 0:
        return None
    mu = Fraction(-top)
    r0 = Fraction(rho0)
    K = sum((abs(c) * r0 ** (sum(a) - m - 1) for a, c in high), Fraction(0))
    rho = r0 if K == 0 else min(r0, mu / (2 * K))
    return rho, {"degree": m, "mu": float(mu), "K": float(K), "cube_radius": float(rho)}
