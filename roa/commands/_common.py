"""What every command shares: the ``--system`` and ``--lyapunov`` options and their parsing.

Commands only parse arguments, call the public API and print: no analysis happens here.
"""

from __future__ import annotations

import argparse
import json
import math
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn, TypeVar

from roa import numparse
from roa.errors import RoaInputError
from roa.io import to_json

T = TypeVar("T")

#: ``--system`` has no default: the analysis commands are not about any one system.
SYSTEM_HELP = (
    "the system (required): a built-in by name ({builtins}), with parameters "
    "(e.g. vanderpol:mu=0.5), or path/file.py:NAME"
)

LYAPUNOV_HELP = (
    "the Lyapunov candidate V = (x - x_eq)' P (x - x_eq): a .json file holding the matrix P "
    '(a list of rows, or an object {"P": rows}), a .npy file, or path/file.py:NAME (a matrix or '
    "a roa.QuadraticLyapunov); default: the system's own V (a user file's LYAPUNOV_P), else P from "
    'A\'P + PA = -I. Beyond quadratic: a .json object {"monomials": [[2,0],[0,2],[4,0]], '
    '"coefficients": [1,1,0.5]} (a polynomial in x - x_eq; also the JSON of `roa certify '
    "--degree D --json`), or file.py:NAME holding any "
    "roa.lyapunov.Lyapunov (PolynomialLyapunov, FunctionLyapunov)"
)


def add_system(p: argparse.ArgumentParser, *, lyapunov: bool = False) -> None:
    """The required ``--system`` (missing: :class:`Parser` lists the built-ins), ``--lyapunov``."""
    from roa.systems import describe_builtins

    p.add_argument(
        "--system",
        required=True,
        metavar="SYSTEM",
        help=SYSTEM_HELP.format(builtins=describe_builtins()),
    )
    p.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE|LOW..HIGH",
        help="set a parameter of the system (repeatable): NAME=VALUE fixes it (an uncertain one "
        "inside its range), NAME=LOW..HIGH makes it uncertain over that range (nominal: its "
        "current value; LOW..NOMINAL..HIGH to choose it); analyses that prove then hold for "
        "every value of the range",
    )
    if lyapunov:
        p.add_argument("--lyapunov", default=None, metavar="FILE", help=LYAPUNOV_HELP)


#: A value that starts like a negative number but that argparse would take for an option
#: (``-10x10``, ``-0.5,0.5``, ``-1e-3``): argparse accepts only ``-5`` and ``-.5`` as values.
_NEGATIVE_VALUE = re.compile(r"-\.?\d.*")
_ARGPARSE_NUMBER = re.compile(r"^-\d+$|^-\d*\.\d+$")


def join_negative_values(argv: list[str]) -> list[str]:
    """``--opt -10x10`` as ``--opt=-10x10``, so that the option's own check names the value and
    its allowed range instead of argparse's "expected one argument" (no option starts ``-digit``)."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        nxt = argv[i + 1] if i + 1 < len(argv) else None
        if (tok.startswith("--") and "=" not in tok and len(tok) > 2 and nxt is not None
                and _NEGATIVE_VALUE.fullmatch(nxt) and not _ARGPARSE_NUMBER.match(nxt)):  # fmt: skip
            out.append(f"{tok}={nxt}")
            i += 2
            continue
        out.append(tok)
        i += 1
    return out


class Parser(argparse.ArgumentParser):
    """The parser of ``roa`` and its commands: an error about ``--system`` (missing, no value)
    lists the systems loadable by name; ``--opt -10x10`` reaches the option (see
    :func:`join_negative_values`)."""

    def parse_known_args(self, args: Any = None, namespace: Any = None) -> Any:
        import sys

        argv = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(join_negative_values(argv), namespace)

    def error(self, message: str) -> NoReturn:
        if "--system" in message and any("--system" in a.option_strings for a in self._actions):
            from roa.systems import describe_builtins

            message += f"; built-in systems: {describe_builtins()}; or a user's path/file.py:NAME"
        super().error(message)


def system(args: argparse.Namespace) -> Any:
    from roa.systems import load_system

    return with_param_options(load_system(args.system), getattr(args, "param", None) or [])


def _number(text: str, where: str) -> float:
    return numparse.parse_number(text, where)


def with_param_options(sys_: Any, specs: list[str]) -> Any:
    """``sys_`` with the ``--param`` options applied (``NAME=VALUE`` fixes, ``NAME=LOW..HIGH``
    makes uncertain)."""
    for spec in specs:
        key, sep, value = spec.partition("=")
        key = key.strip()
        where = f"--param {spec}"
        if not sep or not key:
            raise RoaInputError(f"{where}: expected NAME=VALUE or NAME=LOW..HIGH")
        if ".." in value:
            parts = value.split("..")
            if len(parts) not in (2, 3):
                raise RoaInputError(f"{where}: expected LOW..HIGH or LOW..NOMINAL..HIGH")
            rng = tuple(_number(t, where) for t in parts)
            try:
                sys_ = sys_.with_ranges(**{key: rng})
            except RoaInputError as exc:
                raise RoaInputError(f"{where}: {exc}") from None
            continue
        number = _number(value, where)
        try:
            sys_ = (
                sys_.at(**{key: number})
                if key in sys_.uncertain
                else sys_.with_params(**{key: number})
            )
        except RoaInputError as exc:
            raise RoaInputError(f"{where}: {exc}") from None
    return sys_


def lyapunov(args: argparse.Namespace, sys_: Any) -> Any:
    """The ``--lyapunov`` candidate for ``sys_`` (the system's default when not given)."""
    from roa.lyapunov import Lyapunov, QuadraticLyapunov
    from roa.search._candidate import default_lyapunov

    spec = getattr(args, "lyapunov", None)
    if spec is None:
        return default_lyapunov(sys_)
    obj = read_matrix(spec, what="--lyapunov")
    if isinstance(obj, dict):  # polynomial coefficients from a JSON file
        from roa.lyapunov import from_json

        try:
            return from_json(obj, sys_.x_eq, name=Path(spec).name)
        except RoaInputError as exc:
            raise RoaInputError(f"--lyapunov {spec}: {exc}") from None
        except (TypeError, ValueError, OverflowError):
            raise RoaInputError(
                f"--lyapunov {spec}: monomials must be lists of non-negative integers and "
                "coefficients finite numbers"
            ) from None
    if isinstance(obj, Lyapunov):
        if obj.n != sys_.n:
            raise RoaInputError(f"--lyapunov {spec}: V has {obj.n} states, the system {sys_.n}")
        return obj
    try:
        return QuadraticLyapunov.for_system(sys_, obj, name=Path(spec.split(":")[0]).name)
    except RoaInputError as exc:
        raise RoaInputError(f"--lyapunov {spec}: {exc}") from None


def read_matrix(spec: str, *, what: str) -> Any:
    """A matrix (or a Lyapunov object) from ``.json`` / ``.npy`` / ``file.py:NAME``; a JSON object
    with ``"monomials"`` and ``"coefficients"`` (and its ``"gram"``, if any) is returned as that
    dict (a polynomial V), also
    when they are in its ``"candidate_kind"`` (the JSON of ``roa certify --degree D --json``)."""
    import numpy as np

    if spec.endswith(".py") or ".py:" in spec:
        from roa.systems import user_module

        path_str, _, name = spec.rpartition(":") if ".py:" in spec else (spec, ":", "LYAPUNOV_P")
        module = user_module(Path(path_str))
        if not hasattr(module, name):
            raise RoaInputError(f"{what} {spec}: {path_str} defines no {name!r}")
        return getattr(module, name)
    path = Path(spec)
    if not path.is_file():
        raise RoaInputError(f"{what} {spec!r}: no such file (expected .json, .npy or file.py:NAME)")
    if path.suffix == ".npy":
        try:
            arr = np.load(path, allow_pickle=False)
        except (ValueError, OSError, EOFError) as exc:
            raise RoaInputError(
                f"{what} {spec}: not a readable .npy array of numbers ({type(exc).__name__})"
            ) from None
        if not isinstance(arr, np.ndarray) or arr.dtype.kind not in "iuf":
            raise RoaInputError(
                f"{what} {spec}: the .npy array must hold numbers, got dtype "
                f"{getattr(arr, 'dtype', type(arr).__name__)}"
            )
        return numparse.array(arr, f"{what} {spec}")
    try:
        data = numparse.loads_json(path.read_text(), f"{what} {spec}")
    except json.JSONDecodeError as exc:
        raise RoaInputError(f"{what} {spec}: invalid JSON ({exc})") from None
    except (UnicodeDecodeError, RecursionError, OSError) as exc:
        raise RoaInputError(
            f"{what} {spec}: not a readable JSON file ({type(exc).__name__})"
        ) from None
    if isinstance(data, dict):
        kind = data.get("candidate_kind")
        if "P" not in data and isinstance(kind, dict):  # `roa certify --json` of a polynomial V
            if "monomials" not in kind:
                raise RoaInputError(
                    f"{what} {spec}: its V is a {kind.get('kind')}, which the JSON does not hold: "
                    "give it as file.py:NAME"
                )
            data = kind
        if "monomials" in data or "coefficients" in data:
            if "monomials" not in data or "coefficients" not in data:
                raise RoaInputError(
                    f'{what} {spec}: a polynomial V needs both "monomials" (exponent lists) '
                    'and "coefficients"'
                )
            keep = ("monomials", "coefficients", "gram")
            return {k: data[k] for k in keep if k in data}
        if "P" not in data:
            raise RoaInputError(
                f'{what} {spec}: a JSON object must have a key "P" (the matrix), or '
                '"monomials" and "coefficients" (a polynomial V)'
            )
        data = data["P"]
    if not isinstance(data, list):
        raise RoaInputError(f"{what} {spec}: P must be a list of rows of numbers")
    return numparse.array(data, f"{what} {spec}: P")


def options(make: Callable[[], T], flags: dict[str, str]) -> T:
    """``make()`` (option objects); a :class:`RoaInputError` names the CLI flag, not the field.

    ``flags`` maps ``"Class.field"`` (as the option classes name them) to the flag.
    """
    try:
        return make()
    except RoaInputError as exc:
        msg = str(exc)
        for field, flag in flags.items():
            msg = msg.replace(field, flag)
        raise RoaInputError(msg) from None


def floats(text: str, what: str, n: int | None = None) -> list[float]:
    """Comma-separated numbers (:func:`roa.numparse.parse_number`: no spaces in a number)."""
    vals = [numparse.parse_number(v, what) for v in text.split(",") if v.strip() != ""]
    if n is not None and len(vals) != n:
        raise RoaInputError(f"{what}: expected {n} comma-separated numbers, got {len(vals)}")
    return vals


def emit(args: argparse.Namespace, payload: dict[str, Any]) -> None:
    """Print ``payload`` as JSON (``--json``); text output is each command's own."""
    print(to_json(payload))


def fmt(value: Any, spec: str = ".6g", missing: str = "none") -> str:
    """A number formatted, or a clear word for a missing one (never ``None`` in text output)."""
    if value is None:
        return missing
    try:
        return format(float(value), spec)
    except (TypeError, ValueError):
        return str(value)


def add_stop_rules(p: argparse.ArgumentParser) -> None:
    """``--t-final``, ``--converge-tol``, ``--diverge-bound``, ``--diverge-growth``
    (:class:`roa.StopRules`; read back by :func:`stop_rules`)."""
    p.add_argument(
        "--t-final", type=numparse.arg(), default=60.0, help="final time > 0 (default 60)"
    )
    p.add_argument("--converge-tol", type=numparse.arg(), default=1e-3,
                   help="radius of the ball around the equilibrium that counts as converged "
                   "(default 1e-3)")  # fmt: skip
    p.add_argument("--diverge-bound", type=numparse.arg(), default=1e6, metavar="NORM",
                   help="a run whose norm ||x|| reaches NORM is diverged; finite, > --converge-tol "
                   "(default 1e6)")  # fmt: skip
    p.add_argument("--diverge-growth", type=numparse.arg(), default=100.0, metavar="G",
                   help="a run still going at --t-final is diverged when ||x - x_eq|| is then >= "
                   "NORM/G, >= G x its largest value over the first half of the run, and still "
                   "growing exponentially; G finite > 1, or 0 for no growth rule (default 100)")  # fmt: skip


def stop_rules(args: argparse.Namespace) -> Any:
    """The :class:`roa.StopRules` of :func:`add_stop_rules`' flags; a bad value exits 2 naming
    its flag and the allowed range."""
    from roa.status import StopRules

    for flag, value in (("--t-final", args.t_final), ("--converge-tol", args.converge_tol),
                        ("--diverge-bound", args.diverge_bound)):  # fmt: skip
        if not (math.isfinite(value) and value > 0):
            raise RoaInputError(f"{flag} must be a finite number > 0, got {value}")
    if not args.converge_tol < args.diverge_bound:
        raise RoaInputError(
            f"--diverge-bound ({args.diverge_bound:g}) must be larger than --converge-tol "
            f"({args.converge_tol:g})"
        )
    g = args.diverge_growth
    if not (g == 0 or (math.isfinite(g) and g > 1)):
        raise RoaInputError(
            f"--diverge-growth must be a finite factor > 1, or 0 for no growth rule, got {g}"
        )
    return StopRules(t_final=args.t_final, converge_tol=args.converge_tol,
                     diverge_bound=args.diverge_bound, diverge_growth=g or None)  # fmt: skip
