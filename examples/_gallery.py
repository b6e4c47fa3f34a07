"""What every example script shares: its command line and what it writes.

Each example is ``python examples/NAME.py [--quick] [--out DIR]`` and writes ``DIR/NAME.json`` (the
statuses and numbers of its analyses) and ``DIR/NAME.png`` (a basin slice with the estimates drawn
over it). ``--quick`` runs coarse grids and cheaper certificates (the gallery test runs that).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

DEFAULT_OUT = "results-examples"


def parse(argv: list[str] | None, description: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=description.strip().splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="coarse grid, cheaper certificate")
    parser.add_argument("--out", default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT})")
    return parser.parse_args(argv)


def summary(search: Any, cert: Any, basin: Any) -> dict[str, Any]:
    """The numbers of a level search, a certificate and a basin slice, for the JSON."""
    out: dict[str, Any] = {}
    if search is not None:
        out["level_search"] = {
            "status": search.status.value,
            "level": search.level,
            "method": search.method,
            "witness": None if search.witness is None else [float(v) for v in search.witness],
        }
    if cert is not None:
        out["certificate"] = {
            "status": cert.status.value,
            "level": cert.level,
            "method": cert.method,
            "level_source": cert.level_source,
            "above": None if cert.above is None else cert.above.to_json().get("status"),
            "seconds": round(cert.seconds, 3),
        }
    if basin is not None:
        out["basin_slice"] = {
            "status": basin.status.value,
            "n": basin.n,
            "counts": dict(basin.counts),
            "fraction_converged": basin.fraction_converged,
            "regions": [{k: r[k] for k in ("name", "level", "status", "slice")}
                        for r in basin.to_dict().get("regions", [])],
        }  # fmt: skip
    return out


def box_shares(system: Any, ranges: list[tuple[float, float]], drawn: list[Any], n: int,
               seed: int = 0) -> list[dict[str, Any]]:  # fmt: skip
    """The share of converged points inside each region over ``n`` seeded uniform samples of the
    n-dimensional box ``ranges`` (a second basin run; ``certified_share`` entries, ``over`` box)."""
    import roa

    sampler = roa.box_sample(system, ranges, n, seed=seed)
    res = roa.basin(system, sampler, run=roa.RunOptions(n_jobs=1), regions=drawn)
    return [dict(e) for e in res.certified_shares]


def regions(V: Any, search: Any, cert: Any) -> list[Any]:
    """The level-search estimate and the certified set as regions to draw."""
    from roa.lyapunov import Region

    out = []
    if search is not None and search.level is not None:
        out.append(Region.from_lyapunov(f"V <= {search.level:.4g} (level search)", V,
                                        search.level, "sampled"))  # fmt: skip
    if cert is not None and cert.level is not None:
        out.append(Region.from_lyapunov(f"V <= {cert.level:.4g} ({cert.status.value})", V,
                                        cert.level, cert.status.value))  # fmt: skip
    return out


def write(out: str | Path, name: str, system: Any, data: dict[str, Any], basin: Any,
          drawn: list[Any], started: float,
          extra_shares: Sequence[dict[str, Any]] = ()) -> dict[str, Any]:  # fmt: skip
    """Write ``out/name.json`` and ``out/name.png`` (atomically); return the JSON's content.
    ``extra_shares``: shares over a sampled box (:func:`box_shares`), after the slice's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from roa.io import atomic_savefig, atomic_write_json, to_json

    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    from roa.montecarlo import share_line

    shares = [dict(e) for e in basin.certified_shares] + [dict(e) for e in extra_shares]
    doc = {"example": name, "system": system.name, "states": list(system.state_names), **data,
           "certified_share": shares,
           "seconds": round(time.perf_counter() - started, 2)}  # fmt: skip
    ax = basin.plot(regions=drawn, title=f"basin of {system.name}")
    atomic_savefig(ax.figure, folder / f"{name}.png", dpi=110, bbox_inches="tight")
    plt.close(ax.figure)
    atomic_write_json(folder / f"{name}.json", doc)
    for entry in shares:  # how much of the basin slice each region holds
        print(f"{name}: {share_line(entry)}")
    print(f"{name}: wrote {folder / (name + '.json')} and {folder / (name + '.png')}")
    return json.loads(to_json(doc))
