"""physid.analysis.validation and `physid validate`: the torque balance (a), the simulation (b)
and the residual correlations (c) on held-out data, for every estimator's result."""

from __future__ import annotations

import json
import re
import warnings

import numpy as np
import pytest
from scipy import signal

import physid
from _helpers import DATA, PLANAR2
from _helpers import planar2_pd_run as _run
from physid import Recording
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
from physid.estimators.algebraic import AlgebraicEstimator
from physid.estimators.idim import IDIMEstimator
from physid.estimators.results import save_result
from physid.signals import save_recording
from physid.simulate.closed_loop import simulate_closed_loop
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


# ------------------------------------------------------------------ residual correlations
def _old_xcorr(a, b, max_lag):
    """The reference kernel: the full correlation (O(n²)), sliced to ±max_lag, normalised."""
    n = a.size
    full = np.correlate(a, b, mode="full")
    return full[n - 1 - max_lag : n + max_lag] / np.sqrt(float(a @ a) * float(b @ b))


def test_residual_analysis_matches_the_full_correlation_without_computing_it(monkeypatch):
    rng = np.random.default_rng(11)
    n, lag = 3000, 25
    e = rng.normal(size=(n, 2)) + np.linspace(0, 1, n)[:, None]  # a mean to remove
    u = rng.normal(size=(n, 3))
    ec, uc = e - e.mean(axis=0), u - u.mean(axis=0)
    auto_ref = [_old_xcorr(ec[:, j], ec[:, j], lag)[lag:] for j in range(2)]
    cross_ref = [_old_xcorr(ec[:, j], uc[:, k], lag) for j in range(2) for k in range(3)]

    def refuse(*args, **kwargs):  # the O(n²) full correlation must not be computed any more
        raise AssertionError("np.correlate(mode='full') is O(n^2)")

    monkeypatch.setattr(np, "correlate", refuse)
    r = residual_analysis(e, u, max_lag=lag)
    assert len(r["autocorrelation"]) == 2 and len(r["cross_correlation"]) == 6
    for got, ref in zip(r["autocorrelation"], auto_ref, strict=True):
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
        assert got[0] == pytest.approx(1.0, abs=1e-15)
    for got, ref in zip(r["cross_correlation"], cross_ref, strict=True):
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r["lags"], np.arange(-lag, lag + 1))


# ---------------------------------------------- IDIM results: few held-out rows, the sample period
@pytest.fixture(scope="module")
def idim_file(tmp_path_factory):
    model = physid.load_model(PLANAR2)
    # decimate 10 as the spectrum rule gives here (auto may choose another by cross-validation)
    result = IDIMEstimator(model, "ols", decimate=10).fit(_run(model)).result_
    path = tmp_path_factory.mktemp("idim") / "idim.json"
    save_result(result, path, model=str(PLANAR2))
    return model, path


def test_validate_skips_the_residual_test_on_few_rows_instead_of_failing(idim_file):
    model, path = idim_file
    short = _run(model, phase=0.7, duration=0.6)  # (600 - 2·52) / 10 < 52 decimated rows
    report = validate(path, short)
    assert report.residual == {}
    assert report.relative_error["overall"] < 1e-4  # (a) still stands: noise-free, true model
    (note,) = [n for n in report.notes if n.startswith("(c) skipped")]
    assert re.search(
        r"need more than 51 filtered, decimated rows; the held-out record gives \d+", note
    )
    assert "--" not in note and "max_lag" not in note
    assert "(c) skipped" in report.summary()


def test_validate_of_an_idim_file_without_sample_period_says_so(idim_file, tmp_path):
    model, path = idim_file
    data = json.loads(path.read_text())
    assert data["dt"] == pytest.approx(1e-3, rel=1e-12)  # IDIM results carry dt
    held_2ms = _run(model, phase=0.7, duration=2.0)
    with pytest.raises(InputError, match=r"sampled every 0\.002 s but the fit used 0\.001 s"):
        validate(path, physid.Recording(held_2ms.t[::2], held_2ms.data[::2], held_2ms.names))
    data.pop("dt")  # a file written before IDIM results carried dt
    old = tmp_path / "old.json"
    old.write_text(json.dumps(data))
    held = _run(model, phase=0.7, duration=2.0)
    notes = [n for n in validate(old, held).notes if n.startswith("sampling:")]
    assert len(notes) == 1 and "does not record the fit's sample period" in notes[0]
    assert "Hz at this period" in notes[0]
    data["dt"] = 0.002  # a recorded period that differs from the held-out record's: refused
    old.write_text(json.dumps(data))
    with pytest.raises(InputError, match=r"sampled every 0\.001 s but the fit used 0\.002 s"):
        validate(old, held)


# ------------------------------------------------------------------ an estimated output offset
def _msd_record(freqs, offset):
    t = np.arange(3000) * 1e-3
    u = np.sin(freqs[0] * t) + 0.5 * np.sin(freqs[1] * t)
    x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    return Recording(t, np.c_[u, x + offset], ["u", "x"])


def test_inverse_cross_test_subtracts_the_estimated_output_offset(offset_msd):
    model = offset_msd
    res = AlgebraicEstimator(model).fit(_msd_record((10, 23), 0.01)).result_
    assert res.parameters["offset"] == pytest.approx(0.01, rel=1e-5)
    same = validate(res, _msd_record((7, 17), 0.01), model=model)
    # (a) and (b) now agree: both see the same offset the fit estimated (before: (a) 0.62)
    assert same.relative_error["overall"] < 1e-3
    assert same.fit_percent["x"] > 99.9
    assert any("output offset offset = 0.01" in n for n in same.notes)
    # a held-out record without the offset fails both tests (before: (a) passed at 6.8e-5)
    none = validate(res, _msd_record((7, 17), 0.0), model=model)
    assert none.relative_error["overall"] > 0.3
    assert none.fit_percent["x"] < 60


# ----------------------------------- IDIM: the near-rest rule in (a), the fitted base model in (b)
@pytest.fixture(scope="module")
def pendulum():
    """The 1-DOF pendulum with exact Coulomb friction: it sticks under PD control."""
    model = physid.load_model(DATA / "pendulum1.toml")

    def record(phase):
        t = np.arange(0.0, 10.0, 1e-3)
        r = 0.8 * np.sin(2 * np.pi * 0.5 * t + phase) + 0.3 * np.sin(2 * np.pi * 1.3 * t + 0.4)
        kd = [2 * np.sqrt(40.0)]
        return simulate_closed_loop(model, kp=[200.0], kd=kd, reference=(r - r[0])[:, None], t=t)

    fit_rec, held_out = record(0.0), record(1.1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = IDIMEstimator(model, "ols").fit(fit_rec).result_
    return model, fit_rec, held_out, res


def test_idim_cross_test_drops_the_near_rest_rows_the_fit_dropped(pendulum, tmp_path):
    model, fit_rec, _, res = pendulum
    assert fit_rec.metadata["coulomb"]["stick_time"][0] > 0.05  # [s]: the joint sticks
    assert "joint equations dropped: " in res.message and "where the joint sticks" in res.message
    assert res.stick_threshold == "auto"
    path = save_result(res, tmp_path / "idim.json", model=str(DATA / "pendulum1.toml"))
    for result in (res, path):  # the result object and its file (which records the threshold)
        rep = validate(result, fit_rec, model=model)
        # the fit's own record gives the fit's relative error (before: 0.0218 against 2.1e-4)
        assert rep.relative_error["overall"] == pytest.approx(
            res.relative_error["overall"], rel=1e-6
        )
        # with the equations where the joint sticks, or next to a reversal or at low speed where
        # the residual shows friction the model lacks, dropped (25 %); 2.1e-4 when 44 % were
        # dropped near rest
        assert rep.relative_error["overall"] < 3e-3
        note = next(n for n in rep.notes if "joint equations dropped" in n)
        assert "sticking shown by the measured position" in note
        assert "the fit's" in note and "(c) tests those equations with the others" in note
        assert rep.failures == ()  # the joint keeps rows


def test_idim_closed_loop_test_simulates_the_fitted_base_model(pendulum):
    model, _, held_out, res = pendulum
    assert not res.derived  # no consistent estimate: the base model is simulated
    rep = validate(res, held_out, model=model)
    # before: "(b) skipped: IDIM estimates base parameters ..."
    assert rep.fit_percent["q1"] > 99.0
    assert rep.output_relative_error["q1"] < 0.01
    note = next(n for n in rep.notes if n.startswith("(b)"))
    assert "fitted base model" in note and "not a physical parameter set" in note
    assert "IDIMEstimator" not in " ".join(rep.notes)


def test_idim_closed_loop_test_on_planar2():
    """Two joints with regrouped columns (mcx1R, ZZ1R, …): θ on the kept columns reproduces
    the closed loop on a held-out reference."""
    model = physid.load_model(DATA / "planar2.urdf")
    t = np.arange(0.0, 6.0, 1e-3)
    ramp = np.clip(t, 0.0, 1.0)[:, None] ** 3
    w = np.array([2.0, 3.1])

    def record(phase):
        r = ramp * (0.7 * np.sin(np.outer(t, w) + phase) + 0.3 * np.sin(np.outer(t, 2.3 * w)))
        return simulate_closed_loop(model, kp=[300.0, 200.0], kd=[30.0, 20.0], reference=r, t=t)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = IDIMEstimator(model, "ols").fit(record(0.0)).result_
    assert any(n.endswith("R") for n in res.names)  # regrouped base parameters
    rep = validate(res, record(0.9), model=model)
    assert rep.fit_percent["q1"] > 99.0 and rep.fit_percent["q2"] > 99.0


# ------------------------------------------------------------ a result file whose model file moved
def test_load_result_with_a_missing_model_file_asks_for_the_model(tmp_path):
    data = {
        "format": "physid-result",
        "method": "idim-ols",
        "parameters": {"ZZ1R": 1.0},
        "model": str(tmp_path / "elsewhere" / "arm.urdf"),
    }
    from physid.estimators.results import RESULT_FORMAT

    data["format"] = RESULT_FORMAT
    path = tmp_path / "r.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(InputError, match=r"does not exist here; pass the model \(model=\.\.\.\)"):
        load_result(path)
    try:
        load_result(path)
    except InputError as exc:
        assert "--model MODEL" in exc.render({"model": "--model"})
    # with the model given, the file loads
    loaded = load_result(path, model=DATA / "pendulum1.toml")
    assert loaded.parameters == {"ZZ1R": 1.0}
