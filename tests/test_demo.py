"""`physid demo`: the real quick demo end to end, and the demo's own sections on stand-ins.

The page checks (html.parser structure, embedded PNGs, table numbers against results.json,
headless Chromium rendering) are the independent ones from tests/test_report_html.py.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

import physid  # noqa: E402
from physid.cli import main  # noqa: E402
from physid.errors import InputError  # noqa: E402
from physid.experiments.demo import ADDS_TITLE, ERRATA_TITLE, INTRO_TITLE, run_demo  # noqa: E402
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
    assert titles[0] == INTRO_TITLE and titles[-2:] == [ERRATA_TITLE, ADDS_TITLE]
    parts = payload["results"][INTRO_TITLE]["wall_time_s"]
    assert set(parts) == {"manipulator_paper", "msd_paper"}
    rows = {row[0]: row[1] for row in payload["tables"][INTRO_TITLE][1]["rows"]}
    assert rows["manipulator_paper"] >= 1 and rows["msd_paper"] >= 1
    assert len(titles) == 3 + rows["manipulator_paper"] + rows["msd_paper"]


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
        tmp_path,
        quick=True,
        progress=messages.append,
        experiments=[_stand_in_manipulator, _stand_in_msd],
    )
    payload = json.loads(paths.json.read_text())
    assert list(payload["results"]) == [
        INTRO_TITLE,
        "Arm",
        "MSD 1",
        "MSD 2",
        ERRATA_TITLE,
        ADDS_TITLE,
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


def test_run_demo_rejects_bad_experiments(tmp_path):
    with pytest.raises(InputError, match=r"experiments must hold callables"):
        run_demo(tmp_path, experiments=[42])
    with pytest.raises(InputError, match=r"returned a dict; it must return a list"):
        run_demo(tmp_path, experiments=[lambda quick, progress: [{"title": "x"}]])


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
