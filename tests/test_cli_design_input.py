"""``physid design-input msd``: JSON contract, table output and errors."""

from __future__ import annotations

import json
import re

import pytest

from physid.analysis.input_design import optimal_ratio
from physid.cli import main


def test_json_has_optimal_ratio_per_lambda_and_the_curve(capsys):
    code = main(
        [
            "design-input",
            "msd",
            "--forgetting",
            "0.95,1",
            "--points",
            "30",
            "--horizons",
            "100,3000",
            "--json",
        ]
    )
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["optimal_ratio"]) == {"0.95", "1"}
    assert out["optimal_ratio"]["1"] == pytest.approx(2.0)  # k = 100: the upper end of [0.01, 2]
    assert out["at_boundary"] == {"0.95": True, "1": True}
    assert len(out["curve"]["ratio"]) == 30
    assert len(out["curve"]["log10_variance_factor"]["1"]) == 30
    assert out["parameters"]["optimal_ratio(lambda=1)"] == out["optimal_ratio"]["1"]
    assert out["horizons"]["samples"] == [100, 3000]
    # k = 3000: the optimum is near resonance and matches the library
    z3000 = float(optimal_ratio(1.0, samples=3000, natural_frequency=out["natural_frequency"])[0])
    assert out["horizons"]["optimal_ratio"][1] == pytest.approx(z3000, abs=1e-9)
    assert abs(z3000 - 1) < 0.05
    assert out["natural_frequency"] == pytest.approx((400 / 3) ** 0.5)


def test_options_reach_the_analysis(capsys, tmp_path):
    fig = tmp_path / "k.png"
    code = main(
        [
            "design-input",
            "msd",
            "--samples",
            "2000",
            "--init-samples",
            "5",
            "--forgetting",
            "1",
            "--ratio-range",
            "0.5",
            "1.5",
            "--sample-period",
            "0.002",
            "--natural-frequency",
            "5",
            "--points",
            "20",
            "--horizons",
            "500",
            "--plot",
            str(fig),
        ]
    )
    assert code == 0 and fig.stat().st_size > 1000
    text = capsys.readouterr().out
    expected = float(
        optimal_ratio(
            1.0,
            ratio_range=(0.5, 1.5),
            natural_frequency=5.0,
            sample_period=0.002,
            init_samples=5,
            samples=2000,
        )[0]
    )
    assert f"{expected:10.6f}" in text and "k = 2000, m = 5" in text


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["--forgetting", "0.9,1.5"], r"forgetting must lie in \(0, 1\]"),
        (["--forgetting", "0"], r"forgetting must lie in \(0, 1\]"),
        (["--forgetting", "a,b"], "--forgetting expects comma-separated numbers"),
        (["--ratio-range", "2", "1"], "LO < HI"),
        (["--samples", "2", "--init-samples", "3"], "--init-samples < --samples"),
        (["--natural-frequency", "-1"], "--natural-frequency must be finite and > 0"),
    ],
)
def test_errors_exit_2_with_a_message(capsys, argv, match):
    assert main(["design-input", "msd", *argv]) == 2
    err = capsys.readouterr().err
    assert "physid: error:" in err
    assert re.search(match, err)


def test_other_models_are_refused(capsys):
    assert main(["design-input", "manipulator"]) == 2
    assert "analyses the mass-spring-damper" in capsys.readouterr().err
