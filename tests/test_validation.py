"""physid.analysis.validation and `physid validate` (issue 15, "Validation")."""

from __future__ import annotations

import json

import numpy as np
import pytest

from physid.analysis.validation import (
    BAND_Z,
    fit_percent,
    load_result,
    residual_analysis,
    validate,
)
from physid.cli import main
from physid.errors import DataFileError, InputError
from physid.estimators import make
from physid.estimators.results import save_result
from physid.signals import save_recording
from physid.simulate.msd import msd_paper_scenario


@pytest.fixture(scope="module")
def records():
    return (
        msd_paper_scenario(1.0, 60, duration=3.0, seed=1),
        msd_paper_scenario(3.0, 60, duration=3.0, seed=2),
    )


def test_fit_percent_is_matlab_nrmse():
    y = np.array([0.0, 1.0, 2.0, 3.0])
    assert fit_percent(y, y) == 100.0
    assert fit_percent(y, np.full(4, y.mean())) == 0.0
    # ‖y − ŷ‖ = 0.5·‖y − ȳ‖ → 50 %
    assert fit_percent(y, y + 0.5 * (y.mean() - y)) == pytest.approx(50.0)


def test_residual_analysis_white_and_coloured():
    rng = np.random.default_rng(1)
    e = rng.normal(size=20000)
    u = rng.normal(size=20000)
    r = residual_analysis(e, u)
    assert r["band"] == pytest.approx(BAND_Z / np.sqrt(20000))
    assert r["autocorrelation"][0][0] == pytest.approx(1.0)
    assert r["white"] and r["independent"] and "explains the data" in r["verdict"]
    coloured = np.convolve(e, np.ones(5) / 5, mode="same")
    assert not residual_analysis(coloured, u)["white"]
    leaky = e + 0.3 * np.roll(u, 3)  # residual still carries the input, 3 samples late
    r = residual_analysis(leaky, u)
    assert not r["independent"] and "correlated with the input" in r["verdict"]
    # the cross-correlation peak sits at lag +3 (r_eu(k) = Σ e(t+k) u(t))
    assert r["lags"][int(np.argmax(np.abs(r["cross_correlation"][0])))] == 3


@pytest.mark.parametrize("method", ["algebraic", "rls"])
def test_validate_good_model_on_held_out_data(method, records, tmp_path):
    fit, held = records
    res = make(method, "msd").fit(fit).result_
    path = save_result(res, tmp_path / "r.json", model="msd")
    report = validate(path, held)
    assert report.fit_percent["x"] > 99.0
    assert report.output_relative_error["x"] < 0.01
    assert set(report.relative_error) == {"overall", "u"}
    assert report.relative_error["overall"] < 0.05
    d = json.loads(json.dumps(report.to_dict()))
    assert set(d) >= {"relative_error", "fit_percent", "residual"}
    # the same numbers from the result object directly
    direct = validate(res, held)
    assert direct.fit_percent["x"] == pytest.approx(report.fit_percent["x"], rel=1e-9)


def test_wrong_model_is_caught(records, tmp_path):
    fit, held = records
    res = make("rls", "msd", known={"theta2": 100.0}, unknown=("theta1",)).fit(fit).result_
    report = validate(res, held)
    assert report.fit_percent["x"] < 90.0
    assert not (report.residual["white"] and report.residual["independent"])


def test_validate_refuses_other_sampling(records, tmp_path):
    fit, _ = records
    res = make("rls", "msd").fit(fit).result_
    slow = msd_paper_scenario(1.0, 60, duration=3.0, dt=2e-3, seed=3)
    with pytest.raises(InputError, match="sampled every 0.002 s but the fit used 0.001 s"):
        validate(res, slow)


def test_load_result_errors(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(DataFileError, match="cannot read the result file"):
        load_result(bad)
    other = tmp_path / "other.json"
    other.write_text('{"a": 1}')
    with pytest.raises(DataFileError, match="not a physid result file"):
        load_result(other)


def test_cli_estimate_save_then_validate(records, tmp_path, capsys):
    fit, held = records
    f, h = save_recording(fit, tmp_path / "fit.csv"), save_recording(held, tmp_path / "held.csv")
    out = tmp_path / "rls.json"
    assert main(["estimate", str(f), "--method", "rls", "--save", str(out)]) == 0
    capsys.readouterr()
    plots = tmp_path / "plots"
    assert main(["validate", str(out), str(h), "--json", "--plot", str(plots)]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["fit_percent"]["x"] > 99.0 and 0 < d["relative_error"]["overall"] < 0.05
    assert {p.name for p in plots.iterdir()} >= {"index.html", "residual.png", "output_error.png"}
