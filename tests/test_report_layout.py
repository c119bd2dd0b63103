"""The report's layout in a real browser (headless Chromium) at 1280 and 800 px.

A report shaped like the demo's (a one-screen summary, the your-data commands, three parts of
sections with figures and wide tables, the errata) must open on the summary and the commands,
stay within 6 screens with its parts folded, and have no element wider than the viewport at
800 px. `measure_layout` is also what the numbers in docs/architecture.md were measured with
(on the demo's own report.html).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

from physid.report.demo import _your_data_section  # noqa: E402
from physid.report.html import FigureSpec, Html, ReportSection, Table, write_report  # noqa: E402
from test_report_html import _ReportParser, find_chromium  # noqa: E402

_MEASURE = """<script>
window.addEventListener('load', function () {
  var width = document.documentElement.clientWidth, wide = [];
  function scrolls(el) {
    for (var e = el.parentElement; e; e = e.parentElement) {
      var o = getComputedStyle(e).overflowX;
      if (o === 'auto' || o === 'scroll' || o === 'hidden') { return true; }
    }
    return false;
  }
  document.querySelectorAll('main *').forEach(function (el) {
    var r = el.getBoundingClientRect();
    if (r.width > 0 && (r.right > width + 1 || r.left < -1) && !scrolls(el)) {
      wide.push(el.tagName + ' ' + Math.round(r.left) + '..' + Math.round(r.right));
    }
  });
  var cut = [];
  document.querySelectorAll('caption, figcaption').forEach(function (el) {
    var r = el.getBoundingClientRect();
    if (r.width > 0 && (r.right > width + 1)) { cut.push(el.textContent.slice(0, 40)); }
  });
  function top(id) { var e = document.getElementById(id);
                     return e ? e.getBoundingClientRect().top + window.scrollY : -1; }
  var pre = document.createElement('pre');
  pre.id = 'physid-layout';
  pre.textContent = JSON.stringify({
    height: document.documentElement.scrollHeight,
    client_width: width,
    scroll_width: document.documentElement.scrollWidth,
    too_wide: wide.slice(0, 20),
    captions_cut: cut.slice(0, 20),
    your_data_top: top('your-data-three-commands'),
    your_data_bottom: (function () { var e = document.getElementById('your-data-three-commands');
      if (!e) { return -1; } var r = e.getBoundingClientRect(); return r.bottom + window.scrollY;
    })(),
    commands_top: (function () {
      var e = document.querySelector('#your-data-three-commands pre');
      return e ? e.getBoundingClientRect().top + window.scrollY : -1; })(),
    folds: document.querySelectorAll('details.fold').length
  });
  document.body.appendChild(pre);
});
</script>"""


def measure_layout(report: Path, workdir: Path, width: int, height: int = 800) -> dict:
    """Load ``report`` in headless Chromium at ``width`` × ``height`` px; its layout numbers.

    Returns ``height`` (page height [px], folds closed), ``too_wide`` (elements past the
    viewport outside a scrolling box), ``captions_cut``, ``your_data_top`` / ``_bottom`` [px],
    ``commands_top`` (the top of the your-data command block [px]) and ``folds``. Skips only
    when no Chromium is installed.
    """
    chromium = find_chromium()
    if chromium is None:
        pytest.skip(
            "Chromium is not installed (chromium, chromium-browser or google-chrome on PATH); "
            "`make test` installs Debian's chromium via tools/ensure_chromium.py."
        )
    text = report.read_text(encoding="utf-8")
    page = workdir / f"layout-{width}.html"
    page.write_text(text.replace("<head>", "<head>" + _MEASURE, 1), encoding="utf-8")
    cmd = [
        chromium,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--hide-scrollbars",
        "--no-first-run",
        "--disable-background-networking",
        f"--user-data-dir={workdir / f'profile-{width}'}",
        f"--window-size={width},{height}",
        "--virtual-time-budget=5000",
        "--dump-dom",
        page.resolve().as_uri(),
    ]
    env = dict(os.environ, DBUS_SESSION_BUS_ADDRESS="disabled:")
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr[-2000:]
    parsed = _ReportParser()
    parsed.feed(proc.stdout)
    assert "physid-layout" in parsed.pres, proc.stdout[:300]
    return json.loads(parsed.pres["physid-layout"])


def screenshot(report: Path, png: Path, width: int, height: int = 800) -> Path:
    """A first-paint screenshot of ``report`` at ``width`` × ``height`` px."""
    chromium = find_chromium()
    if chromium is None:
        pytest.skip("Chromium is not installed; `make test` installs it.")
    cmd = [
        chromium,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--hide-scrollbars",
        f"--user-data-dir={png.parent / f'shot-profile-{width}'}",
        f"--window-size={width},{height}",
        f"--screenshot={png}",
        report.resolve().as_uri(),
    ]
    env = dict(os.environ, DBUS_SESSION_BUS_ADDRESS="disabled:")
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0 and png.exists(), proc.stderr[-2000:]
    return png


def _figure():
    fig, ax = plt.subplots(figsize=(9, 4))
    ax.plot([0.0, 1.0, 2.0], [0.0, 1.0, 4.0], label="x")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("x [m]")
    return fig


def _demo_shaped_sections():
    long_caption = (
        "Error, standard errors and the coverage of their nominal 95 % intervals (fractions of "
        "seeds × parameters), and time per fit, for every method and every excitation"
    )
    wide = Table(
        long_caption,
        tuple(f"a rather long column heading {i}" for i in range(10)),
        tuple(tuple(1.234567 * (r + 1) * (c + 1) for c in range(10)) for r in range(6)),
    )
    finding = (  # as long as one of the demo's three findings (two lines at 1280 px)
        "<li><strong>Part N, a system:</strong> 52 base parameters identified from noisy "
        "closed-loop records; the torque of a held-out trajectory is predicted within 2.2 %. "
        "This quick run has 2 seeds, too few to separate bias from scatter. Part N</li>"
    )
    headline = ReportSection(
        "In one screen",
        paragraphs=(
            "physid identifies the physical parameters of mechanical systems (masses, inertias, "
            "friction, stiffness, damping) from measured motion and force signals. This report "
            "reproduces two papers with it and identifies a robot arm from its URDF.",
            Html('<ul class="headline">' + finding * 3 + "</ul>"),
            "Your own data comes next; the errata and the software versions close the report.",
        ),
    )
    your_data = _your_data_section()  # the demo's own: its commands, what they print
    sections = [headline, your_data]
    parts = ("Part I — one paper", "Part II — another paper", "Part III — a 6-DOF arm")
    for p, part in enumerate(parts):
        for k in range(5):
            sections.append(
                ReportSection(
                    f"{part.split(' —')[0]} section {k}",
                    paragraphs=("Headline numbers of this part: 3 of 9 claims hold.", "More."),
                    tables=(wide,),
                    figures=(FigureSpec(f"f{p}_{k}", _figure(), long_caption),),
                    part=part,
                )  # fmt: skip
            )
    sections.append(ReportSection("Notes", paragraphs=("a", "b"), tables=(wide,)))
    return sections


@pytest.fixture(scope="module")
def demo_shaped(tmp_path_factory):
    out = tmp_path_factory.mktemp("layout")
    return write_report(_demo_shaped_sections(), out, lead=2, errata_after=2).html


@pytest.mark.parametrize("width", [1280, 800])
def test_report_opens_folded_within_six_screens_and_fits_the_viewport(demo_shaped, tmp_path, width):
    layout = measure_layout(demo_shaped, tmp_path, width)
    assert layout["folds"] >= 3  # every part folded below its headline paragraph
    assert layout["too_wide"] == [], layout
    assert layout["scroll_width"] <= layout["client_width"], layout
    assert layout["captions_cut"] == [], layout
    assert layout["height"] <= 6 * 800, layout
    # first paint: the summary, then the your-data commands, before any paper
    assert 0 < layout["your_data_top"] < 800, layout
    if width == 1280:  # the three commands themselves start on the first screen
        assert layout["your_data_top"] < layout["commands_top"] < 800, layout
    text = demo_shaped.read_text(encoding="utf-8")
    assert text.index("Your data: three commands") < text.index("Part I")
    png = screenshot(demo_shaped, tmp_path / f"first-{width}.png", width)
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 5000


def test_part_headline_shows_above_its_fold(demo_shaped):
    text = demo_shaped.read_text(encoding="utf-8")
    for part in ("Part I", "Part II", "Part III"):
        block = re.search(
            rf'<h2 class="part-title">{part} —.*?</h2>\s*<p class="part-lead">(.*?)</p>\s*'
            r'<details class="fold"><summary>',
            text,
            re.S,
        )
        assert block and "3 of 9 claims hold" in block.group(1)
