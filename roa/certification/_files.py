"""Reading certificate files: one reader for every place that takes ``roa certify --json``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from roa.errors import RoaInputError


def read_certificate_json(source: str | Path | dict[str, Any], where: str) -> dict[str, Any]:
    """The JSON object of a certificate file (or the dict itself); errors name ``where``."""
    if isinstance(source, dict):
        return source
    path = Path(source)
    if not path.is_file():
        raise RoaInputError(f"{where}: no such file (give the JSON of `roa certify --json`)")
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError, UnicodeDecodeError, RecursionError) as exc:
        raise RoaInputError(f"{where}: not a readable JSON file ({type(exc).__name__})") from None
    if not isinstance(data, dict):
        raise RoaInputError(f"{where}: expected the JSON object written by `roa certify --json`")
    return data
