"""The manipulator paper reproduction (physid.experiments.manipulator_paper), quick mode.

The experiment returns data (`SectionData`); the report renders it (`physid.report.parts`). The
tests read the numbers from the data and the text from the rendered sections.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import physid
from physid.experiments import manipulator_paper as exp
from physid.experiments.data import SectionData
from physid.report.html import ReportSection, write_report
from physid.report.parts import render


@pytest.fixture(scope="module")
def run_quick():
    messages: list[str] = []
    data = exp.run(quick=True, progress=messages.append)
    assert all(isinstance(s, SectionData) for s in data)
    sections = [render(s) for s in data]
    return {s.title: s for s in sections}, messages


def test_sections_and_progress(run_quick):
    sections, messages = run_quick
    assert list(sections) == list(exp.TITLES.values())
    assert all(isinstance(s, ReportSection) for s in sections.values())
    assert messages and all(m.startswith("manipulator: ") for m in messages)


def test_experiments_do_not_import_the_report():
    """Layering: experiments return data; only physid.report renders it."""
    import ast
    from pathlib import Path

    root = Path(exp.__file__).parent.parent
    for path in root.rglob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module:
                assert "report" not in node.module.split("."), f"{path}: imports {node.module}"
            elif isinstance(node, ast.Import):
                assert not any("physid.report" in a.name for a in node.names), path


def test_identification_against_the_paper(run_quick):
    res = run_quick[0][exp.TITLES["identification"]].results
    assert 0.9 < res["J_ratio_to_paper"] < 1.1  # J within 10 % of the paper's 0.0223076
    errors = res["ours"]["errors_percent"]
    assert max(abs(errors[n]) for n in exp.SEPARATE) < 0.1
    # m1·l1²: the same +2.9 % as the paper's own 49.5818·0.407419² = 8.2300
    assert res["ours"][exp.COMBO] == pytest.approx(res["paper"][exp.COMBO], rel=5e-3)
    assert max(abs(v) for v in res["ours_consistent_filters"]["errors_percent"].values()) < 0.1
    # the two implementations of J (residual form and linear-in-β form) agree at the estimate
    assert res["J_fast_form_at_estimate"] == pytest.approx(res["ours"]["J"], rel=1e-6)
    assert res["ours"]["nfev"] < 50 < exp.PAPER_RESULT["evaluations"]
    assert res["nelder_mead"]["nfev"] > 10 * res["ours"]["nfev"]


def test_identifiability_valley(run_quick):
    sec = run_quick[0][exp.TITLES["identifiability"]]
    res = sec.results
    assert res["texts"] == ["m1 and l1 enter only as m1*l1**2"]
    assert res["models_theta_rank"] == 7
    along = np.array(list(res["J_along_valley"].values()))
    np.testing.assert_allclose(along, along[0], rtol=1e-9)  # J is flat along m1·l1² = const
    assert [f.name for f in sec.figures] == ["manipulator_m1_l1_valley"]


def test_filter_sweep_meets_exact_target_and_warns_low_cutoff(run_quick):
    sweep = run_quick[0][exp.TITLES["filters"]].results["sweep"]
    by = {(c["half_width"], c["cutoff"], c["derivatives"]): c for c in sweep}
    best = by[(200, 0.6, "consistent")]
    assert max(abs(v) for v in best["errors_percent"].values()) < 0.05  # 0.05 %
    assert by[(200, 0.2, "paper")]["warned"] and not best["warned"]


def test_noise_bias_reported(run_quick):
    res = run_quick[0][exp.TITLES["noise"]].results
    assert res["noise_std_rad"] == 1e-4
    paper_filter = res["M=100, Ω_g=0.2, paper"]
    noisy = paper_filter["noisy_errors_percent"][0][exp.COMBO]
    assert abs(noisy) > 5 * abs(
        paper_filter["clean_errors_percent"][exp.COMBO]
    )  # errors-in-variables
    lower = res["M=200, Ω_g=0.1, consistent"]["noisy_errors_percent"][0][exp.COMBO]
    assert abs(lower) < abs(noisy)  # a lower cut-off amplifies less noise


def test_errata_have_evidence(run_quick):
    errata = [e for s in run_quick[0].values() for e in s.errata]
    assert len(errata) >= 10
    assert all(e.paper == "Cedro & Janecki" and e.evidence and e.correct for e in errata)
    locations = " ".join(e.location for e in errata)
    for where in ("kinetic energy", "V[k]", "Filtr", "reference signal", "1450", "T1"):
        assert where in locations or any(where in e.printed for e in errata), where


def test_report_writes(run_quick, tmp_path):
    paths = write_report(list(run_quick[0].values()), tmp_path, "manipulator")
    assert paths.html.exists()
    assert len(paths.figures) == 5
    assert len(list(exp.TITLES)) == 7  # overview, five sections, the errata list
    data = json.loads(paths.json.read_text())
    assert exp.TITLES["identification"] in json.dumps(data)


def test_the_library_copy_of_the_papers_numbers_matches_the_golden_file():
    """The report prints physid's copy of the paper's numbers; check it against tests/golden."""
    from _golden import CEDRO

    assert exp.PAPER_INITIAL == CEDRO["initial"]
    assert exp.TRUTH == CEDRO["truth"]
    assert exp.PAPER_RESULT["J"] == CEDRO["result"]["J"]
    assert exp.PAPER_RESULT["parameters"] == {k: v for k, v in CEDRO["result"].items() if k != "J"}
    assert exp.PAPER_RESULT["evaluations"] == CEDRO["evaluations"]["value"]
    assert physid.load_model("manipulator").parameters == CEDRO["truth"]


def test_filtr2_gain_error_is_computed_once_and_quoted_everywhere(run_quick):
    sections = run_quick[0]
    filtr2 = sections[exp.TITLES["identification"]].results["filtr2_gain_error"]
    assert filtr2 == sections[exp.TITLES["filters"]].results["filtr2_gain_error"]
    # the paper's Filtr2 vs s²·Filtr over the motion's band: ~5.6e-4; consistent filters ~3e-5
    assert 4e-4 < filtr2["paper"] < 7e-4 and filtr2["consistent"] < 5e-5
    quoted = f"{filtr2['paper']:.2g}"
    texts = [p for s in sections.values() for p in s.paragraphs]
    texts += [e.correct for s in sections.values() for e in s.errata]
    for t in texts:
        for stale in ("5e-4", "4e-4"):
            assert stale not in t, t
    assert sum(quoted in t for t in texts) >= 3  # identification, filters, erratum


def test_filter_section_explains_the_two_paper_J(run_quick):
    sections = run_quick[0]
    filt = sections[exp.TITLES["filters"]]
    j_measured = filt.results["paper_setting_measured_torque"]["J"]
    j_pd = sections[exp.TITLES["identification"]].results["ours"]["J"]
    assert filt.results["paper_setting_pd_torque_J"] == j_pd
    assert j_measured != pytest.approx(j_pd, rel=1e-3)  # they do differ (Filtr1 ≠ s·Filtr)
    text = " ".join(filt.paragraphs)
    assert f"J = {j_measured:.6g}" in text and f"J = {j_pd:.6g}" in text
    assert "measured torque" in text


def test_noise_wording_matches_the_number_of_seeds(run_quick):
    sec = run_quick[0][exp.TITLES["noise"]]
    assert sec.results["seeds"] == [1]
    text = " ".join(sec.paragraphs)
    assert "across" not in text and "a single noisy record" in text


def test_each_erratum_points_to_its_evidence_section(run_quick):
    sections = run_quick[0]
    errata = [e for s in sections.values() for e in s.errata]
    for e in errata:
        match = [t for t in sections if f"(Evidence in section '{t}'.)" in e.evidence]
        assert len(match) == 1, e
    kinetic = next(e for e in errata if "kinetic energy" in e.location)
    assert exp.TITLES["simulation"] in kinetic.evidence


def test_paper_model_on_exact_data_is_flagged_at_the_bound(run_quick):
    res = run_quick[0][exp.TITLES["simulation"]].results
    assert res["paper_model_fitted_to_exact_data_at_bound"]  # model mismatch, BoundWarning
    assert res["paper_model_fitted_to_exact_data"]["m2"] < 24.0
