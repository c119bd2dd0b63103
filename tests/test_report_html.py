"""The HTML report writer: structure, embedding, escaping, numbers, errors, rendering.

The checks below (`parse_report`, `assert_tables_match_json`, `render_in_chromium`) are
independent of the writer (html.parser and Chromium, not physid code) and are reused by
tests/test_demo.py on the real demo report.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
import re
import shutil
import struct
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

import physid  # noqa: E402
from physid.errors import InputError  # noqa: E402
from physid.report.html import (  # noqa: E402
    LONG_TABLE_ROWS,
    WIDE_TABLE_COLUMNS,
    Erratum,
    FigureSpec,
    Html,
    ReportSection,
    Table,
    format_cell,
    write_report,
)

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
VOID = {"meta", "img", "br", "hr", "link", "input", "col", "source", "wbr"}


# ---------------------------------------------------------------------------------------------
# Independent checkers (html.parser and Chromium)


class _ReportParser(HTMLParser):
    """Collects tags, images, tables and problems from a report page."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.problems: list[str] = []
        self.tags: list[str] = []
        self.images: list[dict] = []
        self.tables: list[dict] = []
        self.pres: dict[str, str] = {}
        self._table = None
        self._row = None
        self._cell = None
        self._caption = None
        self._pre = None

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        self.tags.append(tag)
        for key in ("src", "href", "action", "srcset", "poster", "data"):
            value = (attrs.get(key) or "").strip().lower()
            if value.startswith(("http:", "https:", "//", "ftp:")):
                self.problems.append(f"external resource <{tag} {key}={value[:60]!r}>")
        if tag == "link" or (tag == "script" and attrs.get("src")):
            self.problems.append(f"<{tag}> loads a separate resource: {attrs}")
        if tag == "img":
            self.images.append(attrs)
        if tag == "table":
            self._table = {"caption": "", "header": [], "rows": []}
        elif tag == "caption":
            self._caption = []
        elif tag == "tr":
            self._row = []
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "pre":
            self._pre = (attrs.get("id") or "", [])
        if tag not in VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag, attrs):
        self.handle_starttag(tag, attrs)
        if tag not in VOID:
            self.stack.pop()

    def handle_endtag(self, tag):
        if tag in VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.problems.append(f"unbalanced </{tag}>; open: {self.stack[-4:]}")
            if tag in self.stack:  # recover so one error does not cascade
                while self.stack and self.stack.pop() != tag:
                    pass
            return
        self.stack.pop()
        if tag in ("td", "th") and self._cell is not None and self._row is not None:
            self._row.append(("th" if tag == "th" else "td", "".join(self._cell).strip()))
            self._cell = None
        elif tag == "tr" and self._row is not None and self._table is not None:
            if all(kind == "th" for kind, _ in self._row):
                self._table["header"] = [text for _, text in self._row]
            else:
                self._table["rows"].append([text for _, text in self._row])
            self._row = None
        elif tag == "caption" and self._caption is not None and self._table is not None:
            self._table["caption"] = "".join(self._caption).strip()
            self._caption = None
        elif tag == "table" and self._table is not None:
            self.tables.append(self._table)
            self._table = None
        elif tag == "pre" and self._pre is not None:
            self.pres[self._pre[0]] = "".join(self._pre[1])
            self._pre = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)
        if self._caption is not None:
            self._caption.append(data)
        if self._pre is not None:
            self._pre[1].append(data)


def png_size(data: bytes) -> tuple[int, int]:
    """Width and height from a PNG's IHDR chunk (asserting the signature)."""
    assert data[:8] == PNG_SIGNATURE, "not a PNG (bad signature)"
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def parse_report(text: str) -> dict:
    """Parse a report page and assert it is well formed and self-contained.

    Returns ``{"tables": [...], "images": {name: png_bytes}, "tags": [...]}``.
    """
    parser = _ReportParser()
    parser.feed(text)
    parser.close()
    assert not parser.problems, parser.problems
    assert not parser.stack, f"unclosed tags at the end: {parser.stack}"
    assert text.lstrip().lower().startswith("<!doctype html>")
    for tag in ("html", "head", "body", "main", "title", "style", "nav"):
        assert tag in parser.tags, f"missing <{tag}>"
    lowered = text.lower()
    for pattern in ("@import", "url(http", "url(//", "<script"):
        assert pattern not in lowered, f"report contains {pattern!r}"
    images = {}
    for attrs in parser.images:
        src = attrs.get("src", "")
        assert src.startswith("data:image/png;base64,"), f"image not embedded: {src[:60]!r}"
        data = base64.b64decode(src.split(",", 1)[1], validate=True)
        width, height = png_size(data)
        assert width > 0 and height > 0
        assert attrs.get("alt"), "every image needs alt text"
        images[attrs.get("data-name", f"#{len(images)}")] = data
    return {"tables": parser.tables, "images": images, "tags": parser.tags, "pres": parser.pres}


_NUMBER = re.compile(r"^[-+]?(\d+(\.\d*)?|\.\d+)([eE][-+]?\d+)?$")


def _cell_matches(shown: str, value) -> bool:
    """A shown cell agrees with its JSON value (floats to the 6 significant digits shown)."""
    if value is None:
        return shown in ("—", "nan", "inf", "-inf")
    if isinstance(value, bool):
        return shown == str(value)
    if isinstance(value, (int, float)):
        if not _NUMBER.match(shown):
            return False
        return math.isclose(float(shown), float(value), rel_tol=5e-6, abs_tol=0.0)
    return shown == str(value)


def assert_tables_match_json(parsed: dict, payload: dict) -> int:
    """Every cell of every section table in the page equals the same cell in results.json.

    Returns the number of numeric cells checked.
    """
    json_tables = [t for tables in payload["tables"].values() for t in tables]
    # The page may also hold the aggregated errata table; it is checked against payload["errata"].
    # A long table's visible summary row ("Summary: CAPTION") is checked against its "summary".
    summaries = {
        t["caption"].removeprefix("Summary: "): t
        for t in parsed["tables"]
        if t["caption"].startswith("Summary: ")
    }
    for stored in json_tables:
        if "summary" in stored and len(stored["rows"]) > LONG_TABLE_ROWS:
            shown = summaries.pop(stored["caption"])
            assert shown["rows"] == [[format_cell(c) for c in stored["summary"]]], stored["caption"]
    assert not summaries, f"summary tables without a long table: {list(summaries)}"
    page = [
        t for t in parsed["tables"] if not t["caption"].startswith(("Errata found", "Summary: "))
    ]
    assert [t["caption"] for t in page] == [t["caption"] for t in json_tables]
    n_numbers = 0
    for shown, stored in zip(page, json_tables, strict=True):
        assert shown["header"] == stored["columns"], stored["caption"]
        assert len(shown["rows"]) == len(stored["rows"]), stored["caption"]
        for row_shown, row_stored in zip(shown["rows"], stored["rows"], strict=True):
            assert len(row_shown) == len(row_stored)
            for cell_shown, cell_stored in zip(row_shown, row_stored, strict=True):
                assert _cell_matches(cell_shown, cell_stored), (
                    f"table {stored['caption']!r}: page shows {cell_shown!r}, "
                    f"results.json has {cell_stored!r}"
                )
                n_numbers += isinstance(cell_stored, (int, float)) and not isinstance(
                    cell_stored, bool
                )
        # Numbers shown in a page cell that look numeric must be numbers in the JSON too.
        for row_shown, row_stored in zip(shown["rows"], stored["rows"], strict=True):
            for cell_shown, cell_stored in zip(row_shown, row_stored, strict=True):
                if _NUMBER.match(cell_shown) and isinstance(cell_stored, str):
                    assert cell_shown == cell_stored
    errata_tables = [t for t in parsed["tables"] if t["caption"].startswith("Errata found")]
    if payload["errata"]:
        assert len(errata_tables) == 1
        rows = errata_tables[0]["rows"]
        assert sorted(map(tuple, rows)) == sorted(
            (e["paper"], e["location"], e["printed"], e["correct"], e["evidence"])
            for e in payload["errata"]
        )
    else:
        assert not errata_tables
    return n_numbers


_TAG = re.compile(r"<[^>]+>")
#: References to numbered things of the papers and years: not measurements.
_REFERENCE = re.compile(
    r"(Figs?\.|Eqs?\.|eqs?\.|[Ss]ections?|Part|Table|§|\(\d{4}\))\s*\(?[\d.–\-,A-Z ]*(and \d+)?"
)
_TEXT_NUMBER = re.compile(r"(?<![\w.^_/])[-+−]?\d+(?:\.\d+)?(?:[eE][-+−]?\d+)?(?![\w])")
#: A number in the text may be a results value as is, in percent, or in milli-units.
_SCALES = (1.0, 100.0, 1e3, 1e-3)


def _numbers(value, out: list[float]) -> list[float]:
    if isinstance(value, bool) or value is None:
        return out
    if isinstance(value, (int, float)):
        if math.isfinite(value):
            out.append(float(value))
    elif isinstance(value, dict):
        for v in value.values():
            _numbers(v, out)
    elif isinstance(value, (list, tuple)):
        for v in value:
            _numbers(v, out)
    return out


def _shown_matches(token: str, values: list[float]) -> bool:
    """``token`` (as printed) is one of ``values`` rounded to the digits it shows."""
    text = token.replace("−", "-").lstrip("+").lower()
    mantissa, _, exponent = text.partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    half_step = 0.5 * 10.0 ** (int(exponent or 0) - decimals)
    shown = abs(float(text))
    return any(
        abs(abs(v) * scale - shown) <= half_step * (1 + 1e-9) + 1e-12 * shown
        for v in values
        for scale in _SCALES
    )


def paragraph_number_problems(payload: dict) -> tuple[list[str], int]:
    """Numbers written in paragraphs that are not numbers of their section in results.json.

    Every number token in a section's paragraphs (tags stripped; code blocks, figure/equation/
    section references and years excluded) must equal, at the precision shown, a number of that
    section's ``results`` or tables (as is, ×100 for percent or ×1000 for milli-units).
    Returns the problems and the number of tokens checked.
    """
    problems, checked = [], 0
    for title, paragraphs in payload["paragraphs"].items():
        values = _numbers(payload["results"].get(title, {}), [])
        for table in payload["tables"].get(title, []):
            values = _numbers(table["rows"], values)
        for p in paragraphs:
            # commands and quoted messages (code), not numbers of the results
            text = re.sub(r"<(pre|code)>.*?</\1>", " ", p, flags=re.S)
            text = _REFERENCE.sub(" ", html.unescape(_TAG.sub(" ", text)))
            for m in _TEXT_NUMBER.finditer(text):
                checked += 1
                if not _shown_matches(m.group(0), values):
                    around = text[max(0, m.start() - 50) : m.end() + 20]
                    problems.append(f"{title}: {m.group(0)!r} in ...{around}...")
    return problems, checked


def figure_problems(payload: dict) -> list[str]:
    """Figures without a title, a caption, alt text, or axis labels with units."""
    problems = []
    info = payload["metadata"].get("figure_info", {})
    for name in payload["metadata"]["figures"]:
        fig = info.get(name[:-4] if name.endswith(".png") else name)
        if fig is None:
            problems.append(f"{name}: no figure_info")
            continue
        if not fig["caption"].strip():
            problems.append(f"{name}: no caption")
        if not fig["alt"].strip() or fig["alt"] == fig["caption"]:
            problems.append(f"{name}: no alt text of its own")
        if not fig["title"] and not all(a["title"] for a in fig["axes"]):
            problems.append(f"{name}: no title")
        for i, a in enumerate(fig["axes"]):
            for key in ("xlabel", "ylabel"):
                if "[" not in a[key]:
                    problems.append(f"{name}: axes {i} {key} {a[key]!r} has no unit in brackets")
    return problems


CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome")

_CHECK_SCRIPT = """<script>
(function () {
  var errors = [];
  window.addEventListener('error', function (e) {
    var t = e.target;
    if (t && t !== window && t.tagName) { errors.push('failed to load <' + t.tagName + '>'); }
    else { errors.push('error: ' + e.message); }
  }, true);
  var original = console.error;
  console.error = function () {
    errors.push('console.error: ' + Array.prototype.join.call(arguments, ' '));
    return original.apply(console, arguments);
  };
  function scrolls(el) {
    for (var e = el.parentElement; e; e = e.parentElement) {
      var o = getComputedStyle(e).overflowX;
      if (o === 'auto' || o === 'scroll' || o === 'hidden') { return true; }
    }
    return false;
  }
  function tooWide() {
    var width = document.documentElement.clientWidth, out = [];
    document.querySelectorAll('main *').forEach(function (el) {
      var r = el.getBoundingClientRect();
      if (r.width > 0 && (r.right > width + 1 || r.left < -1) && !scrolls(el)) {
        out.push(el.tagName + (el.id ? '#' + el.id : '') + ' ' + Math.round(r.left) + '..' +
                 Math.round(r.right));
      }
    });
    return out.slice(0, 20);
  }
  window.addEventListener('load', function () {
    var imgs = Array.prototype.slice.call(document.images);
    var loaded = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; });
    var pre = document.createElement('pre');
    pre.id = 'physid-check';
    pre.textContent = JSON.stringify({
      images: imgs.length,
      loaded: loaded.length,
      widths: imgs.map(function (i) { return i.naturalWidth; }),
      not_loaded: imgs.filter(function (i) { return loaded.indexOf(i) < 0; })
                      .map(function (i) { return i.getAttribute('data-name'); }),
      errors: errors,
      scroll_width: document.documentElement.scrollWidth,
      client_width: document.documentElement.clientWidth,
      too_wide: tooWide(),
      parts: Array.prototype.map.call(document.querySelectorAll('main > .part, main > section'),
        function (p) { var r = p.getBoundingClientRect();
                       return {id: p.id, left: r.left, right: r.right, width: p.scrollWidth}; })
    });
    document.body.appendChild(pre);
  });
})();
</script>"""


def screenshot_parts(report: Path, workdir: Path, width: int = 1280) -> dict[str, Path]:
    """A PNG screenshot of each part of the report at ``width`` px (one Chromium run per part).

    Each part (``div.part`` and top-level sections) is shown alone in a copy of the page.
    """
    chromium = find_chromium()
    if chromium is None:
        pytest.skip(
            "Chromium is not installed; `make test` installs it (tools/ensure_chromium.py)."
        )
    text = report.read_text(encoding="utf-8")
    ids = re.findall(r'<div class="part" id="([^"]+)"', text)
    shots = {}
    for part in ids:
        page = workdir / f"part-{part}.html"
        hide = f"<style>main > *:not(header):not(#{part}) {{ display: none !important; }}</style>"
        page.write_text(text.replace("</head>", hide + "</head>", 1), encoding="utf-8")
        png = workdir / f"part-{part}.png"
        cmd = [
            chromium,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            f"--user-data-dir={workdir / 'chromium-profile'}",
            f"--window-size={width},6000",
            f"--screenshot={png}",
            page.resolve().as_uri(),
        ]
        env = dict(os.environ, DBUS_SESSION_BUS_ADDRESS="disabled:")
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=env)
        assert proc.returncode == 0 and png.exists(), proc.stderr[-2000:]
        shots[part] = png
    return shots


def find_chromium() -> str | None:
    for name in CHROMIUM_NAMES:
        path = shutil.which(name)
        if path:
            return path
    return None


def render_in_chromium(report: Path, workdir: Path) -> tuple[dict, str]:
    """Load a copy of ``report`` (with a checking script) in headless Chromium.

    Returns the check record written by the page (images, loaded, errors, ...) and Chromium's
    console lines from stderr. Skips only when no Chromium is installed.
    """
    chromium = find_chromium()
    if chromium is None:
        pytest.skip(
            "Chromium is not installed (looked for chromium, chromium-browser, google-chrome on "
            "PATH); `make test` installs Debian's chromium via tools/ensure_chromium.py."
        )
    text = report.read_text(encoding="utf-8")
    assert "<head>" in text
    page = workdir / "report-check.html"
    page.write_text(text.replace("<head>", "<head>" + _CHECK_SCRIPT, 1), encoding="utf-8")
    profile = workdir / "chromium-profile"
    cmd = [
        chromium,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={profile}",
        "--enable-logging=stderr",
        "--v=0",
        "--window-size=1280,900",
        "--virtual-time-budget=5000",
        "--dump-dom",
        page.resolve().as_uri(),
    ]
    env = dict(os.environ, DBUS_SESSION_BUS_ADDRESS="disabled:")
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0, f"chromium exited {proc.returncode}: {proc.stderr[-2000:]}"
    console = [
        line for line in proc.stderr.splitlines() if ":CONSOLE" in line or "Uncaught" in line
    ]
    parsed = _ReportParser()
    parsed.feed(proc.stdout)
    assert "physid-check" in parsed.pres, (
        "the check script did not run (no <pre id=physid-check> in the dumped DOM); "
        f"stdout starts {proc.stdout[:300]!r}"
    )
    return json.loads(parsed.pres["physid-check"]), "\n".join(console)


# ---------------------------------------------------------------------------------------------
# Fixtures


def _tiny_figure(label: str):
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.plot([0.0, 1.0, 2.0], [0.0, 1.0, 4.0], label=label)
    ax.set_xlabel("t [s]")
    ax.legend()
    return fig


def _sections():
    stiffness = 2.0 * math.pi**2  # an irrational number: tests the 6-digit formatting
    a = ReportSection(
        "Manipulator: stand-in",
        paragraphs=(
            "Plain text with <tags> & ampersands is escaped.",
            Html("A <em>marked</em> paragraph with <code>m1*l1**2</code>."),
        ),
        tables=(
            Table(
                "Estimates <beside> the paper",
                ("parameter", "estimate", "paper", "evaluations"),
                (
                    ("m1", 50.123456789, 50.1, 1450),
                    ("l1 & l2", 0.4, None, 12),
                    ("k", stiffness, float("nan"), 0),
                ),
            ),
        ),
        figures=(FigureSpec("fig_line", _tiny_figure("a"), "A <line> & more."),),
        results={"m1": 50.123456789, "k": stiffness, "nan_value": float("nan")},
        errata=(Erratum("Paper B", "Eq. (3)", "x < y", "x > y", "sympy"),),
    )
    b = ReportSection(
        "MSD: stand-in",
        paragraphs=("Second section.",),
        tables=(
            Table(
                "Small numbers",
                ("what", "value"),
                (("tiny", 1.23456789e-9), ("huge", -9.87654321e12)),
            ),
        ),
        figures=(FigureSpec("fig-two", _tiny_figure("b"), "Second figure."),),
        results={"tiny": 1.23456789e-9},
        errata=(
            Erratum("Paper A", "Table 1", "0.5", "0.25", "fig-two"),
            Erratum("Paper B", "Fig. 4", "label k", "label c", "fig_line"),
        ),
    )
    return [a, b]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    paths = write_report(_sections(), out, title="Test <report>", intro="Intro & more.", quick=True)
    return paths


# ---------------------------------------------------------------------------------------------
# Tests


def test_outputs_exist_and_no_temporaries(report):
    assert report.html.name == "report.html" and report.html.is_file()
    assert report.json.name == "results.json" and report.json.is_file()
    assert [p.name for p in report.figures] == ["fig_line.png", "fig-two.png"]
    leftovers = [p.name for p in report.html.parent.iterdir() if p.name.endswith(".tmp")]
    assert leftovers == []


def test_files_get_permissions_from_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        paths = write_report(
            [ReportSection("S", figures=(FigureSpec("f", _tiny_figure("p")),))], tmp_path
        )
    finally:
        os.umask(old)
    for path in (paths.html, paths.json, *paths.figures):
        assert path.stat().st_mode & 0o777 == 0o644, path


def test_page_parses_and_embeds_every_figure(report):
    text = report.html.read_text(encoding="utf-8")
    parsed = parse_report(text)
    assert set(parsed["images"]) == {"fig_line", "fig-two"}
    for path in report.figures:  # the embedded bytes are exactly the PNG files
        assert parsed["images"][path.stem] == path.read_bytes()
    assert 'name="viewport"' in text and "max-width" in text and "overflow-x: auto" in text


def test_numbers_in_tables_match_results_json(report):
    parsed = parse_report(report.html.read_text(encoding="utf-8"))
    payload = json.loads(report.json.read_text(encoding="utf-8"))
    n = assert_tables_match_json(parsed, payload)
    # 3 + 2 + 2 finite numbers in the first table (None and NaN excluded), 2 in the second.
    assert n == 9
    table = parsed["tables"][1]  # [0] is the errata table
    assert table["rows"][0] == ["m1", "50.1235", "50.1", "1450"]
    assert table["rows"][1] == ["l1 & l2", "0.4", "—", "12"]
    assert table["rows"][2] == ["k", "19.7392", "nan", "0"]
    assert parsed["tables"][2]["rows"] == [["tiny", "1.23457e-09"], ["huge", "-9.87654e+12"]]


def test_results_json_content(report):
    payload = json.loads(report.json.read_text(encoding="utf-8"))
    assert payload["results"]["Manipulator: stand-in"]["k"] == pytest.approx(2 * math.pi**2)
    assert payload["results"]["Manipulator: stand-in"]["nan_value"] is None  # strict JSON
    assert payload["results"]["MSD: stand-in"] == {"tiny": 1.23456789e-9}
    meta = payload["metadata"]
    assert meta["physid_version"] == physid.__version__
    assert meta["quick"] is True
    assert re.match(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d", meta["created"])
    assert meta["figures"] == ["fig_line.png", "fig-two.png"]
    assert len(payload["errata"]) == 3
    assert "NaN" not in report.json.read_text(encoding="utf-8")


def test_errata_grouped_by_paper_near_top(report):
    text = report.html.read_text(encoding="utf-8")
    parsed = parse_report(text)
    errata = parsed["tables"][0]
    assert errata["caption"].startswith("Errata found")
    assert [r[0] for r in errata["rows"]] == ["Paper B", "Paper B", "Paper A"]
    assert errata["rows"][0][2:4] == ["x < y", "x > y"]
    # The errata section comes before the first experiment section, after the contents.
    first_section = text.index("Manipulator: stand-in</h2>")
    assert text.index('id="toc"') < text.index('id="errata"') < first_section


def test_text_is_escaped_and_html_paragraphs_are_not(report):
    text = report.html.read_text(encoding="utf-8")
    assert "with &lt;tags&gt; &amp; ampersands" in text
    assert "<tags>" not in text
    assert "Estimates &lt;beside&gt; the paper" in text
    assert "A &lt;line&gt; &amp; more." in text
    assert "<title>Test &lt;report&gt;</title>" in text
    assert "<p>A <em>marked</em> paragraph with <code>m1*l1**2</code>.</p>" in text
    assert "<p>Intro &amp; more.</p>" in text


def test_table_of_contents_links_every_section(report):
    text = report.html.read_text(encoding="utf-8")
    links = re.findall(r'<li><a href="#([^"]+)">', text)
    assert links == ["errata", "manipulator-stand-in", "msd-stand-in"]
    for anchor in links:
        assert f'id="{anchor}"' in text


def test_errata_section_position(tmp_path):
    sections = _sections()
    paths = write_report(sections, tmp_path, errata_after=1)
    text = paths.html.read_text(encoding="utf-8")
    links = re.findall(r'<li><a href="#([^"]+)">', text)
    assert links == ["manipulator-stand-in", "errata", "msd-stand-in"]
    first, second = text.index('id="manipulator-stand-in"'), text.index('id="msd-stand-in"')
    assert first < text.index('id="errata"') < second
    paths = write_report(_sections(), tmp_path, errata_after=2)
    links = re.findall(r'<li><a href="#([^"]+)">', paths.html.read_text(encoding="utf-8"))
    assert links == ["manipulator-stand-in", "msd-stand-in", "errata"]
    with pytest.raises(InputError, match=r"errata_after must be an int between 0 and .*got 3"):
        write_report(_sections(), tmp_path, errata_after=3)
    plt.close("all")


def test_numeric_columns_are_right_aligned(report):
    text = report.html.read_text(encoding="utf-8")
    caption = "<caption>Estimates &lt;beside&gt; the paper</caption>"
    head = re.search(re.escape(caption) + r"\s*<thead>(.*?)</thead>", text).group(1)
    assert re.findall(r'<th scope="col"( class="num")?>', head) == [
        "",
        ' class="num"',
        ' class="num"',
        ' class="num"',
    ]


def test_wide_tables_use_the_page_width_and_words_are_not_split(report, tmp_path):
    """Many-column tables and the errata get the 'wide' wrapper; text breaks between words."""
    text = report.html.read_text(encoding="utf-8")
    # the 4-column table stays in the text column, the errata table is wide
    assert re.search(r'<div class="table-wrap"><table>\s*<caption>Estimates', text)
    assert '<div class="table-wrap wide"><table class="errata">' in text
    css = re.search(r"<style>(.*?)</style>", text, re.S).group(1)
    assert "overflow-wrap: anywhere" not in css and "break-all" not in css
    assert "overflow-wrap: break-word" in css and "word-break: normal" in css
    assert re.search(r"table\.errata td:nth-child\(2\) \{ min-width: 8\.5em", css)
    columns = tuple(f"c{i}" for i in range(WIDE_TABLE_COLUMNS))
    wide = ReportSection("Wide", tables=(Table("Ten", columns, ((1.0,) * len(columns),)),))
    page = write_report([wide], tmp_path).html.read_text(encoding="utf-8")
    assert '<div class="table-wrap wide"><table>' in page


def test_figures_are_closed_after_saving(tmp_path):
    fig = _tiny_figure("c")
    number = fig.number
    assert plt.fignum_exists(number)
    write_report([ReportSection("S", figures=(FigureSpec("f", fig, "c"),))], tmp_path)
    assert not plt.fignum_exists(number)


def test_rewrite_replaces_files(tmp_path):
    write_report([ReportSection("One", results={"x": 1.0})], tmp_path)
    paths = write_report([ReportSection("Two", results={"x": 2.0})], tmp_path)
    payload = json.loads(paths.json.read_text())
    assert payload["results"] == {"Two": {"x": 2.0}}
    assert "One" not in paths.html.read_text()


def test_format_cell():
    assert format_cell(1234.5678) == "1234.57"
    assert format_cell(0.1 + 0.2) == "0.3"
    assert format_cell(1e-9) == "1e-09"
    assert format_cell(7) == "7"
    assert format_cell(None) == "—"
    assert format_cell(float("-inf")) == "-inf"


@pytest.mark.parametrize("name", ["bad name", "../up", "fig.png", "", "ü", "a/b"])
def test_bad_figure_names_raise(name):
    fig = _tiny_figure("d")
    with pytest.raises(InputError, match=r"letters, digits, '-' and '_'"):
        FigureSpec(name, fig, "caption")
    plt.close(fig)


def test_other_bad_inputs_raise(tmp_path):
    with pytest.raises(InputError, match=r"matplotlib Figure"):
        FigureSpec("ok", object(), "caption")
    with pytest.raises(InputError, match=r"row 0 has 1 cell\(s\) but there are 2 column"):
        Table("t", ("a", "b"), (("only one",),))
    with pytest.raises(InputError, match=r"cell must be str, int, float or None; got list"):
        Table("t", ("a",), (([1, 2],),))
    with pytest.raises(InputError, match=r"paragraphs must be a sequence of strings"):
        ReportSection("S", paragraphs="one string")
    with pytest.raises(InputError, match=r"tables must hold Table objects; got str"):
        ReportSection("S", tables=("no",))
    with pytest.raises(InputError, match=r"title must be a non-empty string"):
        ReportSection("  ")
    with pytest.raises(InputError, match=r"titled 'S'.*unique"):
        write_report([ReportSection("S"), ReportSection("S")], tmp_path)
    f1, f2 = _tiny_figure("e"), _tiny_figure("f")
    with pytest.raises(InputError, match=r"two figures are named 'f'"):
        write_report(
            [
                ReportSection("A", figures=(FigureSpec("f", f1),)),
                ReportSection("B", figures=(FigureSpec("f", f2),)),
            ],
            tmp_path,
        )
    plt.close(f1)
    plt.close(f2)
    with pytest.raises(InputError, match=r"results of section 'S' cannot be written as JSON"):
        write_report([ReportSection("S", results={"a set": {1, 2}})], tmp_path)
    assert not (tmp_path / "results.json").exists()  # nothing is written before the checks pass
    with pytest.raises(InputError, match=r"expects ReportSection objects; got dict"):
        write_report([{"title": "x"}], tmp_path)


def test_checker_catches_defects():
    """The independent checker fails on the defects it exists to catch."""
    good = "<!DOCTYPE html><html><head><title>t</title><style></style></head><body><main><nav>"
    end = "</nav></main></body></html>"
    parse_report(good + end)
    with pytest.raises(AssertionError, match="unbalanced"):
        parse_report(good + "<section><div></section>" + end)
    with pytest.raises(AssertionError, match="not embedded"):
        parse_report(good + '<img src="fig.png" alt="x">' + end)
    with pytest.raises(AssertionError, match="external resource"):
        parse_report(good + '<img src="https://example.org/a.png" alt="x">' + end)
    with pytest.raises(AssertionError, match="signature"):
        bad = base64.b64encode(b"GIF89a" + bytes(30)).decode()
        parse_report(good + f'<img src="data:image/png;base64,{bad}" alt="x">' + end)


def test_renders_in_chromium_without_errors(report, tmp_path):
    check, console = render_in_chromium(report.html, tmp_path)
    assert console == "", console
    assert check["errors"] == []
    assert check["images"] == 2 and check["loaded"] == 2, check
    assert all(w > 0 for w in check["widths"])
    # No horizontal page scroll on a laptop-sized window: wide tables scroll inside their box.
    assert check["scroll_width"] <= check["client_width"], check


def test_chromium_check_catches_errors(tmp_path):
    """The rendering check reports a broken image and a script error when there are some."""
    page = tmp_path / "broken.html"
    page.write_text(
        "<!DOCTYPE html><html><head><title>b</title></head><body>"
        '<img src="data:image/png;base64,AAAA" data-name="broken" alt="x">'
        "<script>throw new Error('boom-physid')</script></body></html>",
        encoding="utf-8",
    )
    check, console = render_in_chromium(page, tmp_path)
    assert check["images"] == 1 and check["loaded"] == 0
    assert check["not_loaded"] == ["broken"]
    assert any("boom-physid" in e for e in check["errors"])
    assert "Uncaught Error: boom-physid" in console
