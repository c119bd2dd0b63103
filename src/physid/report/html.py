"""The self-contained HTML report: the objects experiments fill, and the writer.

An experiment returns a list of `ReportSection` objects; `write_report` turns them into three
outputs in one folder:

``report.html``
    One file, readable without a server or network: inline CSS, figures embedded as base64 PNG
    data URIs, no JavaScript, a table of contents and the errata of all sections in one table.
``results.json``
    Every section's ``results`` keyed by section title, the errata, and metadata (physid version,
    date, quick flag). Strict JSON (no NaN: non-finite numbers become ``null``).
``NAME.png``
    Each figure, also as a standalone file.

Every number shown in a report table is a cell of a `Table`, and `write_report` also stores each
table's rows in ``results.json`` (under ``"tables"``), so a test can check that the page and the
JSON agree.

Example
-------
>>> import tempfile, matplotlib.figure
>>> fig = matplotlib.figure.Figure(figsize=(2, 2)); _ = fig.add_subplot().plot([0, 1], [0, 1])
>>> sec = ReportSection("A test", paragraphs=("Hello & welcome.",),
...                     tables=(Table("Values", ("name", "value"), (("k", 2.0),)),),
...                     figures=(FigureSpec("line", fig, "A line."),), results={"k": 2.0})
>>> paths = write_report([sec], tempfile.mkdtemp())
>>> paths.html.name, paths.json.name, [p.name for p in paths.figures]
('report.html', 'results.json', ['line.png'])
"""

from __future__ import annotations

import base64
import datetime as _dt
import functools
import html as _html
import json
import math
import os
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._paths import atomic_write
from ..errors import InputError
from ..estimators.results import jsonable
from ..experiments.data import Cell, Erratum, Table
from .style import DPI, describe_figure, figure_png

__all__ = [
    "Html",
    "ReportSection",
    "Table",
    "FigureSpec",
    "Erratum",
    "ReportPaths",
    "format_cell",
    "write_report",
]

FIGURE_DPI = DPI
#: Tables with more rows than this are shown collapsed (``<details>``) behind a summary.
LONG_TABLE_ROWS = 20
_NAME_RE = re.compile(r"^[A-Za-z0-9_-]+$")


class Html(str):
    """A paragraph that is already HTML and is inserted as is (not escaped).

    Use it only for markup you wrote yourself (``<code>``, ``<em>``, links inside the page, a
    list); everything else in a report is escaped.
    """

    __slots__ = ()


@dataclass(frozen=True)
class FigureSpec:
    """A matplotlib figure to embed.

    Parameters
    ----------
    name : str
        File stem: letters, digits, ``-`` and ``_`` only; saved as ``NAME.png``. Unique per report.
    figure : matplotlib.figure.Figure
        The figure (closed after it is saved).
    caption : str
        One line saying what to see in the figure.
    alt : str
        Alternative text for readers who cannot see the image (what it shows and its main
        message); the caption is used when empty.
    """

    name: str
    figure: Any
    caption: str = ""
    alt: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME_RE.match(self.name):
            raise InputError(
                f"FigureSpec name must use only letters, digits, '-' and '_' (it becomes "
                f"NAME.png); got {self.name!r}. Rename the figure, e.g. 'fig2_responses'."
            )
        if not hasattr(self.figure, "savefig"):
            raise InputError(
                f"FigureSpec {self.name!r}: figure must be a matplotlib Figure (something with "
                f"savefig); got {type(self.figure).__name__}."
            )


@dataclass(frozen=True)
class ReportSection:
    """One section of the report, filled by an experiment.

    Parameters
    ----------
    title : str
        Section heading; also its key in ``results.json`` (must be unique in a report).
    paragraphs : sequence of str or Html
        Plain text (escaped) or `Html` (inserted as is).
    tables : sequence of Table
    figures : sequence of FigureSpec
    results : mapping
        The numbers of this section (JSON-ready after `physid.estimators.results.jsonable`).
    errata : sequence of Erratum
    part : str
        The part of the report the section belongs to (``"Part I — ..."``); consecutive
        sections of one part are grouped under its heading. Empty: no part.
    """

    title: str
    paragraphs: Sequence[str] = ()
    tables: Sequence[Table] = ()
    figures: Sequence[FigureSpec] = ()
    results: Mapping[str, Any] = field(default_factory=dict)
    errata: Sequence[Erratum] = ()
    part: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.title, str) or not self.title.strip():
            raise InputError(f"ReportSection title must be a non-empty string; got {self.title!r}.")
        if isinstance(self.paragraphs, str):
            raise InputError(
                f"ReportSection {self.title!r}: paragraphs must be a sequence of strings, not one "
                "string; wrap it: paragraphs=(text,)."
            )
        for name, kind in (("tables", Table), ("figures", FigureSpec), ("errata", Erratum)):
            items = tuple(getattr(self, name))
            for item in items:
                if not isinstance(item, kind):
                    raise InputError(
                        f"ReportSection {self.title!r}: {name} must hold {kind.__name__} objects; "
                        f"got {type(item).__name__}."
                    )
            object.__setattr__(self, name, items)
        object.__setattr__(self, "paragraphs", tuple(self.paragraphs))
        if not isinstance(self.results, Mapping):
            raise InputError(
                f"ReportSection {self.title!r}: results must be a mapping name -> value; got "
                f"{type(self.results).__name__}."
            )


@dataclass(frozen=True)
class ReportPaths:
    """Where `write_report` put its outputs.

    Attributes
    ----------
    html : Path
        The self-contained report.html.
    json : Path
        results.json.
    figures : tuple of Path
        The PNG files.
    """

    html: Path
    json: Path
    figures: tuple[Path, ...]


def format_cell(cell: Cell) -> str:
    """The text shown for a table cell.

    Floats get 6 significant digits (``1234.5678 -> '1234.57'``, ``1e-9 -> '1e-09'``), non-finite
    floats are written ``nan``/``inf``, ``None`` is an em dash, strings and ints are unchanged.

    >>> [format_cell(x) for x in (1234.5678, 3, None, "a", float("nan"))]
    ['1234.57', '3', '—', 'a', 'nan']
    """
    if cell is None:
        return "—"
    if isinstance(cell, float):
        if math.isnan(cell):
            return "nan"
        if math.isinf(cell):
            return "inf" if cell > 0 else "-inf"
        return f"{cell:.6g}"
    return str(cell)


# --------------------------------------------------------------------------------------------
# Writing files


def _figure_png(figure: Any) -> bytes:
    return figure_png(figure)


def _slug(title: str, used: set[str]) -> str:
    base = re.sub(r"[^a-z0-9]+", "-", title.lower()).strip("-") or "section"
    slug, i = base, 2
    while slug in used:
        slug, i = f"{base}-{i}", i + 1
    used.add(slug)
    return slug


# --------------------------------------------------------------------------------------------
# HTML

_CSS = """
:root { --fg:#1d2329; --muted:#5b6670; --line:#d5dbe0; --bg:#ffffff; --band:#f4f6f8;
        --accent:#1f5f99; }
* { box-sizing: border-box; }
html { -webkit-text-size-adjust: 100%; }
body { margin: 0; background: var(--bg); color: var(--fg);
       font: 16px/1.55 system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial,
             sans-serif; }
main { max-width: 1040px; margin: 0 auto; padding: 1.5rem 1.25rem 4rem; }
h1 { font-size: 1.9rem; margin: 0.5rem 0 0.25rem; line-height: 1.2; }
h2 { font-size: 1.4rem; margin: 2.5rem 0 0.75rem; padding-top: 0.75rem;
     border-top: 2px solid var(--line); line-height: 1.25; }
h3 { font-size: 1.1rem; margin: 1.5rem 0 0.5rem; }
p { margin: 0.6rem 0; max-width: 80ch; }
a { color: var(--accent); }
code { font-family: ui-monospace, "SFMono-Regular", Menlo, Consolas, monospace;
       font-size: 0.92em; background: var(--band); padding: 0.05em 0.3em; border-radius: 3px; }
pre { overflow-x: auto; max-width: 100%; background: var(--band); padding: 0.6rem 0.8rem;
      border-radius: 6px; font-size: 0.88rem; }
pre code { background: none; padding: 0; }
.meta { color: var(--muted); font-size: 0.92rem; margin: 0 0 1rem; }
nav.toc { background: var(--band); border: 1px solid var(--line); border-radius: 6px;
          padding: 0.75rem 1.25rem; margin: 1rem 0 1.5rem; }
nav.toc h2 { border: 0; margin: 0 0 0.25rem; padding: 0; font-size: 1.05rem; }
nav.toc ol { margin: 0; padding-left: 1.4rem; }
nav.toc ol.sections { list-style: none; padding-left: 0.5rem; font-size: 0.88rem; }
nav.toc ol.sections li { display: inline; }
nav.toc ol.sections li + li::before { content: " · "; color: var(--muted); }
.table-wrap { overflow-x: auto; margin: 0.75rem 0 1.25rem; border: 1px solid var(--line);
              border-radius: 6px; }
table { border-collapse: collapse; width: 100%; font-size: 0.92rem; }
caption { caption-side: top; text-align: left; font-weight: 600; padding: 0.5rem 0.75rem; }
th, td { padding: 0.35rem 0.75rem; border-top: 1px solid var(--line); text-align: left;
         vertical-align: top; }
th { background: var(--band); white-space: nowrap; }
th.num { text-align: right; }
/* Break long text only between words (inside a word only when the word alone is wider than
   the column); break-word does not shrink columns below their longest word. */
td:not(.num) { overflow-wrap: break-word; word-break: normal; hyphens: auto; min-width: 4em; }
table.errata td:first-child { white-space: nowrap; }
table.errata th:nth-child(2), table.errata td:nth-child(2) { min-width: 8.5em; }
/* Tables with many columns (and the errata) stay inside the text column: their headers wrap,
   and what still does not fit scrolls inside the table's box, never past the page. */
.table-wrap { max-width: 100%; }
.table-wrap.wide th { white-space: normal; min-width: 4.5em; }
caption { position: sticky; left: 0; max-width: calc(min(100vw, 1040px) - 4rem);
          white-space: normal; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
figure { margin: 1rem 0 1.5rem; }
figure img { display: block; max-width: 100%; height: auto; margin: 0 auto;
             border: 1px solid var(--line); border-radius: 4px; }
figcaption { color: var(--muted); font-size: 0.92rem; margin-top: 0.4rem; }
.part > h2.part-title { font-size: 1.6rem; border-top: 4px solid var(--accent);
                        margin-top: 3rem; }
.part section > h3 { font-size: 1.2rem; margin: 2rem 0 0.6rem; padding-top: 0.5rem;
                     border-top: 1px solid var(--line); }
details.long-table { margin: 0.5rem 0 1.25rem; }
details.fold > summary { cursor: pointer; color: var(--accent); font-weight: 600;
                         margin: 0.4rem 0 0.8rem; }
details.fold > summary .titles { color: var(--muted); font-weight: 400; font-size: 0.9em; }
.part-lead { font-size: 1.02rem; }
details.long-table > summary { cursor: pointer; color: var(--accent); font-weight: 600; }
table.summary caption { font-weight: 600; }
figcaption .file { color: var(--muted); font-size: 0.85em; }
.headline { border: 1px solid var(--line); border-radius: 6px;
            padding: 0.5rem 1rem 0.5rem 2.2rem; background: var(--band); }
.headline li { margin: 0.3rem 0; }
footer { margin-top: 3rem; color: var(--muted); font-size: 0.85rem; }
@media (max-width: 600px) { body { font-size: 15px; } main { padding: 1rem 0.75rem 3rem; } }
@media print { nav.toc { display: none; } h2 { break-after: avoid; }
               figure { break-inside: avoid; } }
"""


def _esc(text: Any) -> str:
    return _html.escape(str(text), quote=True)


def _paragraph(p: str) -> str:
    if isinstance(p, Html):
        body = str(p)
        # Block-level HTML (a list, a pre) is inserted without a <p> around it.
        if re.match(r"\s*<(ul|ol|pre|div|table|dl|blockquote)\b", body):
            return body
        return f"<p>{body}</p>"
    return f"<p>{_esc(p)}</p>"


#: Tables with at least this many columns get the full page width (class "wide").
WIDE_TABLE_COLUMNS = 7


def _table_html(table: Table, css_class: str = "") -> str:
    if len(table.rows) > LONG_TABLE_ROWS and css_class != "errata":
        return _long_table_html(table)
    return _plain_table_html(table, css_class)


def _long_table_html(table: Table) -> str:
    """A long table collapsed behind its summary row (or its row count)."""
    out = []
    if table.summary is not None:
        out.append(
            _plain_table_html(
                Table(f"Summary: {table.caption}", table.columns, (table.summary,)), "summary"
            )
        )
    out.append(
        f'<details class="long-table"><summary>{_esc(table.caption)} — all '
        f"{len(table.rows)} rows</summary>"
    )
    out.append(_plain_table_html(table))
    out.append("</details>")
    return "\n".join(out)


def _plain_table_html(table: Table, css_class: str = "") -> str:
    opening = f'<table class="{css_class}">' if css_class else "<table>"
    wide = len(table.columns) >= WIDE_TABLE_COLUMNS or css_class == "errata"
    wrap = '<div class="table-wrap wide">' if wide else '<div class="table-wrap">'
    out = [wrap + opening, f"<caption>{_esc(table.caption)}</caption>"]
    numeric = [
        any(isinstance(r[j], (int, float)) for r in table.rows)
        and all(r[j] is None or isinstance(r[j], (int, float)) for r in table.rows)
        for j in range(len(table.columns))
    ]
    out.append(
        "<thead><tr>"
        + "".join(
            ('<th scope="col" class="num">' if is_num else '<th scope="col">') + f"{_esc(c)}</th>"
            for c, is_num in zip(table.columns, numeric, strict=True)
        )
        + "</tr></thead><tbody>"
    )
    for row in table.rows:
        cells = []
        for cell in row:
            cls = ' class="num"' if isinstance(cell, (int, float)) else ""
            cells.append(f"<td{cls}>{_esc(format_cell(cell))}</td>")
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</tbody></table></div>")
    return "\n".join(out)


def _figure_html(name: str, png: bytes, caption: str, alt: str = "") -> str:
    data = base64.b64encode(png).decode("ascii")
    alt = alt or caption or name
    return (
        f'<figure id="fig-{_esc(name)}"><img src="data:image/png;base64,{data}" '
        f'alt="{_esc(alt)}" data-name="{_esc(name)}" loading="eager">'
        f'<figcaption>{_esc(caption)} <span class="file">({_esc(name)}.png)</span>'
        "</figcaption></figure>"
    )


def errata_table(errata: Iterable[Erratum]) -> Table | None:
    """One table of errata grouped by paper (paper order of first appearance); None if empty."""
    errata = list(errata)
    if not errata:
        return None
    papers: list[str] = []
    for e in errata:
        if e.paper not in papers:
            papers.append(e.paper)
    rows = [
        (e.paper, e.location, e.printed, e.correct, e.evidence)
        for paper in papers
        for e in errata
        if e.paper == paper
    ]
    return Table(
        "Errata found in the papers (grouped by paper)",
        ("paper", "where", "printed", "correct", "evidence"),
        rows,
    )


def _check_sections(sections: Sequence[ReportSection]) -> None:
    titles: set[str] = set()
    names: set[str] = set()
    for s in sections:
        if not isinstance(s, ReportSection):
            raise InputError(
                f"write_report expects ReportSection objects; got {type(s).__name__}. Build "
                "sections with physid.report.html.ReportSection(title, ...)."
            )
        if s.title in titles:
            raise InputError(
                f"two report sections are titled {s.title!r}; titles key results.json, so make "
                "them unique."
            )
        titles.add(s.title)
        try:
            json.dumps(jsonable(dict(s.results)), allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise InputError(
                f"the results of section {s.title!r} cannot be written as JSON ({exc}); give "
                "numbers, strings, booleans, None, lists, dicts or numpy arrays."
            ) from None
        for f in s.figures:
            if f.name in names:
                raise InputError(
                    f"two figures are named {f.name!r} (section {s.title!r}); figure names become "
                    "file names, so make them unique."
                )
            names.add(f.name)


def _check_errata_after(errata_after: Any, n_sections: int) -> None:
    """Raise `InputError` unless ``errata_after`` is an int in 0..``n_sections``."""
    if (
        isinstance(errata_after, bool)
        or not isinstance(errata_after, int)
        or not (0 <= errata_after <= n_sections)
    ):
        raise InputError(
            f"errata_after must be an int between 0 and the number of sections "
            f"({n_sections}); got {errata_after!r}."
        )


def _write_figures(sections, out: Path, progress):
    """Write one PNG per figure into ``out``.

    Returns the paths (in report order), each figure's PNG bytes and its description, by name.
    """
    figure_paths: list[Path] = []
    pngs: dict[str, bytes] = {}
    figure_info: dict[str, dict[str, Any]] = {}
    for s in sections:
        for f in s.figures:
            figure_info[f.name] = {
                **describe_figure(f.figure),
                "caption": f.caption,
                "alt": f.alt or f.caption,
                "section": s.title,
            }
            png = _figure_png(f.figure)
            path = out / f"{f.name}.png"
            atomic_write(path, lambda fh, data=png: fh.write(data), binary=True)
            figure_paths.append(path)
            pngs[f.name] = png
            if progress:
                progress(f"report: wrote {path.name}")
    return figure_paths, pngs, figure_info


def _write_json(json_path: Path, meta: dict, sections, all_errata) -> Path:
    """Write ``results.json``: the metadata, and each section's results, tables, paragraphs."""
    payload = {
        "metadata": meta,
        "results": {s.title: dict(s.results) for s in sections},
        "tables": {
            s.title: [
                {
                    "caption": t.caption,
                    "columns": list(t.columns),
                    "rows": [list(r) for r in t.rows],
                    **({} if t.summary is None else {"summary": list(t.summary)}),
                }
                for t in s.tables
            ]
            for s in sections
        },
        "paragraphs": {s.title: [str(p) for p in s.paragraphs] for s in sections},
        "errata": [e for e in all_errata],
    }
    text = json.dumps(jsonable(payload), indent=2, allow_nan=False, ensure_ascii=False)
    atomic_write(json_path, lambda fh: fh.write(text + "\n"))
    return json_path


def _head_html(title: str, version: str, created, quick, intro) -> list[str]:
    """The page's head, its header and the introductory paragraphs."""
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f'<meta name="generator" content="physid {_esc(version)}">',
        f"<title>{_esc(title)}</title>",
        f"<style>{_CSS}</style>",
        "</head>",
        "<body>",
        "<main>",
        f"<header><h1>{_esc(title)}</h1>",
        f'<p class="meta">physid {_esc(version)} · generated {_esc(created.isoformat())}'
        + ("" if quick is None else f" · {'quick run' if quick else 'full run'}")
        + " · numbers also in <code>results.json</code></p></header>",
    ]
    if intro is not None:
        intros = [intro] if isinstance(intro, str) else list(intro)
        parts.extend(_paragraph(p) for p in intros)
    return parts


def _toc_html(sections, slugs, part_slugs, lead, errata_after, has_errata) -> list[str]:
    """The table of contents: the sections after the first ``lead``, nested by part."""
    errata_entry = '<li><a href="#errata">Errata found in the papers</a></li>'
    toc = ['<nav class="toc" id="toc"><h2>Contents</h2><ol>']
    open_part = ""
    for i, (s, slug) in enumerate(zip(sections, slugs, strict=True)):
        if i < lead:
            continue
        if s.part != open_part:
            if open_part:
                toc.append("</ol></li>")
            if s.part:
                toc.append(
                    f'<li><a href="#{part_slugs[s.part]}">{_esc(s.part)}</a><ol class="sections">'
                )
            open_part = s.part
        if i == errata_after and has_errata:
            toc.append(errata_entry)
        toc.append(f'<li><a href="#{slug}">{_esc(s.title)}</a></li>')
    if open_part:
        toc.append("</ol></li>")
    if errata_after == len(sections) and has_errata:
        toc.append(errata_entry)
    toc.append("</ol></nav>")
    return toc


def _errata_html(errata_tab: Table | None, n_errata: int, last: bool) -> list[str]:
    """The aggregated errata section (nothing when there are no errata)."""
    if errata_tab is None:
        return []
    where = "above" if last else "below"
    return [
        '<section id="errata"><h2>Errata found in the papers</h2>',
        f"<p>{n_errata} misprint(s) or error(s), each with the evidence; the "
        f"sections {where} show the details.</p>",
        _fold("Show the errata table", ["errata"]),
        _table_html(errata_tab, "errata"),
        "</details>",
        "</section>",
    ]


def _section_html(s, slug, pngs, *, skip_first: bool = False) -> list[str]:
    """One section: heading, paragraphs, tables and figures (``skip_first``: its first
    paragraph is shown above a fold instead)."""
    heading = "h3" if s.part else "h2"
    out = [f'<section id="{slug}"><{heading}>{_esc(s.title)}</{heading}>']
    out.extend(_paragraph(p) for p in list(s.paragraphs)[1 if skip_first else 0 :])
    out.extend(_table_html(t) for t in s.tables)
    out.extend(_figure_html(f.name, pngs[f.name], f.caption, f.alt) for f in s.figures)
    out.append("</section>")
    return out


def _fold(summary: str, titles: Sequence[str]) -> str:
    shown = " · ".join(_esc(t) for t in titles)
    return (
        f'<details class="fold"><summary>{_esc(summary)} '
        f'<span class="titles">({shown})</span></summary>'
    )


def _body_html(sections, slugs, part_slugs, lead, errata_after, toc, errata_html, pngs):
    """The sections in order, grouped by part, with the contents and the errata in place.

    The first ``lead`` sections are shown in full. After them each part shows its heading and
    the first paragraph of its first section (its headline numbers); the rest of the part is
    folded (``<details>``), and so is every other section below its first paragraph, so the
    page opens at a few screens. A link to a folded section opens its fold (browsers expand
    ``<details>`` around a fragment target; the page has no script).
    """
    parts: list[str] = []
    open_part, part_folded = "", False
    for i, (s, slug) in enumerate(zip(sections, slugs, strict=True)):
        if i == lead:
            parts.extend(toc)
        if s.part != open_part:
            if open_part:
                parts.append("</details></div>" if part_folded else "</div>")
            if s.part:
                parts.append(
                    f'<div class="part" id="{part_slugs[s.part]}">'
                    f'<h2 class="part-title">{_esc(s.part)}</h2>'
                )
                part_folded = i >= lead
                if part_folded:
                    members = [x.title for x in sections[i:] if x.part == s.part]
                    if s.paragraphs:
                        parts.append(
                            _paragraph(s.paragraphs[0]).replace("<p>", '<p class="part-lead">', 1)
                        )
                    parts.append(_fold(f"Show {s.part.split(' —')[0]}", members))
            open_part = s.part
        if i == errata_after:
            parts.extend(errata_html(last=False))
        folded_part = bool(s.part) and i >= lead
        first_of_part = folded_part and (i == 0 or sections[i - 1].part != s.part)
        if folded_part or i < lead or not (s.tables or s.figures or len(s.paragraphs) > 1):
            parts.extend(_section_html(s, slug, pngs, skip_first=first_of_part))
            continue
        # a section outside the parts, after the lead: its first paragraph, the rest folded
        body = _section_html(s, slug, pngs, skip_first=True)
        lead_text = [_paragraph(s.paragraphs[0])] if s.paragraphs else []
        parts.extend([body[0], *lead_text, _fold("Show the details", [s.title]), *body[1:-1]])
        parts.extend(["</details>", body[-1]])
    if open_part:
        parts.append("</details></div>" if part_folded else "</div>")
    if lead >= len(sections):
        parts.extend(toc)
    if errata_after == len(sections):
        parts.extend(errata_html(last=True))
    return parts


def write_report(
    sections: Sequence[ReportSection],
    out_dir: str | os.PathLike,
    title: str = "physid report",
    intro: str | Sequence[str] | None = None,
    *,
    errata_after: int = 0,
    lead: int = 0,
    metadata: Mapping[str, Any] | None = None,
    quick: bool | None = None,
    progress: Callable[[str], None] | None = None,
) -> ReportPaths:
    """Write ``report.html``, ``results.json`` and one PNG per figure into ``out_dir``.

    Parameters
    ----------
    sections : sequence of ReportSection
        In display order. Titles and figure names must be unique.
    out_dir : path
        Created if missing. Existing files of the same names are replaced atomically.
    title : str
        Page title and top heading.
    intro : str, Html or sequence of them, optional
        Paragraphs shown under the title, before the table of contents.
    errata_after : int
        How many sections come before the aggregated errata section (0: right after the table
        of contents; 1: after an introductory section).
    lead : int
        How many sections are shown before the table of contents (e.g. a one-screen summary).
    metadata : mapping, optional
        Extra JSON-ready metadata merged into ``results.json["metadata"]``.
    quick : bool, optional
        Recorded in the metadata (whether the report came from a quick run).
    progress : callable, optional
        Called with a short message per figure written.

    Returns
    -------
    ReportPaths
        ``html``, ``json`` and ``figures`` (PNG paths, in report order).

    Raises
    ------
    InputError
        A section is not a `ReportSection`, or titles or figure names repeat.

    Notes
    -----
    The errata of all sections are collected, grouped by paper, into one table in the section
    "Errata found in the papers", placed after the first ``errata_after`` sections. Figures are
    closed after saving.
    """
    from .. import __version__

    sections = list(sections)
    _check_sections(sections)
    _check_errata_after(errata_after, len(sections))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)

    used: set[str] = {"errata", "toc"}
    slugs = [_slug(s.title, used) for s in sections]
    all_errata = [e for s in sections for e in s.errata]
    errata_tab = errata_table(all_errata)
    created = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0)

    # Figures first: PNG files and their bytes for embedding.
    figure_paths, pngs, figure_info = _write_figures(sections, out, progress)

    meta = {
        "physid_version": __version__,
        "created": created.isoformat(),
        "quick": quick,
        "title": title,
        "figures": [p.name for p in figure_paths],
        "figure_info": figure_info,
    }
    if metadata:
        meta.update(dict(metadata))
    json_path = _write_json(out / "results.json", meta, sections, all_errata)

    parts = _head_html(title, __version__, created, quick, intro)
    part_slugs = {}
    for s in sections:
        if s.part and s.part not in part_slugs:
            part_slugs[s.part] = _slug(s.part, used)
    toc = _toc_html(sections, slugs, part_slugs, lead, errata_after, errata_tab is not None)
    errata_html = functools.partial(_errata_html, errata_tab, len(all_errata))
    parts += _body_html(sections, slugs, part_slugs, lead, errata_after, toc, errata_html, pngs)
    parts.append(
        f"<footer>Written by physid {_esc(__version__)}. Figures: "
        f"{len(figure_paths)} PNG file(s) beside this page; all numbers: results.json.</footer>"
    )
    parts.extend(["</main>", "</body>", "</html>"])
    html_path = out / "report.html"
    atomic_write(html_path, lambda fh: fh.write("\n".join(parts) + "\n"))
    return ReportPaths(html=html_path, json=json_path, figures=tuple(figure_paths))
