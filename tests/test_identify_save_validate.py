"""identify --save → validate: the chain from a fit to its check on held-out data (input-error
and IDIM results)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import physid
from physid.analysis.validation import load_result, validate
from physid.cli import main
from physid.signals import save_recording
from physid.simulate.closed_loop import simulate_closed_loop


def _run(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def _held_out_reference(path, duration=4.0, dt=0.01):
    """Another trajectory than `simulate arm6`'s default multi-sine (other frequencies, phases)."""
    t = np.arange(0.0, duration + 1e-12, dt)
    env = 0.5 * (1 - np.cos(np.pi * np.clip(t / 1.0, 0, 1)))
    freq = 0.17 * (1.0 + 0.29 * np.arange(6))
    r = 0.25 * env[:, None] * np.sin(2 * np.pi * freq * t[:, None] + 0.7 * np.arange(6))
    rows = ["t," + ",".join(f"r{j + 1}" for j in range(6))]
    rows += [",".join(repr(float(v)) for v in (t[i], *r[i])) for i in range(t.size)]
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.fixture(scope="module")
def arm6_records(tmp_path_factory):
    d = tmp_path_factory.mktemp("arm6")
    paths = []
    for seed in (1, 2):
        p = d / f"run{seed}.csv"
        # the held-out run follows ANOTHER trajectory (not only other encoder noise)
        ref = [] if seed == 1 else ["--reference", str(_held_out_reference(d / "ref2.csv"))]
        argv = ["simulate", "arm6", "--out", str(p), "--duration", "4"]
        assert main([*argv, *ref, "--noise-std", "1e-4", "--seed", str(seed)]) == 0
        paths.append(p)
    return paths


def test_held_out_run_is_another_trajectory(arm6_records):
    from physid import load_recording

    a, b = (load_recording(p) for p in arm6_records)
    assert a.t.size == b.t.size
    # other motion and other torques, not the same run with other noise
    assert np.linalg.norm(a["tau1"] - b["tau1"]) > 0.3 * np.linalg.norm(a["tau1"])
    assert np.max(np.abs(a["r2"] - b["r2"])) > 0.1


def test_idim_result_file_validates_on_held_out_run(arm6_records, tmp_path, capsys):
    fit_file = tmp_path / "fit.json"
    code, _, _ = _run(
        [
            "identify",
            str(arm6_records[0]),
            "--model",
            "arm6",
            "--method",
            "idim-ols",
            "--save",
            str(fit_file),
            "--json",
        ],
        capsys,
    )
    saved = json.loads(fit_file.read_text())
    # 4 s of a low-frequency multi-sine: condition number 2.5e3, so the fit is refused as
    # weakly identified (exit 1), but its file is written and validates
    assert code == 1 and "Weakly identified" in saved["message"]
    train = saved["relative_error"]["overall"]
    code, out, _ = _run(
        ["validate", str(fit_file), str(arm6_records[1]), "--model", "arm6", "--json"], capsys
    )
    assert code == 0
    report = json.loads(out)
    held_out = report["relative_error"]["overall"]
    # another trajectory: a 4 s low-frequency multi-sine excites arm6's 52 base parameters
    # poorly, so the held-out error is larger than the training error (measured 0.052 against
    # 0.010), but it stays far below the doubled-parameter prediction checked next (~1)
    assert train < 0.03 and held_out < 0.1
    # base parameters define no simulable model: (b) is skipped, not run with nominal values
    assert report["fit_percent"] == {}
    # the base parameters are really used: doubling them must ruin the prediction
    saved["parameters"] = {k: 2 * v for k, v in saved["parameters"].items()}
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(saved))
    from physid import load_recording

    worse = validate(bad, load_recording(arm6_records[1]), model="arm6")
    assert worse.relative_error["overall"] > 0.5


def test_input_error_result_file_validates(tmp_path, capsys):
    train, held = tmp_path / "m.csv", tmp_path / "m2.csv"
    assert main(["simulate", "manipulator", "--out", str(train)]) == 0
    assert (
        main(["simulate", "manipulator", "--out", str(held), "--noise-std", "1e-5", "--seed", "3"])
        == 0
    )
    fit_file = tmp_path / "fit.json"
    code, _, err = _run(
        ["identify", str(train), "--model", "manipulator", "--save", str(fit_file)], capsys
    )
    assert code == 0 and "result written to" in err
    code, out, _ = _run(
        ["validate", str(fit_file), str(held), "--model", "manipulator", "--json"], capsys
    )
    assert code == 0
    report = json.loads(out)
    assert report["relative_error"]["overall"] < 0.02
    fits = np.array(list(report["fit_percent"].values()))
    assert fits.size == 4 and np.all(fits > 99.0)


def test_identify_save_refuses_its_own_recording(arm6_records, capsys):
    code, _, err = _run(
        [
            "identify",
            str(arm6_records[0]),
            "--model",
            "arm6",
            "--method",
            "idim-ols",
            "--save",
            str(arm6_records[0]),
        ],
        capsys,
    )
    assert code == 2
    assert "physid: error:" in err


# ------------------------------------- the model's options and the gains travel in the result file
KP = "3800,40000,10000,500"


KD = "159.5,120,50,2"


def test_result_file_keeps_the_model_options_and_the_cli_gains(tmp_path, capsys):
    run = tmp_path / "arm.csv"
    assert main(["simulate", "manipulator", "--out", str(run)]) == 0
    res = tmp_path / "kin.json"
    argv = ["identify", str(run), "--model", "manipulator", "--kinetic", "paper"]
    argv += ["--torque", "pd", "--kp", KP, "--kd", KD, "--save", str(res)]
    main(argv)
    data = json.loads(res.read_text())
    assert data["model_options"] == {"kinetic": "paper"}
    assert data["gains"] == {
        "kp": [3800.0, 40000.0, 10000.0, 500.0],
        "kd": [159.5, 120.0, 50.0, 2.0],
    }
    loaded = load_result(res)
    assert loaded.model.kinetic == "paper" and loaded.model_options == {"kinetic": "paper"}
    rec = physid.load_recording(run)
    paper = physid.load_model("manipulator", kinetic="paper")
    explicit = validate(res, rec, model=paper)  # the model object as it is
    # a held-out copy without the gains in its metadata: the file's gains are used
    bare = physid.Recording(rec.t, rec.data, rec.names, units=rec.units)
    report = validate(res, bare)
    for key, value in explicit.relative_error.items():
        assert report.relative_error[key] == pytest.approx(value, rel=1e-12)
    assert explicit.relative_error["tau4"] < 1.5  # the exact-T model gives ~2.5
    assert not [n for n in report.notes if n.startswith("model:")]
    # an older file without the options: loaded with the defaults, and a note says so
    data.pop("model_options")
    data.pop("gains")
    old = tmp_path / "old.json"
    old.write_text(json.dumps(data))
    notes = [n for n in validate(old, rec).notes if n.startswith("model:")]
    assert len(notes) == 1
    assert "does not record the options the model was loaded with" in notes[0]
    assert "kinetic 'exact'" in notes[0] and "gains in the held-out record's metadata" in notes[0]


# ---------------------------------------- the held-out log is read through the result's model file
AXIS_TOML = """
name = "axis"
gravity = [0.0, 0.0, -9.81]

[parameters]
m1 = { value = 12.0, unit = "kg" }
Fv1 = { value = 8.0, unit = "N*s/m" }
OF1 = { value = 1.5, unit = "N" }

[[joints]]
name = "carriage"
type = "prismatic"
transform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
axis = [1, 0, 0]
mass = "m1"
viscous = "Fv1"
torque_offset = "OF1"

[recording]
q1 = "pos"
tau1 = "force"
"""


def _axis_log(model, path, phase):
    t = np.arange(4001) * 1e-3
    ramp = 0.5 * (1 - np.cos(np.pi * np.clip(t, 0, 1)))
    r = ramp * (0.1 * np.sin(2 * np.pi * 0.4 * t + phase) + 0.03 * np.sin(2 * np.pi * 1.3 * t))
    w = 2 * np.pi * 5
    rec = simulate_closed_loop(model, kp=[w**2 * 12], kd=[2 * w * 12], reference=r[:, None], t=t)
    data = np.column_stack([rec["q1"], rec["tau1"]])
    save_recording(physid.Recording(t, data, ["pos", "force"], units=["m", "N"]), path)


def test_validate_reads_the_held_out_log_through_the_result_models_recording_table(
    tmp_path, capsys
):
    # docs/your-data.md §7: `physid validate axis_fit.json axis_heldout.mat` without --model
    # used to ignore the [recording] table of the model file the result names (exit 2).
    toml = tmp_path / "axis.toml"
    toml.write_text(AXIS_TOML)
    model = physid.load_model(toml)
    fit, held = tmp_path / "fit.csv", tmp_path / "held.csv"
    _axis_log(model, fit, 0.0)
    _axis_log(model, held, 1.0)
    res = tmp_path / "axis_fit.json"
    assert main(["identify", str(fit), "--model", str(toml), "--save", str(res)]) == 0
    capsys.readouterr()
    assert main(["validate", str(res), str(held), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["relative_error"]["overall"] < 1e-3  # noise-free, the model that made the data
