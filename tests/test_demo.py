"""`physid demo`: the real quick demo end to end, and the demo's own sections on stand-ins.

The page checks (html.parser structure, embedded PNGs, table numbers against results.json,
headless Chromium rendering) are the independent ones from tests/test_report_html.py.
"""

from __future__ import annotations

import contextlib
import html
import importlib.util
import io
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import physid  # noqa: E402
from physid.cli import main  # noqa: E402
from physid.errors import InputError  # noqa: E402
from physid.report.demo import (  # noqa: E402
    ADDS_TITLE,
    ERRATA_TITLE,
    HEADLINE_TITLE,
    INTRO_TITLE,
    YOUR_DATA_TITLE,
    run_demo,
)
from physid.report.html import Erratum, FigureSpec, ReportSection, Table  # noqa: E402


def _load_checks():
    path = Path(__file__).with_name("test_report_html.py")
    spec = importlib.util.spec_from_file_location("_physid_report_checks", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


checks = _load_checks()


# ---------------------------------------------------------------------------------------------
# The real quick demo, run once through the command line


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "out"
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        status = main(["demo", "--quick", "--out", str(out)])
    plt.close("all")
    return {"status": status, "out": out, "stdout": stdout.getvalue(), "stderr": stderr.getvalue()}


@pytest.fixture(scope="module")
def payload(demo):
    return json.loads((demo["out"] / "results.json").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def page(demo):
    return (demo["out"] / "report.html").read_text(encoding="utf-8")


def test_demo_exits_0_and_prints_the_report_path(demo):
    assert demo["status"] == 0, demo["stderr"][-3000:]
    lines = demo["stdout"].strip().splitlines()
    assert Path(lines[-1]) == demo["out"] / "report.html"
    assert (demo["out"] / "report.html").is_file()
    assert "demo: running manipulator_paper" in demo["stderr"]
    assert "demo: running msd_paper" in demo["stderr"]


def test_report_parses_and_embeds_every_figure(demo, page, payload):
    parsed = checks.parse_report(page)
    pngs = sorted(p.name for p in demo["out"].glob("*.png"))
    assert pngs == sorted(payload["metadata"]["figures"])
    assert len(pngs) >= 4  # both papers contribute figures
    assert sorted(f"{name}.png" for name in parsed["images"]) == pngs
    for name in pngs:  # embedded bytes are the written files, and every referenced name exists
        assert parsed["images"][name[:-4]] == (demo["out"] / name).read_bytes()
        assert f'id="fig-{name[:-4]}"' in page


def test_numbers_in_the_page_match_results_json(page, payload):
    parsed = checks.parse_report(page)
    n_numbers = checks.assert_tables_match_json(parsed, payload)
    assert n_numbers >= 20


def test_results_json_covers_both_papers_and_the_demo_sections(payload):
    meta = payload["metadata"]
    assert meta["quick"] is True and meta["physid_version"] == physid.__version__
    titles = list(payload["results"])
    # the summary, then a user's own data, then the papers
    assert titles[:2] == [HEADLINE_TITLE, YOUR_DATA_TITLE]
    assert titles[-3:] == [ADDS_TITLE, ERRATA_TITLE, INTRO_TITLE]
    parts = payload["results"][INTRO_TITLE]["wall_time_s"]
    assert set(parts) == {"manipulator_paper", "msd_paper", "arm6"}
    rows = {row[0]: row[1] for row in payload["tables"][INTRO_TITLE][1]["rows"]}
    assert all(rows[name] >= 1 for name in parts)
    assert len(titles) == 5 + sum(rows[name] for name in parts)


def test_every_number_in_a_paragraph_comes_from_results_json(payload):
    problems, checked = checks.paragraph_number_problems(payload)
    assert problems == []
    assert checked >= 150  # the paragraphs do quote numbers


def test_every_figure_has_title_caption_alt_text_and_units(payload, page):
    assert checks.figure_problems(payload) == []
    info = payload["metadata"]["figure_info"]
    for name, fig in info.items():
        assert f'alt="{html.escape(fig["alt"], quote=True)}"' in page, name


def test_no_paper_is_called_by_a_seed_and_no_sweep_is_suggested_for_user_data(page):
    assert "Seed 000" not in page and "Seed 003" not in page
    your_data = page.split('id="your-data-three-commands"')[1].split("</section>")[0]
    assert "physid sweep" not in your_data and "physid validate" in your_data
    assert "not installed" not in page


def test_long_tables_are_collapsed_behind_a_summary(payload, page):
    long = [
        t
        for tables in payload["tables"].values()
        for t in tables
        if len(t["rows"]) > 20 and not t["caption"].startswith("Errata")
    ]
    for t in long:
        assert f"<summary>{html.escape(t['caption'])} — all {len(t['rows'])} rows</summary>" in page


def test_errata_from_both_papers_are_reported(payload, page):
    papers = {e["paper"] for e in payload["errata"]}
    assert len(papers) >= 2, papers
    for e in payload["errata"]:
        assert e["evidence"].strip(), e
    summary = payload["results"][ERRATA_TITLE]
    assert summary["total"] == len(payload["errata"])
    assert sum(summary["per_paper"].values()) == len(payload["errata"])
    assert 'id="errata"' in page


def test_report_renders_in_chromium(demo, tmp_path):
    check, console = checks.render_in_chromium(demo["out"] / "report.html", tmp_path)
    assert console == "", console
    assert check["errors"] == [], check["errors"]
    assert check["images"] == len(list(demo["out"].glob("*.png")))
    assert check["loaded"] == check["images"], check["not_loaded"]
    assert all(width > 0 for width in check["widths"])
    assert check["scroll_width"] <= check["client_width"], check
    assert check["too_wide"] == [], check["too_wide"]
    for part in check["parts"]:
        assert part["right"] <= check["client_width"] + 1, part


def test_first_screen_at_1280_px_shows_the_your_data_commands(demo, tmp_path):
    from test_report_layout import measure_layout

    layout = measure_layout(demo["out"] / "report.html", tmp_path, 1280)
    # the summary, the "your data" heading and the top of its command block within 800 px
    assert 0 < layout["your_data_top"] < layout["commands_top"] < 800, layout


def test_each_part_fits_1280_px_in_a_screenshot(demo, tmp_path):
    shots = checks.screenshot_parts(demo["out"] / "report.html", tmp_path)
    assert len(shots) >= 4  # parts I-III and the reference part
    for part, png in shots.items():
        width, height = checks.png_size(png.read_bytes())
        assert width == 1280 and height > 200, part


# ---------------------------------------------------------------------------------------------
# The demo's own sections, on stand-in experiments


def _fig():
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0, 1], [1, 0])
    return fig


def _stand_in_manipulator(quick=False, progress=None):
    if progress:
        progress("stand-in manipulator")
    return [
        ReportSection(
            "Arm",
            tables=(Table("fit", ("what", "value"), (("nfev", 37), ("J", 0.0223))),),
            figures=(FigureSpec("arm", _fig(), "arm"),),
            results={
                "ours": {"nfev": 37},
                "quick": quick,
                "ours_consistent_filters": {"errors_percent": {"m2": 0.2, "m3": -0.5, "m4": None}},
            },
            errata=(
                Erratum("Paper A", "Eq. 1", "a", "b", "derivation"),
                Erratum("Paper A", "Eq. 2", "c", "d", "figure arm"),
            ),
        )
    ]


def _stand_in_msd(quick=False, progress=None):
    return [
        ReportSection("MSD 1", results={"optimal_ratio": {"0.99": 1.7}}),  # not a number: skipped
        ReportSection(
            "MSD 2",
            results={"optimal_ratio": 2.5},
            errata=(Erratum("Paper B", "Eq. 20", "e", "f", "test"),),
        ),
    ]


def test_run_demo_on_stand_ins(tmp_path):
    messages = []
    paths = run_demo(
        tmp_path / "out",
        quick=True,
        progress=messages.append,
        experiments=[_stand_in_manipulator, _stand_in_msd],
    )
    payload = json.loads(paths.json.read_text())
    assert list(payload["results"]) == [
        HEADLINE_TITLE,
        YOUR_DATA_TITLE,
        "Arm",
        "MSD 1",
        "MSD 2",
        ADDS_TITLE,
        ERRATA_TITLE,
        INTRO_TITLE,
    ]
    assert payload["results"]["Arm"]["ours"] == {"nfev": 37}
    assert payload["results"][ERRATA_TITLE] == {
        "total": 3,
        "per_paper": {"Paper A": 2, "Paper B": 1},
    }
    # "what physid adds" pulls its numbers from the sections' results.
    adds = payload["results"][ADDS_TITLE]
    assert {k: v["value"] for k, v in adds.items()} == {
        "evaluations": 37,
        "input_design": 2.5,
        "filters": 0.5,
    }
    assert adds["input_design"]["source"] == "optimal_ratio"
    intro_tables = payload["tables"][INTRO_TITLE]
    versions = dict(map(tuple, intro_tables[0]["rows"]))
    assert versions["physid"] == physid.__version__
    assert [r[:2] for r in intro_tables[1]["rows"]] == [
        ["test_demo._stand_in_manipulator", 1],
        ["test_demo._stand_in_msd", 2],
        ["total", 3],
    ]
    assert "stand-in manipulator" in messages
    assert any(m.startswith("demo: writing the report") for m in messages)
    parsed = checks.parse_report(paths.html.read_text())
    assert checks.assert_tables_match_json(parsed, payload) >= 8
    assert set(parsed["images"]) == {"arm"}
    assert [p.name for p in tmp_path.iterdir()] == ["out"]  # no staging folder left behind


def test_versions_list_only_what_the_run_imported(tmp_path, monkeypatch):
    import sys

    monkeypatch.delitem(sys.modules, "pysindy", raising=False)
    paths = run_demo(tmp_path / "out", quick=True, experiments=[_stand_in_msd])
    payload = json.loads(paths.json.read_text())
    intro = payload["results"][INTRO_TITLE]
    assert "pysindy" not in intro["versions"] and "pysindy" in intro["not_imported"]
    assert "not installed" not in json.dumps(payload["tables"][INTRO_TITLE])
    assert intro["versions"]["numpy"] == np.__version__


def _interrupted(quick=False, progress=None):
    raise KeyboardInterrupt


def test_an_interrupted_demo_leaves_no_partial_folder(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        run_demo(out, quick=True, experiments=[_stand_in_msd, _interrupted])
    assert list(tmp_path.iterdir()) == []  # neither the folder nor a staging folder
    first = run_demo(out, quick=True, experiments=[_stand_in_manipulator])
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    with pytest.raises(KeyboardInterrupt):
        run_demo(out, quick=True, experiments=[_stand_in_msd, _interrupted])
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # the old run, whole
    assert [p.name for p in tmp_path.iterdir()] == ["out"]
    assert first.html.exists()


def test_a_rerun_replaces_the_old_run_without_mixing(tmp_path):
    out = tmp_path / "out"
    run_demo(out, quick=True, experiments=[_stand_in_manipulator])
    (out / "notes.txt").write_text("mine")
    assert (out / "arm.png").exists()
    run_demo(out, quick=True, experiments=[_stand_in_msd])
    names = sorted(p.name for p in out.iterdir())
    assert names == ["notes.txt", "report.html", "results.json"]  # arm.png of the old run gone


def test_demo_out_existing_file_is_refused_before_any_work(tmp_path, capsys):
    target = tmp_path / "taken.txt"
    target.write_text("keep me")
    status = main(["demo", "--quick", "--out", str(target)])
    err = capsys.readouterr().err
    assert status == 2
    assert "physid: error: --out " in err and "is an existing file, not a folder" in err
    assert "demo: running" not in err  # refused before the experiments ran
    assert target.read_text() == "keep me"
    with pytest.raises(InputError, match=r"out_dir='.*taken.txt' is an existing file"):
        run_demo(target, experiments=[_interrupted])  # the library checks first, too


def test_run_demo_rejects_bad_experiments(tmp_path):
    with pytest.raises(InputError, match=r"experiments must hold callables"):
        run_demo(tmp_path / "a", experiments=[42])
    with pytest.raises(InputError, match=r"returned a dict; it must return a list"):
        run_demo(tmp_path / "b", experiments=[lambda quick, progress: [{"title": "x"}]])
    assert list(tmp_path.iterdir()) == []


def test_demo_bad_option_exits_2(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["demo", "--bogus"])
    assert exc.value.code == 2
    assert "unrecognized arguments: --bogus" in capsys.readouterr().err


def test_what_physid_adds_finds_its_numbers_in_the_real_sections(payload):
    """Every row of "what physid adds" found its number in the paper sections' results (if a
    paper module renames a results key, this fails instead of the row silently showing '—')."""
    adds = payload["results"][ADDS_TITLE]
    assert set(adds) == {
        "evaluations",
        "kinetic_energy",
        "identifiability",
        "filters",
        "algebraic",
        "rls",
        "input_design",
        "sweeps",
    }
    assert 1 <= adds["evaluations"]["value"] < 1450  # the paper needed about 1450
    assert adds["identifiability"]["value"] == 7  # 8 parameters, m1 and l1 only as m1*l1**2
    assert adds["sweeps"]["value"] >= 1


def test_every_demo_section_ran_in_the_test_environment(payload):
    # a section can fail quietly (a KeyError caught and shown as "not run") while every other
    # test passes; every section must run where all dependencies are there
    broken = {
        title: section.get("error")
        for title, section in payload["results"].items()
        if isinstance(section, dict)
        and not section.get("skipped_in_quick_run")  # by design (the full demo runs it)
        and (section.get("available") is False or section.get("error"))
    }
    assert not broken, broken
