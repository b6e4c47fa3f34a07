"""The system abstraction: a vector field (or a map) written once for every array namespace.

A continuous-time system is ``x' = f(t, x)``; a discrete-time one is ``x+ = F(x)``
(:meth:`System.discrete`, or :func:`roa.model.discretise` for the Euler / RK4 step of a
continuous one). Every analysis reads a system through the same few members, whatever its time:
:attr:`System.time`, :attr:`System.dynamics` (``f`` or ``F``), :meth:`System.residual_expr`
(``f(x)`` or ``F(x) - x``: zero at an equilibrium) and :meth:`System.decrease_expr` (the
function whose negativity a Lyapunov certificate proves: ``V' = grad V . f`` or
``Delta V = V(F(x)) - V(x)``). The ``field`` of a discrete-time system is a
:class:`NoVectorField` that refuses to be called, so an analysis written for vector fields fails
with a clear error instead of reading the map as a derivative.

A field is ``field(t, x, xp)``, or ``field(t, x, xp, p)`` for a system that declares parameters
(``params``: name -> value; ``p`` is a read-only mapping with attribute access, ``p.mu`` or
``p["mu"]``). :meth:`System.with_params` gives the same system with other parameter values.

A parameter known only to lie in a range is declared in ``parameters`` (name ->
``(low, nominal, high)``): the system then stands for the whole family, ``p`` holds the nominal
values where one value is needed (simulation), :meth:`System.at` fixes values and
:meth:`System.nominal` fixes them all at their nominal values. Analyses that prove (``roa.certify``)
hold for every parameter in the box.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from roa.errors import RoaInputError
from roa.model._backend import NP

Field = Callable[..., Sequence[Any]]
Margin = Callable[[Any, Any], Any]

#: Keys of ``meta`` that older systems used for what are now typed fields.
_TYPED_META = ("numba", "numba_fast", "analysis_coords")


class Uncertain(NamedTuple):
    """The range of an uncertain parameter: ``low <= nominal <= high``."""

    low: float
    nominal: float
    high: float

    @property
    def width(self) -> float:
        return self.high - self.low


#: The largest parameter magnitude: a range's width and midpoint, and a parameter times a
#: squared state of moderate size, stay finite doubles (``1e308..1.79e308`` would not).
MAX_PARAM = 1e150


def _bounded(name: str, value: Any, what: str) -> None:
    if not abs(value) <= MAX_PARAM:
        from roa.numparse import shown

        raise RoaInputError(
            f"{what}[{name!r}] = {shown(value)} is out of range: parameter values must be finite with "
            f"magnitude at most {MAX_PARAM:g} (the arithmetic of ranges and fields must not "
            "overflow)"
        )


def _uncertain(name: str, value: Any) -> Uncertain:
    """``value`` as the range of parameter ``name``, or an error naming it and the rule."""
    try:
        low, nominal, high = (float(v) for v in value)
        ok = all(not isinstance(v, bool) and isinstance(v, int | float | np.floating)
                 for v in value)  # fmt: skip
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok or not all(np.isfinite(v) for v in (low, nominal, high)):
        raise RoaInputError(
            f"System.parameters[{name!r}] must be three finite numbers (low, nominal, high), "
            f"got {value!r}"
        )
    if not low <= nominal <= high or not low < high:
        raise RoaInputError(
            f"System.parameters[{name!r}] needs low <= nominal <= high and low < high, got "
            f"({low!r}, {nominal!r}, {high!r})"
        )
    for v in (low, nominal, high):
        _bounded(name, v, "System.parameters")
    return Uncertain(low, nominal, high)


class Params(Mapping[str, float]):
    """A system's parameter values: a read-only mapping with attribute access (``p.mu``)."""

    __slots__ = ("_values",)
    _values: dict[str, float]

    def __init__(self, values: Mapping[str, Any]) -> None:
        object.__setattr__(self, "_values", dict(values))

    def __getitem__(self, key: str) -> float:
        return self._values[key]

    def __getattr__(self, key: str) -> float:
        try:
            return self._values[key]
        except KeyError:
            raise AttributeError(
                f"no parameter {key!r} (declared: {sorted(self._values)})"
            ) from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __setattr__(self, key: str, value: Any) -> None:
        raise AttributeError("parameters are read-only: use System.with_params")

    def __repr__(self) -> str:
        return f"Params({self._values!r})"

    def __hash__(self) -> int:
        return hash(tuple(sorted(self._values.items())))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Mapping) and dict(self._values) == dict(other)

    def __reduce__(self) -> tuple[Any, ...]:
        return (Params, (self._values,))


@dataclass(frozen=True)
class BoundField:
    """The three-argument field of a system with parameters (picklable)."""

    func: Callable[..., Sequence[Any]]
    params: Params

    def __call__(self, t: Any, x: Any, xp: Any) -> Sequence[Any]:
        return self.func(t, x, xp, self.params)


@dataclass(frozen=True)
class NoVectorField:
    """The ``field`` of a discrete-time system: calling it is an error naming the system (an
    analysis that needs a vector field does not apply to a map)."""

    system: str

    def __call__(self, *args: Any) -> Sequence[Any]:
        raise RoaInputError(
            f"system {self.system!r} is discrete-time (x+ = F(x)): it has no vector field, and "
            "this analysis is for continuous-time systems only (the discrete-time analyses: "
            "level_search, certify with the interval validator, basin, simulate)"
        )


#: The two kinds of time of a system (:attr:`System.time`).
TIMES = ("continuous", "discrete")


@dataclass(frozen=True)
class System:
    """A (possibly time-varying) ODE ``x' = f(t, x)``, or a map ``x+ = F(x)`` (:meth:`discrete`),
    with an equilibrium (a fixed point of a map) and a domain.

    Parameters
    ----------
    name : str
        Short identifier.
    field : callable
        ``field(t, x, xp) -> sequence of n components`` (a :class:`NoVectorField` for a map). ``x`` is indexable by component (numpy
        arrays of any common shape, CasADi or sympy symbols); ``xp`` is a namespace from
        :mod:`roa.model._backend`. Use only ``xp`` functions and arithmetic.
    equilibrium : sequence of float
        The equilibrium studied (``None`` for a time-varying run without one).
    state_names, state_units : tuple of str
        Names and units of the states, for CLI parsing and axis labels.
    margin : callable, optional
        ``margin(x, xp) -> array``: positive inside the domain, zero on its boundary. ``None`` means
        the whole space.
    domain_description : str
        Human-readable description of the domain, used in error messages.
    time_varying : bool
        True for a run that tracks a reference (no equilibrium analysis).
    lyapunov : n x n matrix, optional
        The quadratic Lyapunov candidate ``(x - x_eq)' P (x - x_eq)`` that comes with the system (a
        paper's or a benchmark's); :func:`roa.default_lyapunov` uses it, else solves
        ``A'P + PA = -I``.
    norm : n x n matrix, optional
        Positive-definite ``S`` of the system's natural norm ``(x - x_eq)' S (x - x_eq)``: the
        ``"ball"`` shape of :func:`roa.level_search` (default: the identity).
    params : mapping, optional
        Declared parameters (name -> float): the field is then ``field(t, x, xp, p)``.
    parameters : mapping, optional
        Uncertain parameters (name -> ``(low, nominal, high)``, ``low < high``): the field is
        ``field(t, x, xp, p)`` with ``p`` holding every parameter (the nominal values of these).
        Proofs hold for the whole box; :meth:`at` fixes values.
    numba : callable, optional
        Factory of the batch integrator's compiled field (``() -> (field, margin, params)``,
        the cfunc protocol of :mod:`roa.integration._integrator`), for this system's parameter
        values: :meth:`at`, :meth:`with_params` and :meth:`with_ranges` rebuild it for other values
        with ``factory.with_params(values)`` when it has that method, else drop it (the numpy
        backend then runs). ``dataclasses.replace(system, params=...)`` does neither: use those
        methods.
    numba_fast : callable, optional
        Factory of the njit fast path of the same field (:mod:`roa.integration._integrator`).
    analysis_coords : object, optional
        Coordinates that certificates of this system may live in (terminal sets,
        :mod:`roa.integration._terminal`): ``names``, ``systems`` (certified system name ->
        coordinates name), ``__call__(name)`` (the numpy map) and ``system(name)``.
    input_names, input_units : tuple of str
        Names and units of the inputs ``u`` of a closed loop (``from_control`` takes the names
        from the model's input labels), for axis labels and JSON.
    feedback : callable, optional
        ``feedback(x) -> sequence of m values``: the inputs the loop applies at the state ``x``
        (components, numpy), e.g. ``u = u_eq - K (x - x_eq)``; ``roa.simulate`` reports and plots
        ``u(t)`` with it. It plays no part in any analysis (the field already holds it); not
        compared.
    map : callable, optional
        For a discrete-time system ``x+ = F(x)``: ``map(t, x, xp) -> sequence of n components``
        (``map(t, x, xp, p)`` with parameters), the next state, written like a field; ``t`` is
        the time ``k * sample_time`` of step ``k``. ``field`` is then a :class:`NoVectorField`
        (build one with :meth:`discrete`).
    sample_time : float, optional
        The time one step of the map stands for (a discretised plant's ``h``; default 1: time
        counts steps). Monte Carlo runs count ``t_final`` in this unit.
    meta : dict
        Anything else (notes for reports); not compared. ``meta["lyapunov_name"]`` names the
        candidate of ``lyapunov`` (e.g. the Riccati solution of an LQR design). Older systems' ``"numba"``,
        ``"numba_fast"`` and ``"analysis_coords"`` entries are taken as the typed fields.
    """

    name: str
    field: Field
    equilibrium: tuple[float, ...] | None
    state_names: tuple[str, ...]
    state_units: tuple[str, ...] = ()
    margin: Margin | None = None
    domain_description: str = "R^n"
    time_varying: bool = False
    lyapunov: Any = None  # stored as a tuple of rows
    norm: Any = None  # stored as a tuple of rows
    params: Any = None  # stored as Params (nominal values of the uncertain ones included)
    parameters: Any = None  # stored as a read-only mapping name -> Uncertain (None: none)
    numba: Any = dataclasses.field(default=None, compare=False, hash=False, repr=False)
    numba_fast: Any = dataclasses.field(default=None, compare=False, hash=False, repr=False)
    analysis_coords: Any = dataclasses.field(default=None, compare=False, hash=False, repr=False)
    meta: dict[str, Any] = dataclasses.field(default_factory=dict, compare=False, hash=False)
    input_names: tuple[str, ...] = ()
    input_units: tuple[str, ...] = ()
    feedback: Any = dataclasses.field(default=None, compare=False, hash=False, repr=False)
    map: Field | None = None
    sample_time: float | None = None

    def __post_init__(self) -> None:
        self._check_time()
        self._bind_params()
        self._check_labels()
        if any(k in self.meta for k in _TYPED_META):
            for key in _TYPED_META:
                if key in self.meta and getattr(self, key) is None:
                    object.__setattr__(self, key, self.meta[key])
            rest = {k: v for k, v in self.meta.items() if k not in _TYPED_META}
            object.__setattr__(self, "meta", rest)
        for name in ("lyapunov", "norm"):
            value = getattr(self, name)
            if value is not None:
                from roa import numparse

                arr = numparse.array(value, f"System.{name}")
                if arr.shape != (self.n, self.n) or not np.all(np.isfinite(arr)):
                    raise RoaInputError(
                        f"System.{name} must be a finite {self.n}x{self.n} matrix, got shape "
                        f"{arr.shape}"
                    )
                object.__setattr__(self, name, tuple(tuple(float(v) for v in row) for row in arr))

    def _check_labels(self) -> None:
        """Names and units as tuples of strings of the right lengths (units may be omitted)."""
        for attr in ("state_names", "state_units", "input_names", "input_units"):
            value = getattr(self, attr)
            if isinstance(value, str) or not all(isinstance(v, str) for v in value):
                raise RoaInputError(f"System.{attr} must be a sequence of strings, got {value!r}")
            object.__setattr__(self, attr, tuple(value))
        if self.state_units and len(self.state_units) != self.n:
            raise RoaInputError(
                f"System.state_units must give one unit per state ({self.n}: "
                f"{', '.join(self.state_names)}), got {len(self.state_units)}"
            )
        m = len(self.input_names)
        if self.input_units and len(self.input_units) != m:
            raise RoaInputError(
                f"System.input_units must give one unit per input ({m}: "
                f"{', '.join(self.input_names) or 'no input_names'}), got {len(self.input_units)}"
            )
        if self.feedback is not None and not callable(self.feedback):
            raise RoaInputError(
                f"System.feedback must be callable feedback(x) -> inputs, got {self.feedback!r}"
            )

    def inputs(self, x: np.ndarray) -> np.ndarray:
        """The inputs ``u`` that ``feedback`` applies at states ``x`` (shape ``(..., n)``), shape
        ``(..., m)``; an error for a system without ``feedback``."""
        if self.feedback is None:
            raise RoaInputError(f"system {self.name!r} has no feedback (no inputs to report)")
        x = np.asarray(x, dtype=float)
        comps = [x[..., i] for i in range(self.n)]
        out = [np.asarray(u, dtype=float) for u in self.feedback(comps)]
        return np.stack(np.broadcast_arrays(*out, x[..., 0])[:-1], axis=-1)

    @classmethod
    def from_sympy(
        cls,
        exprs: Any,
        states: Sequence[Any],
        *,
        equilibrium: Sequence[float] | None = None,
        parameters: Mapping[Any, Sequence[float]] | None = None,
        params: Mapping[Any, float] | None = None,
        name: str = "sympy-system",
        state_units: Sequence[str] = (),
        **kwargs: Any,
    ) -> System:
        """The system ``x' = exprs(x)`` from sympy expressions of the state symbols.

        Parameters
        ----------
        exprs : sequence or sympy Matrix of sympy expressions
            One per state, in the symbols of ``states`` and of the parameters.
        states : sequence of sympy Symbol or str
            The state symbols, in order; their names become ``state_names``.
        equilibrium : sequence of float, optional
            The equilibrium studied (default: the origin).
        parameters : mapping, optional
            Uncertain parameters: symbol or name -> ``(low, nominal, high)`` (as ``System``).
        params : mapping, optional
            Fixed parameters: symbol or name -> value (as ``System``; ``with_params`` changes them).
        name, state_units
            As :class:`System`.
        **kwargs
            As :class:`System` (``margin``, ``lyapunov``, ``norm``, ``domain_description``, ...).

        The field is compiled once (:mod:`roa.model._sympy_system`) and runs in every namespace: numpy,
        CasADi, sympy, mpmath, intervals and jets (rationals enclosed). An unsupported function
        or symbol is an error naming it.

        Examples
        --------
        >>> import sympy as sp
        >>> x1, x2, mu = sp.symbols("x1 x2 mu")
        >>> vdp = System.from_sympy([-x2, x1 + mu * (x1**2 - 1) * x2], [x1, x2], params={mu: 1.0})
        >>> vdp.f([0.5, 0.5]).tolist()
        [-0.5, 0.125]
        """
        from roa.model._sympy_system import system_from_sympy

        return system_from_sympy(cls, exprs, states, equilibrium=equilibrium, parameters=parameters,
                                 params=params, name=name, state_units=state_units,
                                 **kwargs)  # fmt: skip

    @classmethod
    def from_control(
        cls,
        sys: Any,
        K: Any = None,
        *,
        field: Callable[..., Sequence[Any]] | None = None,
        equilibrium: Sequence[float] | None = None,
        u_eq: Sequence[float] | None = None,
        params: Mapping[str, Any] | None = None,
        name: str | None = None,
        lqr: tuple[Any, Any] | None = None,
        **kwargs: Any,
    ) -> System:
        """The closed loop of a python-control model under ``u = u_eq - K (x - x_eq)``.

        Parameters
        ----------
        sys : control.NonlinearIOSystem or control.StateSpace
            The continuous-time plant ``x' = updfcn(t, x, u, params)``; its state labels become
            ``state_names`` (``x[0]`` -> ``x0``).
        K : m x n matrix or the result of ``control.lqr``, optional
            The gain, e.g. ``control.lqr(sys.linearize(x_eq, u_eq), Q, R)[0]`` (default zero:
            the open loop, for a model without inputs). Given the whole result ``(K, S, E)`` of
            ``control.lqr``, the Riccati solution ``S`` becomes the system's Lyapunov candidate
            ``(x - x_eq)' S (x - x_eq)`` (``lyapunov``; :func:`roa.default_lyapunov` then uses it
            instead of ``A'P + PA = -I``): it is the LQR loop's own cost-to-go, and its level
            sets follow the loop's slow directions.
        field : callable, optional
            ``field(t, x, u, xp)``: the same equations written with arithmetic and ``xp``
            functions. Without it, a ``NonlinearIOSystem``'s numpy ``updfcn`` is traced
            symbolically; an ``updfcn`` that branches on the state or leaves numpy's ufuncs
            cannot be, and the error says to pass ``field=``.
        equilibrium, u_eq : sequence of float, optional
            ``x_eq`` and the input holding the plant there (default zero).
        params : mapping, optional
            Values overriding ``sys.params`` (fixed when the system is built).
        name : str, optional
            Default: ``sys.name``.
        lqr : (Q, R), optional
            Instead of ``K``: the gain of ``control.lqr`` on ``sys`` linearised at
            ``(x_eq, u_eq)`` with these weights, and its ``S`` as the candidate (as above).
        **kwargs
            As :class:`System` (``state_units``, ``input_units``, ``margin``, ``lyapunov``,
            ...). ``input_names`` default to the model's input labels; ``feedback`` is the
            control law, so ``roa.simulate`` reports and plots ``u(t)``.

        The analysed field (traced or ``field=``) is checked against ``updfcn`` on numpy at
        sample points around ``x_eq`` (:mod:`roa.model._control_system`); a difference is an error.
        Needs python-control (``pip install control``, or ``pip install ".[control]"`` in a clone).

        Examples
        --------
        >>> import control, numpy as np
        >>> def upd(t, x, u, params):
        ...     return [x[1], -np.sin(x[0]) - 0.1 * x[1] + u[0]]
        >>> plant = control.nlsys(upd, None, inputs=1, states=2, name="pendulum")
        >>> K, _, _ = control.lqr(plant.linearize([0, 0], [0]), np.eye(2), np.eye(1))
        >>> closed = System.from_control(plant, K)
        >>> closed.state_names
        ('x0', 'x1')
        """
        from roa.model._control_system import from_control

        return from_control(cls, sys, K, field=field, equilibrium=equilibrium, u_eq=u_eq,
                            params=params, name=name, lqr=lqr, **kwargs)  # fmt: skip

    @classmethod
    def discrete(
        cls,
        map: Field,  # noqa: A002 - the mathematical name
        *,
        name: str,
        equilibrium: Sequence[float] | None,
        state_names: Sequence[str],
        sample_time: float | None = None,
        **kwargs: Any,
    ) -> System:
        """The discrete-time system ``x+ = F(x)`` with ``F = map(t, x, xp)`` (``map(t, x, xp, p)``
        with ``params`` / ``parameters``), written against the array namespace ``xp`` like a
        field.

        ``equilibrium`` is a fixed point ``F(x_eq) = x_eq``; ``sample_time`` the time one step
        stands for (default 1). ``**kwargs`` as :class:`System` (``margin``, ``lyapunov``,
        ``norm``, ``params``, ``parameters``, ``state_units``, ...).

        Examples
        --------
        >>> def F(t, x, xp):
        ...     return [0.5 * x[0] + x[1] ** 2, 0.5 * x[1]]
        >>> sys_ = System.discrete(F, name="toy", equilibrium=(0.0, 0.0), state_names=("a", "b"))
        >>> sys_.time, sys_.step([[1.0, 2.0]]).tolist()
        ('discrete', [[4.5, 1.0]])
        """
        eq = None if equilibrium is None else tuple(float(v) for v in equilibrium)
        return cls(name=name, field=NoVectorField(name), equilibrium=eq,
                   state_names=tuple(state_names), map=map, sample_time=sample_time,
                   **kwargs)  # fmt: skip

    def _check_time(self) -> None:
        """A discrete-time system has a ``map`` and a :class:`NoVectorField` as its field."""
        if self.map is None:
            if self.sample_time is not None:
                raise RoaInputError(
                    f"System.sample_time is for discrete-time systems (a map); system "
                    f"{self.name!r} has a vector field"
                )
            if self.field is None or isinstance(self.field, NoVectorField):
                raise RoaInputError(
                    f"system {self.name!r}: give a vector field (field=) or a map (map=, "
                    "System.discrete)"
                )
            return
        if not callable(self.map):
            raise RoaInputError(f"System.map must be callable, got {self.map!r}")
        if self.field is not None and not isinstance(self.field, NoVectorField):
            raise RoaInputError(
                f"system {self.name!r}: give either a vector field (field=) or a map (map=), "
                "not both"
            )
        if self.time_varying:
            raise RoaInputError(
                f"system {self.name!r}: a discrete-time system must be autonomous "
                "(time_varying=False)"
            )
        h = 1.0 if self.sample_time is None else self.sample_time
        if (
            isinstance(h, bool)
            or not isinstance(h, int | float | np.floating)
            or not (np.isfinite(h) and h > 0)
        ):
            raise RoaInputError(
                f"System.sample_time must be a finite number > 0, got {self.sample_time!r}"
            )
        object.__setattr__(self, "sample_time", float(h))
        object.__setattr__(self, "field", NoVectorField(self.name))

    @property
    def _slot(self) -> str:
        """The attribute holding the dynamics: ``"map"`` or ``"field"``."""
        return "field" if self.map is None else "map"

    def _bind_params(self) -> None:
        slot = self._slot
        dyn = getattr(self, slot)
        func = dyn.func if isinstance(dyn, BoundField) else dyn
        if self.parameters is not None:
            if not isinstance(self.parameters, Mapping) or not self.parameters:
                raise RoaInputError(
                    "System.parameters must be a non-empty mapping name -> (low, nominal, high), "
                    f"got {self.parameters!r}"
                )
            box = {}
            for key, value in self.parameters.items():
                if not isinstance(key, str) or not key.isidentifier():
                    raise RoaInputError(
                        f"System.parameters: names must be identifiers, got {key!r}"
                    )
                box[key] = _uncertain(key, value)
            fixed = dict(self.params or {})
            for key, rng in box.items():
                if key in fixed and isinstance(self.params, Params):
                    # re-bound (dataclasses.replace): a value inside the range is the nominal
                    if not rng.low <= fixed[key] <= rng.high:
                        raise RoaInputError(
                            f"parameter {key!r} = {fixed[key]!r} is outside its range "
                            f"[{rng.low!r}, {rng.high!r}]"
                        )
                    box[key] = Uncertain(rng.low, float(fixed[key]), rng.high)
                elif key in fixed:
                    raise RoaInputError(
                        f"parameter {key!r} is declared both fixed (params) and uncertain "
                        "(parameters): declare it once"
                    )
                fixed[key] = box[key].nominal
            object.__setattr__(self, "parameters", Params(box))
            object.__setattr__(self, "params", fixed)
        if self.params is None:
            if func is not dyn:
                object.__setattr__(self, slot, func)
            return
        if not isinstance(self.params, Mapping):
            raise RoaInputError(
                f"System.params must be a mapping name -> number, got {self.params!r}"
            )
        values: dict[str, float] = {}
        for key, value in self.params.items():
            if not isinstance(key, str) or not key.isidentifier():
                raise RoaInputError(f"System.params: names must be identifiers, got {key!r}")
            if isinstance(value, bool) or not isinstance(value, int | float | np.floating):
                raise RoaInputError(f"System.params[{key!r}] must be a number, got {value!r}")
            if isinstance(value, float | np.floating) and not np.isfinite(value):
                raise RoaInputError(f"System.params[{key!r}] must be finite, got {value!r}")
            _bounded(key, value, "System.params")
            values[key] = float(value)
        bound = Params(values)
        object.__setattr__(self, "params", bound)
        object.__setattr__(self, slot, BoundField(func, bound))

    @property
    def uncertain(self) -> tuple[str, ...]:
        """Names of the uncertain parameters (empty for a system with fixed parameters only)."""
        return tuple(self.parameters or ())

    def at(self, **values: float) -> System:
        """The same system with the uncertain parameters ``values`` fixed (each inside its range;
        the others stay uncertain)."""
        box = dict(self.parameters or {})
        for key, value in values.items():
            if key not in box:
                raise RoaInputError(
                    f"system {self.name!r} has no uncertain parameter {key!r} "
                    f"(uncertain: {', '.join(box) or 'none'})"
                )
            rng = box[key]
            if (
                isinstance(value, bool)
                or not isinstance(value, int | float | np.floating)
                or not rng.low <= value <= rng.high
            ):
                raise RoaInputError(
                    f"parameter {key!r} must be a number in [{rng.low!r}, {rng.high!r}], "
                    f"got {value!r}"
                )
        rest = {k: v for k, v in box.items() if k not in values}
        params = {k: v for k, v in (self.params or {}).items() if k not in rest}
        params.update({k: float(v) for k, v in values.items()})
        return self._rekernel(dataclasses.replace(self, params=params, parameters=rest or None))

    def with_ranges(self, **ranges: Sequence[float]) -> System:
        """The same system with declared parameters made uncertain: ``name=(low, high)`` (the
        nominal value is the parameter's current one, which must lie in the range) or
        ``name=(low, nominal, high)``."""
        declared = dict(self.params or {})
        box = {k: tuple(r) for k, r in (self.parameters or {}).items()}
        for key, rng in ranges.items():
            if key not in declared:
                raise RoaInputError(
                    f"system {self.name!r} has no parameter {key!r} "
                    f"(declared: {', '.join(sorted(declared)) or 'none'})"
                )
            values = tuple(rng)
            if len(values) == 2:
                values = (values[0], declared[key], values[1])
            box[key] = values
        params = {k: v for k, v in declared.items() if k not in box}
        return self._rekernel(dataclasses.replace(self, params=params or None, parameters=box))

    def nominal(self) -> System:
        """The system with every uncertain parameter fixed at its nominal value."""
        box = self.parameters or {}
        return self.at(**{k: r.nominal for k, r in box.items()}) if box else self

    def with_params(self, **values: float) -> System:
        """The same system with some parameters set to other values (names must be declared)."""
        held = sorted(set(values) & set(self.uncertain))
        if held:
            raise RoaInputError(
                f"parameter {held[0]!r} of {self.name!r} is uncertain: fix it with "
                f"System.at({held[0]}=...) (a value in its range)"
            )
        if self.params is None:
            raise RoaInputError(f"system {self.name!r} declares no parameters")
        unknown = sorted(set(values) - set(self.params))
        if unknown:
            raise RoaInputError(
                f"system {self.name!r} has no parameter {unknown[0]!r} "
                f"(declared: {', '.join(sorted(self.params))})"
            )
        return self._rekernel(dataclasses.replace(self, params={**self.params, **values}))

    def _rekernel(self, other: System) -> System:
        """``other`` (this system with other parameter values) with compiled-field factories
        that are for *its* values.

        A factory (``numba``, ``numba_fast``) is built for the parameter values of the system it
        came with. When the values change, a factory that can be rebuilt for them
        (``factory.with_params(values) -> factory``, ``values`` every parameter by name) is
        rebuilt; any other is dropped, so the batch integrator falls back to the numpy backend
        rather than integrate the field of other parameter values.
        """
        if dict(other.params or {}) == dict(self.params or {}):
            return other
        values = dict(other.params or {})
        kernels: list[Any] = []
        for factory in (other.numba, other.numba_fast):
            rebuild = getattr(factory, "with_params", None)
            kernels.append(rebuild(values) if callable(rebuild) else None)
        return dataclasses.replace(other, numba=kernels[0], numba_fast=kernels[1])

    @property
    def n(self) -> int:
        return len(self.state_names)

    @property
    def x_eq(self) -> np.ndarray:
        if self.equilibrium is None:
            raise RoaInputError(f"system {self.name!r} has no equilibrium (time-varying run)")
        return np.asarray(self.equilibrium, dtype=float)

    def f(self, x: np.ndarray, t: float | np.ndarray = 0.0) -> np.ndarray:
        """Evaluate the field with numpy on states of shape ``(..., n)``; returns ``(..., n)``."""
        return self._evaluate(self.field, x, t)

    # -- the members every analysis reads, whatever the system's time ----------------------------
    @property
    def time(self) -> str:
        """``"continuous"`` (``x' = f(t, x)``) or ``"discrete"`` (``x+ = F(x)``, :attr:`map`)."""
        return "continuous" if self.map is None else "discrete"

    @property
    def dynamics(self) -> Field:
        """The function defining the system: the field ``f`` or the map ``F`` (each
        ``(t, x, xp) -> n components``)."""
        return self.field if self.map is None else self.map

    def residual_expr(self, x: Any, xp: Any, t: Any = 0.0) -> list[Any]:
        """What vanishes at an equilibrium, in namespace ``xp``: ``f(x)``, or ``F(x) - x`` for a
        map (its fixed points)."""
        out = list(self.dynamics(t, x, xp))
        if self.map is None:
            return out
        return [out[i] - x[i] for i in range(len(out))]

    def decrease_expr(self, V: Any, x: Any, xp: Any) -> Any:
        """The function a Lyapunov certificate proves negative, at the components ``x`` in
        ``xp``: ``V' = grad V · f`` (continuous time), or ``Delta V = V(F(x)) - V(x)``
        (discrete time). ``V`` is a :class:`roa.lyapunov.Lyapunov`."""
        if self.map is None:
            g = V.gradient_expr(x, xp)
            f = self.field(0.0, x, xp)
            out: Any = 0.0
            for i in range(self.n):
                out = g[i] * f[i] + out
            return out
        return V.expr(list(self.map(0.0, x, xp)), xp) - V.expr(x, xp)

    def decrease(self, V: Any, x: np.ndarray) -> np.ndarray:
        """:meth:`decrease_expr` with numpy on states of shape ``(..., n)``."""
        x = np.asarray(x, dtype=float)
        if self.map is None:
            return np.einsum("...i,...i->...", V.gradient(x), self.f(x))
        return V.value(self.step(x)) - V.value(x)

    def step(self, x: np.ndarray, t: float | np.ndarray = 0.0) -> np.ndarray:
        """One step ``F(x)`` of a discrete-time system on states of shape ``(..., n)``."""
        if self.map is None:
            raise RoaInputError(f"system {self.name!r} is continuous-time: it has no map to step")
        return self._evaluate(self.map, x, t)

    def evaluate(self, x: np.ndarray, t: float | np.ndarray = 0.0) -> np.ndarray:
        """:attr:`dynamics` with numpy on states of shape ``(..., n)``: ``f(x)`` or ``F(x)``."""
        return self._evaluate(self.dynamics, x, t)

    def residual(self, x: np.ndarray) -> np.ndarray:
        """:meth:`residual_expr` with numpy on states of shape ``(..., n)``."""
        x = np.asarray(x, dtype=float)
        return self.f(x) if self.map is None else self.step(x) - x

    def _evaluate(self, func: Field, x: Any, t: Any) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if x.shape[-1] != self.n:
            raise RoaInputError(
                f"state must have {self.n} components {self.state_names}, got shape {x.shape}"
            )
        comps = [x[..., i] for i in range(self.n)]
        out = func(t, comps, NP)
        shape = np.broadcast_shapes(*(np.shape(o) for o in out))
        res = np.empty((*shape, len(out)), dtype=np.result_type(*out))
        for i, o in enumerate(out):
            res[..., i] = o  # broadcast, as np.stack(np.broadcast_arrays(*out), axis=-1) would
        return res

    def inside(self, x: np.ndarray) -> np.ndarray:
        """Boolean mask of states (``(..., n)``) strictly inside the domain."""
        x = np.asarray(x, dtype=float)
        if self.margin is None:
            return np.all(np.isfinite(x), axis=-1)
        comps = [x[..., i] for i in range(self.n)]
        return np.asarray(self.margin(comps, NP) > 0) & np.all(np.isfinite(x), axis=-1)

    def check_state(self, x: Sequence[float] | np.ndarray, *, what: str = "state") -> np.ndarray:
        """Validate one or many states; raise ``ValueError`` naming the problem."""
        arr = np.asarray(x, dtype=float)
        if arr.ndim == 0 or arr.shape[-1] != self.n:
            raise RoaInputError(
                f"{what} must have {self.n} components {', '.join(self.state_names)}; "
                f"got shape {arr.shape}"
            )
        bad = ~np.isfinite(arr)
        if bad.any():
            idx = np.argwhere(bad)[0]
            raise RoaInputError(
                f"{what}: component {self.state_names[idx[-1]]} is not finite (NaN/inf)"
            )
        if self.margin is not None and not np.all(self.inside(arr)):
            raise RoaInputError(
                f"{what} outside the domain of {self.name}: {self.domain_description}"
            )
        return arr


def closed_loop(
    field: Any,
    K: Any,
    states: Sequence[str],
    *,
    equilibrium: Sequence[float] | None = None,
    u_eq: Sequence[float] | None = None,
    name: str = "closed-loop",
    **kwargs: Any,
) -> System:
    """The :class:`roa.System` of ``x' = field(t, x, u, xp)`` under ``u = u_eq - K (x - x_eq)``.

    Parameters
    ----------
    field : callable
        ``field(t, x, u, xp) -> n components``, written with arithmetic and ``xp`` functions only
        (as a :class:`roa.System` field, plus the inputs ``u``, a sequence of m values).
    K : m x n matrix
        The state-feedback gain (``control.lqr(A, B, Q, R)[0]``).
    states : sequence of str
        State names (n of them).
    equilibrium : sequence of float, optional
        ``x_eq`` (default the origin).
    u_eq : sequence of float, optional
        The input holding the plant at ``x_eq`` (default zero): ``field(t, x_eq, u_eq) = 0``.
    name : str
        As :class:`roa.System`.
    **kwargs
        As :class:`roa.System` (``state_units``, ``input_names``, ``input_units``, ``margin``,
        ``lyapunov``, ...). ``input_names`` defaults to ``u0, u1, ...``.

    Returns
    -------
    roa.System
        Its field evaluates ``field`` in every namespace; roa's checks (``f(x_eq) = 0``, the
        linearisation ``A - B K`` Hurwitz) run when it is analysed. Its ``feedback`` is the
        control law (:class:`LinearFeedback`), so a simulation reports ``u(t)``.

    Examples
    --------
    >>> from roa import closed_loop
    >>> def pendulum(t, x, u, xp):
    ...     return (x[1], -xp.sin(x[0]) - 0.1 * x[1] + u[0])
    >>> cl = closed_loop(pendulum, [[1.0, 2.0]], ("theta", "omega"))
    >>> cl.f([0.0, 1.0]).tolist()
    [1.0, -2.1]
    """
    from roa.model._control_system import build_closed_loop

    return build_closed_loop(System, field, K, states, equilibrium=equilibrium, u_eq=u_eq,
                             name=name, **kwargs)  # fmt: skip
