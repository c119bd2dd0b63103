"""The fleet report (``fleet.html``): one self-contained page, in the report's style.

An overview (one line per log: verdict, torque error, moved parameters), then per robot each base
parameter with its 95 % interval (value ± 1.96·se) and, with a reference fit, the reference value
and whether it moved (highlighted), then the failed logs with their reasons. Tables have at most
six columns (parameter, unit, value, half-width of the interval, reference, moved), so they stay inside the text column.
"""

from __future__ import annotations

from pathlib import Path

from .html import _CSS, _esc, format_cell

__all__ = ["fleet_html", "write_fleet_report"]

_EXTRA_CSS = """
tr.moved td { background: #fde8e8; font-weight: 600; }
td.moved-mark { color: #b00020; }
"""


def _table(caption: str, columns, rows, moved_rows=()) -> str:
    """A table like the report's (`physid.report.html`), rows in ``moved_rows`` highlighted."""
    out = ['<div class="table-wrap"><table>', f"<caption>{_esc(caption)}</caption>", "<thead><tr>"]
    for j, c in enumerate(columns):
        numeric = any(isinstance(r[j], (int, float)) and not isinstance(r[j], bool) for r in rows)
        cls = ' class="num"' if numeric else ""
        out.append(f'<th scope="col"{cls}>{_esc(c)}</th>')
    out.append("</tr></thead><tbody>")
    for i, row in enumerate(rows):
        out.append('<tr class="moved">' if i in moved_rows else "<tr>")
        for cell in row:
            num = isinstance(cell, (int, float)) and not isinstance(cell, bool)
            cls = ' class="num"' if num else ""
            out.append(f"<td{cls}>{_esc(format_cell(cell))}</td>")
        out.append("</tr>")
    out.append("</tbody></table></div>")
    return "\n".join(out)


def _overview(result) -> str:
    ref = result.reference is not None
    rows = []
    for r in result.rows:
        verdict = "failed" if r["status"] != "ok" else ("success" if r["success"] else "no success")
        err = r["relative_error"]
        moved = (r.get("moved") or "none") if ref and r["status"] == "ok" else "—"
        rows.append((Path(r["log"]).name, verdict, None if err is None else 100 * err, moved))
    cols = ("log", "verdict", "torque error [%]", "moved" if ref else "moved (no reference)")
    flagged = {i for i, r in enumerate(result.rows) if r.get("moved")}
    return _table("Robots: one fit per log", cols, rows, flagged)


def _robot(result, row, data, entries) -> str:
    z = result.z
    by_name = {e["parameter"]: e for e in entries}
    units = (data or {}).get("units") or {}
    cols = ["parameter", "unit", "value", f"± {z:g}·se"]
    if result.reference is not None:
        cols += ["reference", "moved"]
    rows, flagged = [], set()
    for i, name in enumerate(n for n in result.parameter_names if row.get(n) is not None):
        se = row.get(name + "_se")
        cells = [name, units.get(name, ""), row[name], None if se is None else z * se]
        if result.reference is not None:
            e = by_name.get(name, {})
            mark = {True: "moved", False: "no", None: "not comparable"}[e.get("moved")]
            cells += [e.get("reference"), mark]
            if e.get("moved"):
                flagged.add(i)
        rows.append(tuple(cells))
    return _table(f"{Path(row['log']).name}: base parameters", cols, rows, flagged)


def fleet_html(result) -> str:
    """The fleet report page of a `physid.analysis.fleet_result.FleetResult`.

    Parameters
    ----------
    result : FleetResult

    Returns
    -------
    str
        A complete HTML document (inline CSS, no script, no network).
    """
    import physid

    entries = result.moved() if result.reference is not None else []
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>physid fleet: {_esc(result.model)}</title>",
        f"<style>{_CSS}{_EXTRA_CSS}</style></head><body><main>",
        f"<h1>Fleet: {len(result.rows)} logs</h1>",
        f'<p class="meta">physid {_esc(physid.__version__)} · model {_esc(result.model)} · '
        f"{_esc(result.method)} · {_esc(result.backend)} · {result.elapsed_s:.1f} s</p>",
    ]
    if result.reference is not None:
        parts.append(
            f"<p>A parameter moved since the reference fit {_esc(result.reference.path)} when "
            f"|β − β_ref| &gt; {result.z:g}·√(se² + se_ref²) (two-sided 95 %); moved rows are "
            "highlighted. A parameter in only one of the two fits is not comparable.</p>"
        )
    parts.extend(f"<p>Note: {_esc(n)}</p>" for n in result.notes)
    parts.append("<h2>Overview</h2>")
    parts.append(_overview(result))
    ok = [r for r in result.rows if r["status"] == "ok"]
    if ok:
        parts.append("<h2>Base parameters per robot</h2>")
        for r, data in zip(result.rows, result.results, strict=True):
            if r["status"] == "ok":
                mine = [e for e in entries if e["log"] == r["log"]]
                parts.append(_robot(result, r, data, mine))
    failed = [r for r in result.rows if r["status"] != "ok"]
    if failed:
        parts.append("<h2>Failed logs</h2>")
        rows = [(Path(r["log"]).name, r["reason"]) for r in failed]
        parts.append(_table("Logs that could not be fitted", ("log", "reason"), rows))
    parts.append("</main></body></html>")
    return "\n".join(parts) + "\n"


def write_fleet_report(result, out_dir) -> dict:
    """Write the fleet's folder with its page: tables, result files and ``fleet.html``.

    Parameters
    ----------
    result : physid.analysis.fleet_result.FleetResult
    out_dir : str or Path
        The folder (created; the fleet's own file names replaced, other files left alone).

    Returns
    -------
    dict of str to Path
        As `physid.analysis.fleet_result.write_fleet`, with ``html``.
    """
    return result.write(out_dir, page=fleet_html(result))
