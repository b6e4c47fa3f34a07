"""Closed loops from python-control models: :meth:`roa.System.from_control`, :func:`roa.closed_loop`.

python-control users hold a plant ``x' = f(t, x, u)`` (a ``control.NonlinearIOSystem`` whose
``updfcn(t, x, u, params)`` is written with numpy, or a ``control.StateSpace``) and a gain ``K``
from ``control.lqr``. roa analyses the closed loop ``x' = f(t, x, u_eq - K (x - x_eq))``.

Claims and assumptions:

* roa evaluates a field in several array namespaces (numpy, CasADi, sympy, mpmath, intervals), so a
  certificate needs the field as arithmetic and namespace functions. A numpy ``updfcn`` runs on
  numpy arrays only. :meth:`System.from_control` therefore *traces* it once: it is called on
  symbolic states and inputs (numpy object arrays whose elements record every operation as a sympy
  expression), and the expressions are compiled by :meth:`roa.System.from_sympy`. The analysed
  field is that expression; it is checked against ``updfcn`` on numpy at sample points (relative
  difference below :data:`AGREEMENT_RTOL`). Its float arithmetic is sympy's order, so values may
  differ from ``updfcn`` in the last bits.
* Tracing fails, with a message saying what to write instead, when ``updfcn`` branches on the
  state (``if x[0] > 0``, ``np.clip``, ``np.where``), converts it to a float (``float(x[0])``,
  ``math.sin``, writing into ``np.zeros(n)``) or calls a function outside numpy's ufuncs listed in
  :data:`roa.model._sympy_system.SUPPORTED`. The remedy is ``field=``: the same equations written once as
  ``field(t, x, u, xp)`` with ``xp.sin``, ``xp.cos``, ... (checked against ``updfcn`` the same way).
* The plant must be autonomous (roa analyses an equilibrium of ``x' = f(x)``): ``updfcn`` is
  called with a symbolic ``t`` at numeric sample states (an expression in ``t``, or a comparison or
  float conversion of one, is a dependence on ``t``) and with numeric ``t`` in
  :data:`TIME_PROBES` (its values must equal those at ``t = 0``). A dependence found either way is
  an input error; one that neither finds (a branch on ``t`` inside a function that rejects the
  symbol, taken only at times beyond the probes) is not detected.
* ``K``, ``equilibrium`` and ``u_eq`` must be real: a complex entry with a nonzero imaginary part
  is an input error (never its real part taken).
* ``params`` of the model are fixed at their values when the system is built.
* ``control`` is imported only by :meth:`System.from_control` (``pip install control``);
  :func:`roa.closed_loop` needs no python-control.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from roa.errors import RoaInputError
from roa.model._field_probe import MAX_OPS

#: Largest relative difference |f_roa - updfcn| / (1 + |updfcn|) accepted at the sample points.
AGREEMENT_RTOL = 1e-9
#: Sample points of the agreement check (normal around the equilibrium, standard deviation 0.5).
AGREEMENT_POINTS = 64
#: Times at which ``updfcn`` (and the analysed field) must give what it gives at ``t = 0``.
TIME_PROBES = (0.5, 1.5, 7.25, 100.0, 1e4)
#: Sample states (of the agreement points) at which the time probes run.
TIME_POINTS = 8

ControlField = Callable[..., Sequence[Any]]


@dataclass(frozen=True)
class LinearFeedback:
    """``u = u_eq - K (x - x_eq)`` as a function of the state components (picklable); the
    ``feedback`` of a closed loop built here. Zero gains are skipped, so an input depends only
    on the states its row of ``K`` names."""

    gain: tuple[tuple[float, ...], ...]
    x_eq: tuple[float, ...]
    u_eq: tuple[float, ...]

    def __call__(self, x: Any) -> list[Any]:
        us: list[Any] = []
        for row, u0 in zip(self.gain, self.u_eq, strict=True):
            u: Any = u0
            for j, k in enumerate(row):
                if k != 0.0:
                    d = x[j] - self.x_eq[j] if self.x_eq[j] != 0.0 else x[j]
                    u = u - k * d
            us.append(u)
        return us


@dataclass(frozen=True)
class ClosedLoopField:
    """``field(t, x, xp) = plant(t, x, u, xp)`` with ``u = u_eq - K (x - x_eq)`` (picklable)."""

    plant: ControlField
    gain: tuple[tuple[float, ...], ...]
    x_eq: tuple[float, ...]
    u_eq: tuple[float, ...]

    def inputs(self, x: Any) -> list[Any]:
        return LinearFeedback(self.gain, self.x_eq, self.u_eq)(x)

    def __call__(self, t: Any, x: Any, xp: Any) -> Sequence[Any]:
        return self.plant(t, x, self.inputs(x), xp)


def _real(value: Any, what: str) -> np.ndarray:
    """``value`` as a float array; a complex entry with a nonzero imaginary part is an input
    error. Raises TypeError or ValueError for what is not numbers."""
    arr = np.asarray(value)
    if arr.dtype.kind == "c" or arr.dtype == object:
        c = arr.astype(complex)
        if np.any(c.imag != 0):
            k = tuple(int(i) for i in np.argwhere(c.imag != 0)[0])
            raise RoaInputError(
                f"{what} must be real, got the complex entry {complex(c[k])!r} at index {k} (its "
                "imaginary part is never dropped)"
            )
        arr = c.real
    return np.asarray(arr, dtype=float)


def _matrix(value: Any, shape: tuple[int, int], what: str) -> tuple[tuple[float, ...], ...]:
    try:
        arr = _real(value, what)
    except RoaInputError:
        raise
    except (TypeError, ValueError):
        raise RoaInputError(f"{what} must be a {shape[0]}x{shape[1]} matrix of numbers") from None
    if arr.ndim == 1 and shape[0] == 1:
        arr = arr.reshape(1, -1)
    if arr.shape != shape or not np.all(np.isfinite(arr)):
        raise RoaInputError(
            f"{what} must be a finite {shape[0]}x{shape[1]} matrix (inputs x states), "
            f"got shape {arr.shape}"
        )
    return tuple(tuple(float(v) for v in row) for row in arr)


def _vector(value: Any, n: int, what: str) -> tuple[float, ...]:
    try:
        arr = np.zeros(n) if value is None else _real(value, what).reshape(-1)
    except RoaInputError:
        raise
    except (TypeError, ValueError):
        raise RoaInputError(f"{what} must be {n} finite numbers, got {value!r}") from None
    if arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise RoaInputError(f"{what} must be {n} finite numbers, got {value!r}")
    return tuple(float(v) for v in arr)


def build_closed_loop(
    system_cls: Any,
    field: ControlField,
    K: Any,
    states: Sequence[str],
    *,
    equilibrium: Sequence[float] | None = None,
    u_eq: Sequence[float] | None = None,
    name: str = "closed-loop",
    **kwargs: Any,
) -> Any:
    """:func:`roa.closed_loop` building an instance of ``system_cls``."""
    names = tuple(states)
    n = len(names)
    try:
        rows = _real(K, "K")
    except RoaInputError:
        raise
    except (TypeError, ValueError):
        raise RoaInputError(f"K must be a matrix of numbers (inputs x states), got {K!r}") from None
    m = rows.shape[0] if rows.ndim == 2 else 1
    gain = _matrix(K, (m, n), "K")
    x_eq = _vector(equilibrium, n, "equilibrium")
    u0 = _vector(u_eq, m, "u_eq")
    kwargs.setdefault("input_names", tuple(f"u{i}" for i in range(m)))
    if len(kwargs["input_names"]) != m:
        raise RoaInputError(
            f"input_names must name the {m} input(s) of K, got {tuple(kwargs['input_names'])!r}"
        )
    if m:
        kwargs.setdefault("feedback", LinearFeedback(gain, x_eq, u0))
    return system_cls(
        name=name,
        field=ClosedLoopField(field, gain, x_eq, u0),
        equilibrium=x_eq,
        state_names=names,
        **kwargs,
    )


#: The name of a closed loop's V when it is the Riccati solution of its LQR design.
RICCATI_NAME = "S of control.lqr (Riccati)"


def lqr_parts(K: Any, n: int) -> tuple[Any, Any]:
    """``(K, S)`` from what :func:`control.lqr` returns, ``(K, S, E)`` (``S`` the n x n
    Riccati solution, ``E`` the n closed-loop eigenvalues), or ``(K, None)`` for a gain alone."""
    if isinstance(K, tuple | list) and len(K) == 3:
        try:
            S_shape, E_ndim = np.shape(K[1]), np.ndim(K[2])
        except ValueError:  # ragged: not an lqr result
            return K, None
        if S_shape == (n, n) and E_ndim == 1 and np.ndim(K[0]) == 2:
            return K[0], K[1]
    return K, None


# --- python-control ------------------------------------------------------------------------


class Untraceable(RoaInputError):
    """An ``updfcn`` did something a symbolic trace cannot follow."""


class TimeDependent(RoaInputError):
    """An ``updfcn`` compared, or converted to a number, a value that depends on ``t``."""


class TraceTooLarge(RoaInputError):
    """An ``updfcn`` did more operations on the symbolic states than a field may
    (:data:`roa.model._field_probe.MAX_OPS`, the bound of a field written as ``field=``)."""


#: Work bound of one trace: the sizes (arguments) of the expressions it builds, summed. sympy
#: rebuilds a sum at each ``+`` (a sum of k terms written term by term costs ~k^2 / 2): 100,000
#: is a sum of ~450 terms built that way, seconds.
MAX_TRACE_WORK = 100_000
#: Operations and work recorded by the current trace (reset by :func:`_trace`).
_OPS = [0, 0]


@functools.lru_cache(maxsize=1)
def _time_symbol() -> Any:
    """The symbol standing for ``t`` when ``updfcn`` is probed for a dependence on time."""
    import sympy as sp

    return sp.Dummy("t")


#: numpy ufunc name -> sympy function name; numpy calls the method of that name on each element of
#: an object array (``np.sin(a)`` calls ``a[i].sin()``).
_UFUNCS = {
    "sin": "sin",
    "cos": "cos",
    "tan": "tan",
    "exp": "exp",
    "log": "log",
    "sqrt": "sqrt",
    "arctan": "atan",
    "arcsinh": "asinh",
    "arctanh": "atanh",
    "sinh": "sinh",
    "cosh": "cosh",
    "tanh": "tanh",
    "arcsin": "asin",
    "arccos": "acos",
    "absolute": "Abs",
}


def _expr(value: Any) -> Any:
    import sympy as sp

    if isinstance(value, Traced):
        return value.e
    if isinstance(value, bool | np.bool_):
        raise Untraceable(f"a boolean ({value!r}) enters the arithmetic")
    if isinstance(value, int | np.integer):
        return sp.Integer(int(value))
    if isinstance(value, float | np.floating):
        v = float(value)
        return sp.Integer(int(v)) if np.isfinite(v) and v == int(v) else sp.Float(v)
    raise Untraceable(f"an operand of type {type(value).__name__} ({value!r})")


class Traced:
    """A sympy expression standing for a value of ``updfcn``: arithmetic and numpy's ufuncs on
    object arrays build the expression; comparisons and conversions to numbers raise
    :class:`Untraceable` (the control flow would depend on the state)."""

    __slots__ = ("e",)
    __array_priority__ = 1000

    def __init__(self, e: Any) -> None:
        self.e = e
        _OPS[0] += 1
        _OPS[1] += 1 + len(getattr(e, "args", ()))
        if _OPS[0] > MAX_OPS or _OPS[1] > MAX_TRACE_WORK:
            raise TraceTooLarge(
                f"System.from_control: the updfcn does more than {MAX_OPS} operations on the "
                f"states, or builds expressions of more than {MAX_TRACE_WORK} terms in all (a "
                "sum of ~450 terms written term by term; allowed: at most these); simplify it "
                "or split the system"
            )

    def __add__(self, o: Any) -> Traced:
        return Traced(self.e + _expr(o))

    def __radd__(self, o: Any) -> Traced:
        return Traced(_expr(o) + self.e)

    def __sub__(self, o: Any) -> Traced:
        return Traced(self.e - _expr(o))

    def __rsub__(self, o: Any) -> Traced:
        return Traced(_expr(o) - self.e)

    def __mul__(self, o: Any) -> Traced:
        return Traced(self.e * _expr(o))

    def __rmul__(self, o: Any) -> Traced:
        return Traced(_expr(o) * self.e)

    def __truediv__(self, o: Any) -> Traced:
        return Traced(self.e / _expr(o))

    def __rtruediv__(self, o: Any) -> Traced:
        return Traced(_expr(o) / self.e)

    def __pow__(self, o: Any) -> Traced:
        return Traced(self.e ** _expr(o))

    def __rpow__(self, o: Any) -> Traced:
        return Traced(_expr(o) ** self.e)

    def __neg__(self) -> Traced:
        return Traced(-self.e)

    def __pos__(self) -> Traced:
        return self

    def __abs__(self) -> Traced:
        import sympy as sp

        return Traced(sp.Abs(self.e))

    def __getattr__(self, name: str) -> Any:
        if name in _UFUNCS:
            import sympy as sp

            fn = getattr(sp, _UFUNCS[name])
            return lambda: Traced(fn(self.e))
        raise AttributeError(name)  # numpy then names the ufunc it could not apply

    def _refuse(self, *_: Any) -> Any:
        if _time_symbol() in self.e.free_symbols:
            raise TimeDependent(
                f"a comparison or a conversion to a number of {self.e} ({_time_symbol()} is t)"
            )
        raise Untraceable(
            "a comparison or a conversion to a number (if/np.where/np.clip/float()/math.*/"
            "assignment into a float array) depends on the state"
        )

    __lt__ = __le__ = __gt__ = __ge__ = _refuse
    __float__ = __int__ = __bool__ = __index__ = __complex__ = _refuse

    def __eq__(self, other: object) -> bool:
        return bool(self._refuse())

    __hash__ = None  # type: ignore[assignment]


def _labels(labels: Sequence[str], prefix: str = "x") -> tuple[str, ...]:
    """python-control's labels as identifiers (``x[0]`` -> ``x0``), unique, else ``x0, x1, ...``
    (``prefix`` instead of ``x``)."""
    names = tuple(re.sub(r"\W", "", str(s)) for s in labels)
    ok = all(s.isidentifier() for s in names) and len(set(names)) == len(names)
    return names if ok else tuple(f"{prefix}{i}" for i in range(len(labels)))


def _design_lqr(sys: Any, lqr: Any, x_eq: Sequence[float], u_eq: Sequence[float],
                params: Mapping[str, Any]) -> tuple[Any, Any, Any]:  # fmt: skip
    """``control.lqr`` on ``sys`` linearised at ``(x_eq, u_eq)``: ``(K, S, E)``."""
    import control

    try:
        Q, R = lqr
    except (TypeError, ValueError):
        raise RoaInputError(f"System.from_control: lqr must be (Q, R), got {lqr!r}") from None
    linear = sys.linearize(list(x_eq), list(u_eq), params=dict(params))
    try:
        return control.lqr(linear, Q, R)  # type: ignore[no-any-return]
    except Exception as exc:  # noqa: BLE001 - python-control's own message (shapes, not stabilisable)
        raise RoaInputError(f"System.from_control: lqr=(Q, R): control.lqr failed: {exc}") from None


def _trace(sys: Any, params: Mapping[str, Any], x_eq: Sequence[float], u_eq: Sequence[float],
           gain: Sequence[Sequence[float]], names: Sequence[str]) -> list[Any]:  # fmt: skip
    """The closed loop's right-hand side as sympy expressions of the state symbols ``names``."""
    import sympy as sp

    syms = [sp.Symbol(s) for s in names]
    _OPS[:] = [0, 0]
    x = np.array([Traced(s) for s in syms], dtype=object)
    loop = ClosedLoopField(_no_plant, tuple(map(tuple, gain)), tuple(x_eq), tuple(u_eq))
    u = np.array(loop.inputs(list(x)), dtype=object)
    u = np.array([v if isinstance(v, Traced) else Traced(_expr(v)) for v in u], dtype=object)
    try:
        out = sys.updfcn(0.0, x, u, dict(params))
    except (Untraceable, TraceTooLarge):
        raise
    except Exception as exc:  # anything the updfcn raised on symbolic arguments
        raise Untraceable(f"it raised {type(exc).__name__}: {exc}") from exc
    values = list(np.asarray(out, dtype=object).reshape(-1))
    if len(values) != len(names):
        raise RoaInputError(
            f"System.from_control: updfcn returned {len(values)} components for {len(names)} states"
        )
    return [_expr(v) if not isinstance(v, sp.Basic) else v for v in values]


def _check_agreement(system: Any, sys: Any, params: Mapping[str, Any],
                     inputs: Callable[[list[float]], list[Any]], origin: str) -> None:  # fmt: skip
    """``system.f`` against ``sys.updfcn`` under the same feedback at sample points (numpy), at
    ``t = 0`` and, at the first :data:`TIME_POINTS` of them, at the times of :data:`TIME_PROBES`
    (so a ``field=`` that depends on ``t`` where the plant does not is refused)."""
    X = _sample_states(system.x_eq, system.n)
    for k, x in enumerate(X):
        u = np.array(inputs(list(x)), dtype=float)
        for t in (0.0, *(TIME_PROBES if k < TIME_POINTS else ())):
            with np.errstate(all="ignore"):
                ref = np.asarray(sys.updfcn(t, x, u, dict(params)), dtype=float).reshape(-1)
                got = system.f(x, t)
            if not (np.all(np.isfinite(ref)) and np.all(np.isfinite(got))):
                continue
            err = np.max(np.abs(got - ref) / (1.0 + np.abs(ref)))
            if not err <= AGREEMENT_RTOL:
                raise RoaInputError(
                    f"System.from_control: the {origin} differs from {sys.name}'s updfcn at "
                    f"t = {t}, x = {x.tolist()}, u = {u.tolist()}: {got.tolist()} vs "
                    f"{ref.tolist()} (relative {err:.2e} > {AGREEMENT_RTOL:g}); write the same "
                    "equations"
                )


def _sample_states(x_eq: Any, n: int) -> np.ndarray:
    """The agreement check's states: normal around ``x_eq``, standard deviation 0.5, seed 0."""
    rng = np.random.default_rng(0)
    return np.asarray(x_eq, dtype=float) + 0.5 * rng.standard_normal((AGREEMENT_POINTS, n))


def _time_varying(sys: Any, params: Mapping[str, Any], X: np.ndarray,
                  inputs: Callable[[list[float]], list[Any]]) -> str | None:  # fmt: skip
    """How ``sys.updfcn`` under the feedback depends on ``t`` at the states ``X``, or None when no
    dependence shows: called with a symbolic ``t`` (a result in ``t``, or a comparison or float
    conversion of one, is a dependence; at a state where it raises anything else the numeric
    probes decide),
    then with each time of :data:`TIME_PROBES` (a value other than at ``t = 0``)."""
    _OPS[:] = [0, 0]
    T = Traced(_time_symbol())
    for x in X:
        u = np.array(inputs(list(x)), dtype=float)
        try:
            out = sys.updfcn(T, x.copy(), u.copy(), dict(params))
        except TimeDependent as exc:
            return f"at x = {x.tolist()}: {exc}"
        except TraceTooLarge:
            raise
        except Exception:  # noqa: BLE001 - e.g. a library call that rejects the symbol
            continue
        for i, v in enumerate(np.asarray(out, dtype=object).reshape(-1)):
            if isinstance(v, Traced) and _time_symbol() in v.e.free_symbols:
                return f"component {i} at x = {x.tolist()} is {v.e} (t is the time)"
    for x in X:
        u = np.array(inputs(list(x)), dtype=float)
        with np.errstate(all="ignore"):
            ref = np.asarray(sys.updfcn(0.0, x.copy(), u.copy(), dict(params)), dtype=float)
            for t in TIME_PROBES:
                try:
                    got = np.asarray(sys.updfcn(t, x.copy(), u.copy(), dict(params)), dtype=float)
                except Exception as exc:  # noqa: BLE001 - it fails at t but not at t = 0
                    return f"at x = {x.tolist()} it raised {type(exc).__name__} at t = {t}"
                same = np.isclose(got.reshape(-1), ref.reshape(-1), rtol=1e-12, atol=0.0,
                                  equal_nan=True)  # fmt: skip
                if not same.all():
                    return (f"at x = {x.tolist()} it gives {ref.reshape(-1).tolist()} at t = 0 "
                            f"and {got.reshape(-1).tolist()} at t = {t}")  # fmt: skip
    return None


def from_control(
    system_cls: Any,
    sys: Any,
    K: Any = None,
    *,
    field: ControlField | None = None,
    equilibrium: Sequence[float] | None = None,
    u_eq: Sequence[float] | None = None,
    params: Mapping[str, Any] | None = None,
    name: str | None = None,
    lqr: tuple[Any, Any] | None = None,
    **kwargs: Any,
) -> Any:
    """The closed loop of a python-control model under ``u = u_eq - K (x - x_eq)``; see
    :meth:`roa.System.from_control`."""
    try:
        import control
    except ImportError:
        raise RoaInputError(
            "System.from_control needs python-control: pip install control"
        ) from None
    if not isinstance(sys, control.NonlinearIOSystem):
        raise RoaInputError(
            f"System.from_control: sys must be a control.NonlinearIOSystem or StateSpace, got "
            f"{type(sys).__name__}"
        )
    if not sys.isctime():
        raise RoaInputError(
            f"System.from_control: {sys.name} is discrete-time (dt={sys.dt}); roa analyses "
            "continuous-time systems (dt=0)"
        )
    n, m = sys.nstates, sys.ninputs
    names = _labels(sys.state_labels)
    kwargs.setdefault("input_names", _labels(sys.input_labels, "u"))
    x_eq = _vector(equilibrium, n, "equilibrium")
    u0 = _vector(u_eq, m, "u_eq")
    all_params = {**(sys.params or {}), **(params or {})}
    if lqr is not None:
        if K is not None:
            raise RoaInputError("System.from_control: give K or lqr=(Q, R), not both")
        K = _design_lqr(sys, lqr, x_eq, u0, all_params)
    K, S = lqr_parts(K, n)
    if S is not None and kwargs.get("lyapunov") is None:
        kwargs["lyapunov"] = _matrix(S, (n, n), "S (control.lqr's Riccati solution)")
        kwargs["meta"] = {"lyapunov_name": RICCATI_NAME, **(kwargs.get("meta") or {})}
    if K is None:
        K = np.zeros((m, n))
    gain = _matrix(K, (m, n), "K")
    label = name or sys.name
    loop = ClosedLoopField(_no_plant, gain, x_eq, u0)
    if not isinstance(sys, control.StateSpace):
        X = _sample_states(x_eq, n)[:TIME_POINTS]
        how = _time_varying(sys, all_params, np.vstack([x_eq, X]), loop.inputs)
        if how is not None:
            raise RoaInputError(
                f"System.from_control: {sys.name}'s updfcn depends on the time t ({how}); roa "
                "analyses the equilibrium of an autonomous closed loop x' = f(x), so a "
                "time-varying plant is refused (a field frozen at t = 0 would be certified for "
                "trajectories it does not have). Remove t from the updfcn, or simulate it as "
                "roa.System(..., time_varying=True)"
            )
    if field is not None:
        system = build_closed_loop(
            system_cls, field, gain, names, equilibrium=x_eq, u_eq=u0, name=label, **kwargs
        )
        if not isinstance(sys, control.StateSpace):
            _check_agreement(system, sys, all_params, loop.inputs, "field=")
        return system
    if isinstance(sys, control.StateSpace):
        plant = AffinePlant(_matrix(sys.A, (n, n), "sys.A"), _matrix(sys.B, (n, m), "sys.B"))
        return build_closed_loop(
            system_cls, plant, gain, names, equilibrium=x_eq, u_eq=u0, name=label, **kwargs
        )
    try:
        exprs = _trace(sys, all_params, x_eq, u0, gain, names)
        if m:
            kwargs.setdefault("feedback", LinearFeedback(gain, x_eq, u0))
        system = system_cls.from_sympy(exprs, names, equilibrium=x_eq, name=label, **kwargs)
    except TraceTooLarge:
        raise
    except RoaInputError as exc:  # Untraceable, or a function from_sympy cannot evaluate
        raise RoaInputError(
            f"System.from_control: {sys.name}'s updfcn cannot be traced into an expression roa "
            f"can evaluate with intervals, CasADi and sympy ({exc}). A numpy updfcn runs on "
            "numpy only; pass the same equations as field=lambda t, x, u, xp: (...) written "
            "with arithmetic and xp.sin, xp.cos, xp.sqrt, ... (roa checks it against the "
            "updfcn)"
        ) from None
    _check_agreement(system, sys, all_params, loop.inputs, "traced field")
    return system


def _no_plant(t: Any, x: Any, u: Any, xp: Any) -> tuple[Any, ...]:
    return ()


@dataclass(frozen=True)
class AffinePlant:
    """``x' = A x + B u`` of a ``control.StateSpace`` as a plant ``field(t, x, u, xp)``
    (zero entries skipped; picklable)."""

    A: tuple[tuple[float, ...], ...]
    B: tuple[tuple[float, ...], ...]

    def __call__(self, t: Any, x: Any, u: Any, xp: Any) -> tuple[Any, ...]:
        return tuple(_dot(a, x) + _dot(b, u) for a, b in zip(self.A, self.B, strict=True))


def _dot(row: Sequence[float], v: Sequence[Any]) -> Any:
    out: Any = 0.0
    for a, vi in zip(row, v, strict=True):
        if a != 0.0:
            out = out + a * vi
    return out
