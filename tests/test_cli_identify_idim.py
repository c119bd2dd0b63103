"""``physid identify --method idim-*`` (physid.cli.verb_identify, IDIM part)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import physid
from physid.cli import main
from physid.estimators.idim import base_regressor_info
from physid.signals import Recording, save_recording
from physid.simulate.closed_loop import simulate_closed_loop

KP = "3800,40000,10000,500"
KD = "159.5,120,50,2"
W0 = 2 * np.pi * np.array([0.2, 0.3, 0.5, 0.7])


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("identify-idim")
    arm = physid.load_model("manipulator")
    out = []
    for k, phase in enumerate((0.0, 0.9)):
        t = np.arange(0.0, 6.0, 1e-3)
        ramp = np.clip(t / 1.0, 0.0, 1.0) ** 3  # start at rest: a step would be broadband
        ref = ramp[:, None] * (
            0.8 * np.sin(np.outer(t, W0) + phase) + 0.3 * np.sin(np.outer(t, 2.3 * W0) + 1)
        )
        rec = simulate_closed_loop(
            arm,
            kp=[float(x) for x in KP.split(",")],
            kd=[float(x) for x in KD.split(",")],
            reference=ref,
            t=t,
        )
        path = folder / f"run{k}.csv"
        save_recording(rec, path)
        out.append(path)
    names = [f"q{j}" for j in range(1, 5)] + [f"tau{j}" for j in range(1, 5)]
    rec = physid.load_recording(out[0])
    bare = folder / "bare.csv"
    save_recording(Recording(rec.t, rec.select(names), names), bare)
    truth = base_regressor_info(arm).from_standard(arm.beta())
    return out, bare, dict(zip(base_regressor_info(arm).names, truth, strict=True))


def run_json(capsys, argv):
    code = main(argv + ["--json"])
    captured = capsys.readouterr()
    return code, json.loads(captured.out), captured.err


@pytest.mark.parametrize("method", ["idim-ols", "idim-wls"])
def test_idim_json_holds_the_issue_fields(files, capsys, method):
    paths, _, truth = files
    code, out, _ = run_json(
        capsys,
        [
            "identify",
            str(paths[0]),
            str(paths[1]),
            "--model",
            "manipulator",
            "--method",
            method,
            "--cutoff",
            "0.3",
        ],
    )
    assert code == 0
    assert out["method"] == method
    assert out["n_recordings"] == 2
    for key in ("condition_number", "relative_error", "stderr", "iterations", "base_expressions"):
        assert key in out
    assert set(out["relative_error"]) == {"overall", "tau1", "tau2", "tau3", "tau4"}
    rows = {b["name"]: b for b in out["base_parameters"]}
    assert rows["m3*l3"]["expression"] == "m3*l3 + m4*l3"
    for name, value in truth.items():
        assert rows[name]["value"] == pytest.approx(value, rel=5e-3)
        assert rows[name]["stderr"] > 0


def test_iv_with_gains_on_the_command_line(files, capsys):
    paths, _, truth = files
    code, out, _ = run_json(
        capsys,
        [
            "identify",
            str(paths[0]),
            "--model",
            "manipulator",
            "--method",
            "idim-iv",
            "--kp",
            KP,
            "--kd",
            KD,
            "--cutoff",
            "0.3",
            "--max-iter",
            "3",
        ],
    )
    assert out["iterations"] >= 1
    assert len(out["iv_changes"]) == out["iterations"]
    assert out["parameters"]["m2*l2**2"] == pytest.approx(truth["m2*l2**2"], rel=5e-3)
    assert out["success"] and code == 0  # converged within 3 iterations: a success


def test_iv_without_controller_exits_2(files, capsys):
    _, bare, _ = files
    code = main(["identify", str(bare), "--model", "manipulator", "--method", "idim-iv"])
    err = capsys.readouterr().err
    assert code == 2
    assert "--kp" in err and "r1" in err


def test_input_error_refuses_several_files(files, capsys):
    paths, _, _ = files
    code = main(["identify", str(paths[0]), str(paths[1]), "--model", "manipulator"])
    assert code == 2
    assert "idim-ols" in capsys.readouterr().err


def test_default_method_of_the_paper_arm_stays_input_error(files, capsys):
    paths, _, _ = files
    from physid.cli.verb_identify import _default_method

    assert _default_method(physid.load_model("manipulator")) == "input-error"


def test_text_output(files, capsys):
    paths, _, _ = files
    code = main(
        [
            "identify",
            str(paths[0]),
            "--model",
            "manipulator",
            "--method",
            "idim-ols",
            "--cutoff",
            "0.3",
            "--decimate",
            "20",
        ]
    )
    out = capsys.readouterr().out
    assert code == 0
    assert "condition number" in out and "m1*l1**2" in out


def test_decimate_auto_on_the_command_line_is_the_default(files, capsys):
    paths, _, _ = files
    argv = ["identify", str(paths[0]), "--model", "manipulator", "--method", "idim-ols"]
    code_default, default, _ = run_json(capsys, argv)
    code_auto, auto, _ = run_json(capsys, argv + ["--decimate", "auto"])
    assert code_default == code_auto == 0
    assert "chosen by a 5-fold cross-validated torque error" in auto["message"]
    assert auto["decimate"] == default["decimate"] > 1
    values = [[b["value"] for b in out["base_parameters"]] for out in (default, auto)]
    np.testing.assert_array_equal(values[0], values[1])
