"""``physid identify`` (physid.cli.verb_identify)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from _golden import CEDRO
from physid.cli import main
from physid.signals import Recording, save_recording
from physid.simulate.closed_loop import paper_manipulator_experiment

TOML = Path(__file__).resolve().parents[1] / "examples" / "models" / "manipulator.toml"
PAPER_INITIAL = ",".join(f"{k}={v}" for k, v in CEDRO["initial"].items())
TRUTH = CEDRO["truth"]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """The paper's experiment (paper kinetic energy) as CSV, and a copy without torques/metadata."""
    folder = tmp_path_factory.mktemp("identify")
    rec = paper_manipulator_experiment(kinetic="paper")
    full = folder / "arm.csv"
    save_recording(rec, full)
    names = ["q1", "q2", "q3", "q4", "r1", "r2", "r3", "r4"]
    bare = folder / "bare.csv"
    save_recording(Recording(rec.t, rec.select(names), names), bare)
    return full, bare


def run_json(capsys, argv):
    code = main(argv + ["--json"])
    captured = capsys.readouterr()
    return code, json.loads(captured.out), captured.err


def test_json_output_reproduces_the_paper(files, capsys):
    code, out, err = run_json(
        capsys,
        [
            "identify",
            str(files[0]),
            "--model",
            "manipulator",
            "--kinetic",
            "paper",
            "--torque",
            "pd",
            "--derivatives",
            "paper",
            "--half-width",
            "100",
            "--cutoff",
            "0.2",
            "--initial",
            PAPER_INITIAL,
        ],
    )
    assert code == 0
    for key in (
        "parameters",
        "stderr",
        "cost",
        "nfev",
        "njev",
        "success",
        "message",
        "unidentifiable",
        "fixed",
    ):
        assert key in out
    assert out["success"] is True
    assert out["unidentifiable"] == ["m1*l1**2"]
    assert out["fixed"] == {"l1": 0.41}
    assert out["stderr"]["l1"] is None  # held: not estimated
    assert out["cost"] == pytest.approx(CEDRO["result"]["J"], rel=0.10)  # the paper's J
    for name in ("m2", "m3", "m4", "l2", "l3", "l4"):
        assert out["parameters"][name] == pytest.approx(TRUTH[name], rel=1e-3)
    assert "m1 and l1 enter only as m1*l1**2" in err  # the warning goes to stderr


def test_fix_and_measured_torque(files, capsys):
    code, out, err = run_json(
        capsys,
        [
            "identify",
            str(files[0]),
            "--model",
            "manipulator",
            "--kinetic",
            "paper",
            "--fix",
            "l1=0.4",
            "--half-width",
            "100",
            "--cutoff",
            "0.2",
            "--start",
            "linear",
        ],
    )
    assert code == 0
    assert out["fixed"] == {"l1": 0.4}
    assert "enter only as" not in err
    assert out["parameters"]["m1"] == pytest.approx(50.0, rel=0.04)  # the paper filter's ~3 % bias


def test_toml_model_file_matches_builtin(files, capsys):
    common = [
        "--kinetic",
        "paper",
        "--start",
        "linear",
        "--torque",
        "pd",
        "--kp",
        "3800,40000,10000,500",
        "--kd",
        "159.5,120,50,2",
    ]
    code, from_file, _ = run_json(
        capsys, ["identify", str(files[0]), "--model", str(TOML)] + common
    )
    assert code == 0
    code, builtin, _ = run_json(
        capsys, ["identify", str(files[0]), "--model", "manipulator"] + common
    )
    for name, value in builtin["parameters"].items():
        assert from_file["parameters"][name] == pytest.approx(value, rel=1e-8), name


def test_text_output(files, capsys):
    assert (
        main(
            [
                "identify",
                str(files[0]),
                "--model",
                "manipulator",
                "--kinetic",
                "paper",
                "--start",
                "linear",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "InputErrorResult: success" in out and "m1*l1**2 = " in out


def test_missing_torques_is_a_clear_error(files, capsys):
    assert main(["identify", str(files[1]), "--model", "manipulator"]) == 2
    err = capsys.readouterr().err
    assert "physid: error:" in err and "lacks ['tau1', 'tau2', 'tau3', 'tau4']" in err


def test_pd_without_gains_is_a_clear_error(files, capsys):
    assert main(["identify", str(files[1]), "--model", "manipulator", "--torque", "pd"]) == 2
    assert "needs the kp gains" in capsys.readouterr().err


def test_bad_assignment_is_a_clear_error(files, capsys):
    assert main(["identify", str(files[0]), "--model", "manipulator", "--fix", "l1"]) == 2
    assert "--fix expects NAME=VALUE" in capsys.readouterr().err


def test_default_consistent_filters_meet_the_target_and_shrink_J(files, capsys):
    """Default filters: every identifiable quantity within 0.1 %, J far below the paper's."""
    code, out, _ = run_json(
        capsys,
        [
            "identify",
            str(files[0]),
            "--model",
            "manipulator",
            "--kinetic",
            "paper",
            "--torque",
            "pd",
            "--initial",
            PAPER_INITIAL,
        ],
    )
    assert code == 0 and out["derivatives"] == "consistent"
    for name in ("m2", "m3", "m4", "l2", "l3", "l4"):
        assert out["parameters"][name] == pytest.approx(TRUTH[name], rel=1e-3), name
    true_combination = TRUTH["m1"] * TRUTH["l1"] ** 2
    assert out["combinations"]["m1*l1**2"] == pytest.approx(true_combination, rel=1e-3)
    assert out["cost"] < 0.01 * CEDRO["result"]["J"]  # the paper's J is mostly filter inconsistency


def test_gains_without_pd_torque_exit_2(files, capsys):
    code = main(["identify", str(files[0]), "--model", "manipulator", "--kp", "1,2,3,4"])
    assert code == 2
    err = capsys.readouterr().err
    # the library names kp=/torque='pd'; the CLI may translate them to its flags
    assert re.search(
        r"physid: error: (kp=/kd=|--kp/--kd) are used only with (torque='pd'|--torque pd)", err
    )


def test_fit_on_a_bound_is_reported_and_fails(tmp_path, capsys):
    """Paper kinetic energy fitted to exact-arm data drives m1 (and m3) to the lower bound."""
    exact = tmp_path / "exact.csv"
    save_recording(paper_manipulator_experiment(kinetic="exact"), exact)
    code, out, err = run_json(
        capsys, ["identify", str(exact), "--model", "manipulator", "--kinetic", "paper"]
    )
    assert code == 1 and out["success"] is False
    assert out["at_bound"] == ["m1", "m3"]
    assert out["parameters"]["m1"] == pytest.approx(5e-5, rel=1e-3)  # 1e-6 x the initial 50
    assert out["stderr"] is None and "balance only to" in out["stderr_reason"]  # withheld
    assert "ended on a bound: m1 = 5e-05" in out["message"]
    assert "warning: the fit ended on a bound" in err


# identify must not drop the options of the other method family silently (exit 0).
@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--fix", "m1=5"], r"--fix applies to --method input-error, not to --method idim-ols"),
        (["--initial", "m1=2", "--noise", "compensate"], r"--initial, --noise apply to"),
        (["--method", "idim-wls", "--kp", "1,2"], r"--kp applies to --method idim-iv"),
        (["--method", "input-error", "--consistent"], r"--consistent applies to the idim-\*"),
        (["--method", "input-error", "--decimate", "5"], r"--decimate applies to the idim-\*"),
    ],
)
def test_identify_refuses_options_the_method_ignores(tmp_path, capsys, flags, message):
    import re

    from physid.cli import main

    rec = tmp_path / "run.csv"
    rec.write_text("t,q1,q2,tau1,tau2\n0,0,0,0,0\n0.001,0,0,0,0\n")  # never read: refused first
    assert main(["identify", str(rec), "--model", "tests/data/planar2.urdf", *flags]) == 2
    err = capsys.readouterr().err
    assert err.startswith("physid: error: ") and err.count("\n") == 1
    assert re.search(message, err), err


def test_detrend_of_joint_channels_is_refused_for_an_arm(tmp_path, capsys):
    # --detrend would subtract the gravity load from tau and the mean angle from q, and
    # IDIM then would report success with a 48 % torque error.
    from physid.cli import main

    rec = tmp_path / "run.csv"
    rec.write_text("t,q1,q2,tau1,tau2\n0,0,0,0,0\n0.001,0,0,0,0\n0.002,0,0,0,0\n")
    argv = ["identify", str(rec), "--model", "tests/data/planar2.urdf", "--detrend"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--detrend would subtract the mean of q1, q2, tau1, tau2" in err
    assert "OF1..OFn" in err
