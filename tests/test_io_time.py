"""Time of a recording (physid.signals.io.timebase) and the checks around it: integer stamps kept
exact, units on the time column, the hint for stamps read as seconds, ``--rate`` and ``rate`` in
the ``[recording]`` table (model files and URDF sidecars), ``validate --resample`` onto the fit's
period, and the plausibility of unit-less channels against the model."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import scipy.io

import physid
from _helpers import PLANAR2, planar2_pd_run
from physid.cli import main
from physid.errors import DataFileError, InputError, ModelFileError, PhysidWarning
from physid.signals import load_recording, save_recording
from physid.signals.io.plausibility import implausible_units, likely_unit

T0 = 1_700_000_000_123_456_789


def _csv(path, header, columns):
    lines = [header] + [",".join(str(v) for v in row) for row in zip(*columns, strict=True)]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize(
    ("unit", "step", "scale"), [("ns", 2_000_000, 1e-9), ("us", 2_000, 1e-6), ("ms", 20, 1e-3)]
)
def test_integer_stamps_are_subtracted_exactly_before_conversion(tmp_path, unit, step, scale):
    first = {"ns": T0, "us": T0 // 1000, "ms": T0 // 10**6}[unit]
    stamps = first + np.arange(50, dtype=np.int64) * step + np.arange(50) % 3  # jitter 0..2
    path = _csv(tmp_path / "r.csv", f"t [{unit}],x", [stamps, np.arange(50.0)])
    rec = load_recording(path, uniform_rtol=None)
    np.testing.assert_array_equal(rec.t, (stamps - stamps[0]).astype(float) * scale)
    assert rec.metadata["time_origin"] == {"first_stamp": int(stamps[0]), "unit": unit}


def test_epoch_nanoseconds_as_floats_would_not_be_uniform(tmp_path):
    stamps = T0 + np.arange(2000, dtype=np.int64) * 2_000_000  # exactly 500 Hz
    path = _csv(tmp_path / "r.csv", "header.stamp [ns],q1", [stamps, np.zeros(2000)])
    rec = load_recording(path)  # found by name, uniform: no --resample needed
    assert rec.dt == 0.002
    floats = stamps.astype(float) * 1e-9  # what a float64 reading would give
    assert np.ptp(np.diff(floats)) > 1e-7  # 2.4e-7 s steps: 1e-4 of the period


def test_map_with_a_unit_on_the_time(tmp_path):
    stamps = T0 + np.arange(20, dtype=np.int64) * 1_000_000
    path = _csv(tmp_path / "r.csv", "stamp_ns,x", [stamps, np.arange(20.0)])
    rec = load_recording(path, {"t": "stamp_ns [ns]"})
    assert rec.dt == pytest.approx(1e-3, rel=1e-12) and rec.t[0] == 0.0


def test_stamps_read_as_seconds_get_a_hint(tmp_path, capsys):
    stamps = T0 + np.arange(200, dtype=np.int64) * 2_000_000
    path = _csv(tmp_path / "r.csv", "header.stamp,q1,q2,tau1,tau2", [stamps] + [np.zeros(200)] * 4)
    with pytest.warns(PhysidWarning, match=r"mean period is 2e\+06 s .*in ns \(a period of 2 ms\)"):
        load_recording(path)
    main(["filter", str(path), "--out", str(tmp_path / "f.csv")])
    assert "--map 't=header.stamp [ns]'" in capsys.readouterr().err
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_recording(path, {"t": "header.stamp [ns]"})  # said: no hint


def test_rate_for_a_file_without_time(tmp_path, capsys):
    path = _csv(tmp_path / "r.csv", "q1,tau1", [np.arange(5.0), np.ones(5)])
    rec = load_recording(path, rate=5000)
    np.testing.assert_array_equal(rec.t, np.arange(5) / 5000)
    with pytest.raises(InputError, match="rate must be the sample rate in Hz"):
        load_recording(path, rate=0)
    timed = _csv(tmp_path / "t.csv", "time,q1", [np.arange(5.0), np.ones(5)])
    with pytest.raises(DataFileError, match="has its time in 'time'; drop rate="):
        load_recording(timed, rate=100)
    code = main(["filter", str(timed), "--rate", "100", "--out", str(tmp_path / "f.csv")])
    assert code == 2 and "drop --rate" in capsys.readouterr().err
    with pytest.raises(
        DataFileError, match=r"give the sample rate of a file without time \(rate=\)"
    ):
        load_recording(path)


def test_rate_in_the_recording_table_of_a_model_file_and_a_sidecar(tmp_path, capsys):
    sim = planar2_pd_run(physid.load_model(PLANAR2), duration=3.0)
    log = _csv(tmp_path / "log.csv", "enc1,enc2,tau1,tau2",
               [sim["q1"] * 1000, sim["q2"] * 1000, sim["tau1"], sim["tau2"]])  # fmt: skip
    sidecar = tmp_path / "arm.toml"
    sidecar.write_text(
        f'extends = "{PLANAR2}"\n[recording]\nrate = 1000\n'
        'q1 = "enc1/1000 [rad]"\nq2 = "enc2/1000 [rad]"\n'
    )
    code = main(["identify", str(log), "--model", str(sidecar), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    truth = physid.load_model(PLANAR2).parameters
    assert out["parameters"]["mcx2"] == pytest.approx(truth["mcx2"], rel=1e-4)
    # the table's rate is a default: a file with its own time keeps it
    timed = tmp_path / "timed.csv"
    save_recording(sim, timed)
    assert main(["identify", str(timed), "--model", str(sidecar)]) == 0
    sidecar.write_text(f'extends = "{PLANAR2}"\n[recording]\nrate = -5\n')
    with pytest.raises(ModelFileError, match="recording.rate is the sample rate in Hz"):
        physid.load_model(sidecar)
    sidecar.write_text(f'extends = "{PLANAR2}"\n[recording]\nq1 = 3\n')
    with pytest.raises(ModelFileError, match="recording.q1 must be a string"):
        physid.load_model(sidecar)


def test_validate_resamples_onto_the_fit_period(tmp_path, capsys):
    model = physid.load_model(PLANAR2)
    fit_log, held = tmp_path / "fit.csv", tmp_path / "held.csv"
    save_recording(planar2_pd_run(model, duration=3.0), fit_log)
    other = planar2_pd_run(model, phase=0.7, duration=3.0)
    save_recording(other.resample(2e-3), held)  # another period: 500 Hz
    result = tmp_path / "fit.json"
    assert main(["identify", str(fit_log), "--model", str(PLANAR2), "--save", str(result)]) == 0
    capsys.readouterr()
    assert main(["validate", str(result), str(held)]) == 2
    err = capsys.readouterr().err
    assert "sampled every 0.002 s but the fit used 0.001 s" in err and "--resample" in err
    assert main(["validate", str(result), str(held), "--resample", "--json"]) == 0
    captured = capsys.readouterr()
    assert "resampled from 0.002 s onto the fit's period 0.001 s" in captured.err
    report = json.loads(captured.out)
    assert report["relative_error"]["overall"] < 0.02


def test_likely_units():
    assert [likely_unit(r, True) for r in (900.0, 80.0, 2e5)] == ["mm", "cm", "um"]
    assert likely_unit(57.3, False) == "deg"


def test_positions_in_degrees_beyond_the_urdf_limits_warn(tmp_path, capsys):
    model = physid.load_model(PLANAR2)
    sim = planar2_pd_run(model, duration=2.0)
    log = _csv(tmp_path / "deg.csv", "t [s],q1,q2,tau1,tau2",
               [sim.t, np.degrees(sim["q1"]) * 8, np.degrees(sim["q2"]) * 8,
                sim["tau1"], sim["tau2"]])  # fmt: skip
    rec = load_recording(log)
    messages = implausible_units(rec, model.joint_types, model.limits, source="deg.csv")
    assert messages and "channel 'q1' has no unit" in messages[0]
    assert "the model's joint limit 3 rad: is it in deg?" in messages[0]
    # each interface names its own fix: channels= in Python, --map on the command line
    assert str(PhysidWarning(messages[0])).endswith(
        "(a header 'q1 [deg]' or channels={'q1': 'SOURCE [deg]'}); a fit on it is wrong."
    )
    main(["identify", str(log), "--model", str(PLANAR2)])
    err = capsys.readouterr().err
    assert "physid: warning: " in err
    assert "or --map 'q1=SOURCE [deg]'); a fit on it is wrong." in err
    # with its unit in the header, nothing is doubtful
    tagged = _csv(tmp_path / "tagged.csv", "t [s],q1 [rad],q2 [rad]",
                  [sim.t, sim["q1"] * 400, sim["q2"]])  # fmt: skip
    assert implausible_units(load_recording(tagged), model.joint_types, model.limits) == []


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


def test_a_mat_log_in_millimetres_is_no_silent_success(tmp_path, capsys):
    from physid.simulate.closed_loop import simulate_closed_loop

    model_file = tmp_path / "axis.toml"
    model_file.write_text(AXIS)
    axis = physid.load_model(model_file)
    t = np.arange(5001) * 1e-3
    ramp = np.clip(t, 0, 1) ** 3
    r = ramp * (0.10 * np.sin(2 * np.pi * 0.4 * t) + 0.03 * np.sin(2 * np.pi * 1.3 * t + 1))
    w = 2 * np.pi * 5
    rec = simulate_closed_loop(axis, kp=[w**2 * 18], kd=[2 * w * 18], reference=r[:, None], t=t)
    log = tmp_path / "axis_mm.mat"
    scipy.io.savemat(log, {"t": t[:, None], "q1": 1000 * rec["q1"][:, None],
                           "tau1": rec["tau1"][:, None]})  # fmt: skip
    main(["identify", str(log), "--model", str(model_file), "--json"])
    captured = capsys.readouterr()
    m1 = json.loads(captured.out)["parameters"]["m1"]
    assert m1 == pytest.approx(0.018, rel=1e-2)  # 1000 times too small: the mm
    assert "m1 = 0.018 kg is 1000 times below the model nominal 18 kg" in captured.err
    assert "q1 have no unit in the file: in mm?" in captured.err
