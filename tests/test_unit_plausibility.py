"""A fit whose masses are 100× away from the model's nominal ones fails its verdict (the
estimators' plausibility gate, estimators/plausibility.py `implausible_scale`), exit status 1;
the same log in the right unit succeeds."""

import contextlib
import io
import json

import numpy as np
import pytest
import scipy.io

import physid
from physid.cli import main
from physid.estimators.plausibility import implausible_scale

AXIS = """
name = "axis"
gravity = [0.0, 0.0, -9.81]
[parameters]
m1 = { value = 18.0, unit = "kg" }
Fv1 = { value = 8.0, unit = "N*s/m" }
[[joints]]
name = "carriage"
type = "prismatic"
transform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
axis = [1, 0, 0]
mass = "m1"
viscous = "Fv1"
"""


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """An 18 kg axis under PD: the same log as .mat files in m and in mm (no units)."""
    from physid.simulate.closed_loop import simulate_closed_loop

    d = tmp_path_factory.mktemp("units")
    model_file = d / "axis.toml"
    model_file.write_text(AXIS)
    axis = physid.load_model(model_file)
    t = np.arange(5001) * 1e-3
    ramp = np.clip(t, 0, 1) ** 3
    r = ramp * (0.10 * np.sin(2 * np.pi * 0.4 * t) + 0.03 * np.sin(2 * np.pi * 1.3 * t + 1))
    w = 2 * np.pi * 5
    rec = simulate_closed_loop(axis, kp=[w**2 * 18], kd=[2 * w * 18], reference=r[:, None], t=t)
    files = {}
    for unit, scale in (("m", 1.0), ("mm", 1000.0)):
        files[unit] = d / f"axis_{unit}.mat"
        scipy.io.savemat(files[unit], {"t": t[:, None], "q1": scale * rec["q1"][:, None],
                                       "tau1": rec["tau1"][:, None]})  # fmt: skip
    return str(model_file), {k: str(v) for k, v in files.items()}


def _identify(model, log, method):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["identify", log, "--model", model, "--method", method, "--json"])
    return code, json.loads(out.getvalue()), err.getvalue()


@pytest.mark.parametrize("method", ["idim-ols", "input-error"])
def test_a_log_in_mm_fails_with_both_numbers_and_the_unit(logs, method):
    model, files = logs
    code, out, err = _identify(model, files["mm"], method)
    assert code == 1 and out["success"] is False
    assert out["parameters"]["m1"] == pytest.approx(0.018, rel=1e-3)
    message = out["message"]
    assert message.startswith("Implausible: m1 = 0.018 kg is 1000 times below the model nominal")
    assert "18 kg" in message and "q1 have no unit in the file: in mm?" in message
    assert "physid: warning: m1 = 0.018 kg is 1000 times below" in err  # also on stderr


@pytest.mark.parametrize("method", ["idim-ols", "input-error"])
def test_the_same_log_in_m_succeeds(logs, method):
    model, files = logs
    code, out, err = _identify(model, files["m"], method)
    assert code == 0 and out["success"] is True, out["message"]
    assert out["parameters"]["m1"] == pytest.approx(18.0, rel=1e-4)
    assert "Implausible" not in out["message"] and "times below" not in err


def test_the_library_fit_fails_too(logs):
    """Through the estimator, without the command line: success False, the unit named."""
    from physid.estimators.idim import IDIMEstimator
    from physid.signals import load_recording

    model_file, files = logs
    model = physid.load_model(model_file)
    r = IDIMEstimator(model, "ols").fit(load_recording(files["mm"])).result_
    assert not r.success and "in mm?" in r.message
    # the boundary: 99× away passes, 100× fails; a unit on the channel drops the guess
    axis = type("M", (), {"parameters": {"m1": 18.0}, "units": {"m1": "kg"}})()
    assert implausible_scale({"m1": 18.0 / 99}, axis) == []
    (text,) = implausible_scale({"m1": 18.0 / 100}, axis)
    assert "100 times below" in text and "no unit" not in text
    assert implausible_scale({"m1": 1800.0}, axis)[0].startswith("m1 = 1800 kg is 100 times above")
