"""A held output offset (``identify = false``) is removed at its value by the linear-ODE
estimators, where it used to be ignored (a silent 9 % error in θ2 on this record)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

import physid
from physid import Recording
from physid.estimators import AlgebraicEstimator, RecursiveLeastSquares

MODEL = """\
name = "msd_held_offset"
kind = "linear_ode"
[parameters]
theta2 = { value = 100.0, unit = "1/s^2" }
theta1 = { value = 2.0, unit = "1/s" }
b0 = { value = 1.0, identify = false }
offset = { value = OFFSET, unit = "m", identify = false }
[ode]
a = ["theta2", "theta1"]
b = ["b0"]
output_offset = "offset"
"""


def _record():
    t = np.arange(6000) * 1e-3
    u = np.sin(10 * t) + 0.5 * np.sin(23 * t)
    x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    return Recording(t, np.c_[u, x + 0.01], ["u", "x"], units=["", "m"]), x


@pytest.mark.parametrize("estimator", [AlgebraicEstimator, RecursiveLeastSquares])
def test_a_held_offset_is_removed_at_its_value(tmp_path, estimator):
    rec, x = _record()
    path = tmp_path / "m.toml"
    path.write_text(MODEL.replace("OFFSET", "0.01"), encoding="utf-8")
    model = physid.load_model(path)
    assert not model.offset_unknown and model.known_output_offset() == 0.01
    res = estimator(model).fit(rec).result_
    assert "offset" not in res.names
    assert res.parameters["theta2"] == pytest.approx(100.0, rel=1e-3)
    assert res.parameters["theta1"] == pytest.approx(2.0, rel=2e-2)
    # the prediction carries the held offset again: it is the measured channel's
    np.testing.assert_allclose(res.predict(rec)["x"], x + 0.01, atol=1e-4)
    # held at 0 instead (the old behaviour for any value): θ2 is far off
    path.write_text(MODEL.replace("OFFSET", "0.0"), encoding="utf-8")
    wrong = estimator(physid.load_model(path)).fit(rec).result_
    assert abs(wrong.parameters["theta2"] / 100.0 - 1) > 0.05  # measured 9.2-9.6 %


def test_validate_uses_a_held_offset(tmp_path):
    from physid.analysis.validation import validate

    rec, _ = _record()
    path = tmp_path / "m.toml"
    path.write_text(MODEL.replace("OFFSET", "0.01"), encoding="utf-8")
    model = physid.load_model(path)
    res = RecursiveLeastSquares(model).fit(rec).result_
    report = validate(res, rec, model=model)
    assert report.relative_error["overall"] < 0.01  # a0·y sees the 1 cm offset otherwise
    assert report.fit_percent["x"] > 99.0
    assert any("held output offset offset = 0.01" in n for n in report.notes)


def test_the_plain_function_and_the_stream_remove_a_held_offset_too(tmp_path):
    from physid.estimators.algebraic import StreamingAlgebraicEstimator, algebraic_estimates

    rec, _ = _record()
    path = tmp_path / "m.toml"
    path.write_text(MODEL.replace("OFFSET", "0.01"), encoding="utf-8")
    model = physid.load_model(path)
    direct = algebraic_estimates(rec["u"], rec["x"], rec.dt, model)
    assert direct.parameters["theta2"] == pytest.approx(100.0, rel=1e-3)
    stream = StreamingAlgebraicEstimator(model, dt=rec.dt)
    last = [
        stream.update(rec["u"][k : k + 1000], rec["x"][k : k + 1000]) for k in range(0, 6000, 1000)
    ][-1]
    assert last.estimates[-1][last.names.index("theta2")] == pytest.approx(100.0, rel=1e-3)


def test_the_rls_regression_and_stream_remove_a_held_offset_too(tmp_path):
    from physid.estimators.recursive import StreamingRecursiveEstimator, build_regression

    rec, _ = _record()
    path = tmp_path / "m.toml"
    path.write_text(MODEL.replace("OFFSET", "0.01"), encoding="utf-8")
    model = physid.load_model(path)
    reg = build_regression(model, rec["x"], rec["u"], rec.dt)
    theta = np.linalg.lstsq(reg.X, reg.Y, rcond=None)[0]
    assert theta[list(reg.names).index("theta2")] == pytest.approx(100.0, rel=1e-3)
    stream = StreamingRecursiveEstimator(RecursiveLeastSquares(model), dt=rec.dt)
    for k in range(0, 6000, 1000):
        last = stream.update(rec["u"][k : k + 1000], rec["x"][k : k + 1000])
    assert last.estimates[-1][list(last.names).index("theta2")] == pytest.approx(100.0, rel=1e-3)
