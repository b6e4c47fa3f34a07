"""``.. roa-example-table:: examples/NAME.json``: an example's JSON as a table of its numbers.

Rows: the level search (status, level, method), the certificate (status, level, method, where the
level came from, the verdict 1.001 x above it), the basin slice (points per status) and, for each
certified region, the share of the slice's converged points inside it with its 95 % Clopper-Pearson
interval (the JSON's ``certified_share``, or computed from the region's converged count when an
older JSON has none). A second candidate (``identity_candidate``) gets its own rows.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from docutils import nodes
from docutils.parsers.rst import Directive
from docutils.statemachine import StringList


def _num(v: Any, digits: int = 6) -> str:
    return "none" if v is None else f"{float(v):.{digits}g}"


def _pct(v: float) -> str:
    return f"{100 * v:.2f} %"


def _shares(doc: dict[str, Any]) -> list[tuple[str, str]]:
    from roa.montecarlo._certified_share import clopper_pearson

    rows = []
    entries = doc.get("certified_share")
    if entries is None:  # older JSON: the region's converged count over the slice's converged
        basin = doc.get("basin_slice") or {}
        m = int((basin.get("counts") or {}).get("converged", 0))
        entries = []
        for r in basin.get("regions", []):
            if r.get("status") != "certified" or not m:
                continue
            k = int(r["slice"]["converged"])
            entries.append({"region": r["name"], "share": k / m, "converged": m,
                            "converged_in_region": k, "ci95": clopper_pearson(k, m)})  # fmt: skip
    for e in entries:
        if e.get("share") is None:
            continue
        lo, hi = e["ci95"]
        where = "the box's (uniform samples)" if e.get("over") == "box" else "the slice's"
        rows.append((f"share of {where} converged points in {e['region']}",
                     f"{_pct(e['share'])} ({e['converged_in_region']} of {e['converged']}; "
                     f"95 % CI {_pct(lo)} - {_pct(hi)})"))  # fmt: skip
    return rows


def _analysis_rows(doc: dict[str, Any], prefix: str = "") -> list[tuple[str, str]]:
    rows = []
    s = doc.get("level_search")
    if s:
        rows.append((f"{prefix}level search ({s['method']})", f"{s['status']}: {_num(s['level'])}"))
    c = doc.get("certificate")
    if c:
        rows.append((f"{prefix}certificate ({c['method']}, level from {c['level_source']})",
                     f"{c['status']}: {_num(c['level'])}"))  # fmt: skip
        if c.get("above"):
            rows.append((f"{prefix}1.001 x the level found", str(c["above"])))
    return rows


def rows_of(doc: dict[str, Any]) -> list[tuple[str, str]]:
    """The table's rows ``(quantity, value)`` of an example's JSON."""
    rows = [("system (states)", f"{doc['system']} ({', '.join(doc['states'])})")]
    rows += _analysis_rows(doc)
    other = doc.get("identity_candidate")
    if other:
        rows += _analysis_rows(other, "V of A'P + PA = -I: ")
    b = doc.get("basin_slice")
    if b:
        counts = ", ".join(f"{k} {v}" for k, v in b["counts"].items() if v)
        rows.append(("basin slice", f"{b['n']} points: {counts}"))
    rows += _shares(doc)
    if "seconds" in doc:
        rows.append(("run time", f"{doc['seconds']:g} s"))
    return rows


class ExampleTable(Directive):
    required_arguments = 1

    def run(self) -> list[nodes.Node]:
        env = self.state.document.settings.env
        rel, path = env.relfn2path(self.arguments[0])
        env.note_dependency(rel)
        doc = json.loads(Path(path).read_text())
        lines = [".. list-table::", "   :header-rows: 1", "   :widths: 45 55", "",
                 "   * - quantity", "     - value"]  # fmt: skip
        for key, value in rows_of(doc):
            lines += [f"   * - {key}", f"     - {value}"]
        node = nodes.section()
        node.document = self.state.document
        self.state.nested_parse(StringList(lines, source=path), self.content_offset, node)
        return list(node.children)


def setup(app: Any) -> dict[str, Any]:
    app.add_directive("roa-example-table", ExampleTable)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
