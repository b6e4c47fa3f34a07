"""One bounded grammar for the numbers a user writes: command-line values, JSON, TOML, ``.npy``.

Claims and assumptions:

* A number written as text is ASCII ``[+-]digits[.digits][(e|E)[+-]digits]`` (also ``.5``, ``5.``)
  of at most :data:`MAX_CHARS` characters, checked *before* any conversion: no spaces,
  underscores, non-ASCII digits, ``inf`` or ``nan``, and no text long enough to make a conversion
  slow (Python's int-string limit is never reached).
* Its value is a finite double: a literal that overflows (``1e999``) is refused, not turned into
  infinity. The magnitude a value may have is the caller's range (:func:`bounded`); a value that
  is scaled before use (a level, a matrix) is checked finite after the scaling by the caller.
* Values already parsed by a reader (JSON, TOML, numpy) pass :func:`value`: a bool is not a
  number, an integer must fit a finite double (checked by its bit length, without converting it
  to text), a float must be finite.
* Stored certificates have their own exact-rational grammar
  (:func:`roa.proof._sos_check.parse_rational`); this one is for floats.
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Any

from roa.errors import RoaInputError

if TYPE_CHECKING:
    import numpy as np

#: Longest number accepted as text (17 significant digits, sign, point and exponent fit easily).
MAX_CHARS = 64
#: The largest level of a Lyapunov candidate accepted from the command line: with ``P`` of
#: entries up to :data:`roa.lyapunov._base.MAX_SCALE`, ``level / lambda_min(P)`` and the programs
#: built on ``{V <= level}`` stay finite doubles.
MAX_LEVEL = 1e150
#: Integers with more bits than this do not fit a finite double.
MAX_INT_BITS = 1024

_INTEGER = re.compile(r"[+-]?[0-9]{1,18}")
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def shown(text: Any) -> str:
    """``text`` for a one-line message: at most 40 characters, with its length if cut."""
    s = text if isinstance(text, str) else repr(text)
    return repr(s) if len(s) <= 40 else f"{s[:20]!r}... ({len(s)} characters)"


def parse_number(text: str, where: str) -> float:
    """The finite double written as ``text`` (the grammar above); a :class:`RoaInputError`
    naming ``where`` otherwise."""
    if not isinstance(text, str):
        raise RoaInputError(f"{where}: expected a number, got {type(text).__name__}")
    if len(text) > MAX_CHARS:
        raise RoaInputError(f"{where}: {shown(text)} is too long for a number (at most "
                            f"{MAX_CHARS} characters)")  # fmt: skip
    if not _NUMBER.fullmatch(text):
        raise RoaInputError(
            f"{where}: {shown(text)} is not a number (a finite number in ASCII digits with an "
            "optional sign, point and exponent, e.g. 0.5, -2, 1e-3; no spaces)"
        )
    x = float(text)
    if not math.isfinite(x):
        raise RoaInputError(f"{where}: {shown(text)} overflows a double (finite numbers only)")
    return x


def bounded(x: float, where: str, lo: float, hi: float) -> float:
    """``x`` if ``lo <= x <= hi``; otherwise an error naming ``where`` and the range."""
    if not lo <= x <= hi:
        raise RoaInputError(f"{where} must be in [{lo:g}, {hi:g}], got {x!r}")
    return x


def value(v: Any, where: str) -> float:
    """A number parsed by a reader (JSON, TOML, numpy scalar) as a finite double."""
    import numpy as np

    if isinstance(v, bool | np.bool_) or not isinstance(v, int | float | np.integer | np.floating):
        raise RoaInputError(f"{where}: expected a number, got {shown(v)}")
    if isinstance(v, int | np.integer) and int(v).bit_length() > MAX_INT_BITS - 1:
        raise RoaInputError(f"{where}: the integer of {int(v).bit_length()} bits overflows a "
                            "double (finite numbers only)")  # fmt: skip
    x = float(v)
    if not math.isfinite(x):
        raise RoaInputError(f"{where}: {shown(v)} is not a finite number")
    return x


def array(obj: Any, where: str) -> np.ndarray:
    """A nested list (JSON) or numeric array (``.npy``) as a float array, every entry checked by
    :func:`value`; subnormal entries are refused (a matrix scaled by them is not finite)."""
    import numpy as np

    if isinstance(obj, np.ndarray):
        if obj.dtype.kind not in "iuf":
            raise RoaInputError(f"{where}: the array must hold numbers, got dtype {obj.dtype}")
        flat = obj.reshape(-1)
        if obj.dtype.kind == "f" and not np.all(np.isfinite(flat)):
            raise RoaInputError(f"{where}: the array holds entries that are not finite")
        arr = obj.astype(float)
    else:
        entries: list[float] = []

        def walk(x: Any, depth: int) -> Any:
            if isinstance(x, list | tuple):
                if depth > 8:
                    raise RoaInputError(f"{where}: nested deeper than a matrix")
                return [walk(y, depth + 1) for y in x]
            entries.append(value(x, where))
            return entries[-1]

        try:
            arr = np.asarray(walk(obj, 0), dtype=float)
        except ValueError as exc:  # ragged rows
            raise RoaInputError(f"{where}: rows of different lengths ({exc})") from None
    tiny = np.finfo(float).tiny
    if np.any((arr != 0) & (np.abs(arr) < tiny)):
        raise RoaInputError(
            f"{where}: an entry is subnormal (nonzero with magnitude below {tiny:.3g}); scale "
            "the matrix"
        )
    return arr


def _json_int(text: str) -> int | float:
    if len(text) > MAX_CHARS:
        raise RoaInputError(f"{shown(text)} is too long for a number (at most {MAX_CHARS} "
                            "characters)")  # fmt: skip
    return int(text)


def _json_constant(text: str) -> float:
    raise RoaInputError(f"{text} is not a finite number")


def loads_json(text: str, where: str) -> Any:
    """``json.loads(text)`` with every number bounded as text before conversion (integers and
    floats: at most :data:`MAX_CHARS` characters; ``NaN``, ``Infinity`` refused; a float literal
    that overflows refused); a :class:`RoaInputError` naming ``where`` for any number refused.
    Other JSON errors propagate as :class:`json.JSONDecodeError`."""
    import json

    try:
        return json.loads(text, parse_int=_json_int, parse_constant=_json_constant,
                          parse_float=lambda s: parse_number(s, "a number"))  # fmt: skip
    except RoaInputError as exc:
        raise RoaInputError(f"{where}: {exc}") from None


def arg(lo: float = -math.inf, hi: float = math.inf, *, low_open: bool = False) -> Any:
    """An ``argparse`` type: :func:`parse_number`, then ``lo <= x <= hi`` (``lo < x`` with
    ``low_open``); a refusal is argparse's usage error (exit 2) naming the option."""
    import argparse

    def number(text: str) -> float:
        try:
            x = parse_number(text, "value")
        except RoaInputError as exc:
            raise argparse.ArgumentTypeError(str(exc).removeprefix("value: ")) from None
        if not (lo < x if low_open else lo <= x) or not x <= hi:
            left = "(" if low_open else "["
            raise argparse.ArgumentTypeError(f"{x!r} is outside {left}{lo:g}, {hi:g}]")
        return x

    number.__name__ = "number"
    return number


def integer(lo: int = -(10**18), hi: int = 10**18) -> Any:
    """An ``argparse`` type for an integer option: ASCII ``[+-]digits`` (at most 18 digits: no
    spaces, underscores or non-ASCII digits), then ``lo <= n <= hi``; a refusal is argparse's usage
    error (exit 2) naming the option."""
    import argparse

    def whole(text: str) -> int:
        if not isinstance(text, str) or not _INTEGER.fullmatch(text):
            raise argparse.ArgumentTypeError(
                f"{shown(text)} is not an integer (ASCII digits with an optional sign, at most "
                "18 digits; no spaces)"
            )
        n = int(text)
        if not lo <= n <= hi:
            raise argparse.ArgumentTypeError(f"{n} is outside [{lo}, {hi}]")
        return n

    whole.__name__ = "integer"
    return whole
