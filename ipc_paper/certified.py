"""Certified IPC regions as :class:`roa.lyapunov.Region` objects, for basin maps and Monte Carlo.

Read from ``results/certify/certified.json`` (written by ``roa run experiments/certify.toml``).
Entries hold a quadratic V (``P``) or a polynomial one (its monomials and coefficients, see
:meth:`roa.lyapunov.Region.from_json`). A region's status is ``certified`` only when the interval validation of its level passed; other
verdicts are kept with their own status (``refuted`` / ``inconclusive``), never merged.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from roa.errors import RoaInputError
from roa.lyapunov import Region

CERTIFIED_PATH = Path("results/certify/certified.json")

#: Coordinates a stored IPC Lyapunov matrix is written in (``coords`` of certified.json).
COORDS = ("flat", "hybrid")


def coords_map(name: str) -> Callable[[np.ndarray], np.ndarray]:
    """Physical IPC states -> the named analysis coordinates (``inf`` outside |theta| < pi/2).

    ``"flat"``: (2.2), ``(z1, z2, w1, w2)``; ``"hybrid"``: ``(q, z2, w1, w2)`` of
    :mod:`ipc_paper.system.hybrid`.
    """
    if name == "flat":
        from ipc_paper.system import physical_to_flat_or_inf

        return physical_to_flat_or_inf
    if name == "hybrid":
        from ipc_paper.system.hybrid import physical_to_hybrid_or_inf

        return physical_to_hybrid_or_inf
    raise RoaInputError(f"coords {name!r}: allowed {', '.join(COORDS)}")


#: Plain legend words per certified entry, by the start of its name (written by certify_runs).
_PLAIN = (
    ("paper V (3.11)", "level set of the paper's V"),
    ("optimised quadratic V (box fraction)", "optimised V, largest box share"),
    ("optimised quadratic V (sector)", "optimised V, widest sector"),
    ("optimised quadratic V (paper's ball)", "optimised V around the paper's ball"),
    ("quadratic V in hybrid coordinates (sector)", "V in (q, z2, w1, w2), widest sector"),
    (
        "quadratic V in hybrid coordinates (box fraction)",
        "V in (q, z2, w1, w2), largest box share",
    ),
    ("saturated loop", "level set of V for the saturated loop"),
)


def plain_label(name: str, status: str, level: float) -> str:
    """Legend text of a certified entry in plain words, e.g. "our certified level set of the
    paper's V: V <= 2.281" (the status word once; other verdicts say "candidate")."""
    what = next((w for start, w in _PLAIN if name.startswith(start)), None)
    if what is None:
        what = name.split(":")[0]
    word = "certified" if status == "certified" else "candidate"
    return f"our {word} {what}: V <= {level:.4g}"


def ipc_certified_regions(path: str | Path = CERTIFIED_PATH) -> list[Region]:
    """The IPC's certified sublevel sets ``{V(coords(x)) <= level}``.

    Paper's V (3.11) and the optimised quadratic V (reference-box fraction, sector at
    q = q' = theta' = 0, paper's ball; in flat or hybrid coordinates, the entry's ``coords``,
    default flat), each with its own verdict as status.
    """
    path = Path(path)
    if not path.is_file():
        raise RoaInputError(f"{path} does not exist: run `roa run experiments/certify.toml` first")
    data = json.loads(path.read_text())
    return [_region(entry) for entry in data["regions"]]


def _region(entry: dict) -> Region:
    """One entry of certified.json as a Region: ``P`` (quadratic) or a polynomial V (``V`` /
    ``candidate_kind`` / ``monomials`` and ``coefficients``, centred at the equilibrium, which is
    0 in flat and hybrid coordinates)."""
    label = plain_label(entry["name"], entry["status"], float(entry["level"]))
    return Region.from_json(entry, coords_map(entry.get("coords", "flat")), meta={"label": label})


def ipc_saturated_regions(
    path: str | Path = CERTIFIED_PATH, *, saturation: float | None = None
) -> list[Region]:
    """Certified sets of the *saturated* loop (``saturated`` of certified.json; claim C11), for
    the limit ``saturation`` (all limits if None). They are not in :func:`ipc_certified_regions`:
    a set certified for one loop says nothing about the other. Empty if the file or key is missing.
    """
    path = Path(path)
    if not path.is_file():
        return []
    return [
        _region(entry)
        for entry in json.loads(path.read_text()).get("saturated", [])
        if saturation is None or float(entry["saturation"]) == float(saturation)
    ]


def load_optimised_P(path: str | Path = CERTIFIED_PATH, *, which: str = "box") -> np.ndarray:
    """An optimised Lyapunov matrix of the last certify experiment (flat coordinates).

    ``which="box"``: maximising the reference-box fraction; ``"sector"``: maximising the sector.
    """
    keys = {"box": "optimised_P", "sector": "sector_P"}
    if which not in keys:
        raise RoaInputError(f"which {which!r}: allowed {', '.join(keys)}")
    path = Path(path)
    if not path.is_file():
        raise RoaInputError(f"{path} does not exist: run `roa run experiments/certify.toml` first")
    data = json.loads(path.read_text())
    if keys[which] not in data:
        raise RoaInputError(
            f"{path} has no {keys[which]}: rerun `roa run experiments/certify.toml`"
        )
    return np.asarray(data[keys[which]], dtype=float)
