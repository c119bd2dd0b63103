"""Fixes from the wave-3 review (findings F2, F10, F12, ...): each would fail on the old code."""

from __future__ import annotations

import numpy as np
import pytest

import physid
from physid.errors import DataFileError


@pytest.fixture
def degree_csv(tmp_path):
    path = tmp_path / "u.csv"
    path.write_text("t [s],pos [deg],tq [N*m]\n0,0,1\n0.001,10,1\n0.002,20,1\n0.003,30,1\n")
    return path


def test_map_unit_that_contradicts_the_header_is_refused(degree_csv):
    # F12: the map's [rad] used to relabel the file's degrees as radians (57x wrong angles).
    with pytest.raises(DataFileError, match=r"file says 'pos' is in \[deg\]"):
        physid.load_recording(degree_csv, {"q1": "pos [rad]", "tau1": "tq"})


@pytest.mark.parametrize("q1", ["pos", "pos [deg]", "pos*1 [rad]"])
def test_map_units_that_agree_convert_from_the_header(degree_csv, q1):
    rec = physid.load_recording(degree_csv, {"q1": q1, "tau1": "tq [N m]"})
    np.testing.assert_allclose(rec["q1"], np.deg2rad([0.0, 10.0, 20.0, 30.0]), rtol=1e-15)
    np.testing.assert_array_equal(rec["tau1"], np.ones(4))


# F2: identify used to drop the options of the other method family silently (exit 0).
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
    # F14: --detrend used to subtract the gravity load from tau and the mean angle from q, and
    # IDIM then reported success with a 48 % torque error.
    from physid.cli import main

    rec = tmp_path / "run.csv"
    rec.write_text("t,q1,q2,tau1,tau2\n0,0,0,0,0\n0.001,0,0,0,0\n0.002,0,0,0,0\n")
    argv = ["identify", str(rec), "--model", "tests/data/planar2.urdf", "--detrend"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--detrend would subtract the mean of q1, q2, tau1, tau2" in err
    assert "OF1..OFn" in err


def _reference_file(tmp_path, seconds=1.0):
    t = np.arange(0.0, seconds + 1e-12, 0.01)
    path = tmp_path / "ref.csv"
    rows = ["t,r1,r2"] + [f"{float(x)!r},{0.1 * float(np.sin(x))!r},0.0" for x in t]
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--duration", "3"], r"--duration 3 s is longer than the --reference file \(1 s\)"),
        (["--dt", "1e-8"], r"asks for 1e\+08 samples; at most 5e7"),
    ],
)
def test_simulate_with_reference_checks_duration_and_size(tmp_path, capsys, extra, message):
    # F4: --duration was silently ignored with --reference F, and the sample guard bypassed.
    import re

    from physid.cli import main

    ref = _reference_file(tmp_path)
    out = tmp_path / "out.csv"
    argv = ["simulate", "tests/data/planar2.urdf", "--reference", str(ref), "--out", str(out)]
    assert main([*argv, *extra]) == 2
    assert re.search(message, capsys.readouterr().err)
    assert not out.exists()


def test_simulate_honours_a_shorter_duration_with_a_reference(tmp_path):
    from physid.cli import main

    ref = _reference_file(tmp_path)
    out = tmp_path / "out.csv"
    argv = ["simulate", "tests/data/planar2.urdf", "--reference", str(ref), "--out", str(out)]
    assert main([*argv, "--duration", "0.5", "--dt", "0.01"]) == 0
    rec = physid.load_recording(out)
    assert rec.t.size == 51 and rec.t[-1] == pytest.approx(0.5, abs=1e-12)


def test_design_excitation_refuses_a_huge_grid_before_allocating(tmp_path, capsys):
    from physid.cli import main

    out = tmp_path / "x.csv"
    argv = ["design-excitation", "tests/data/planar2.urdf", "--harmonics", "2", "--period"]
    assert main([*argv, "1e12", "--out", str(out)]) == 2
    assert "asks for 1e+15 samples; at most 5e7" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["validate", "RESULT", "REC", "--plot", "FILE"],
        ["sweep", "msd", "--snr", "25", "--ratio", "1", "--trials", "1", "--out", "FILE"],
    ],
)
def test_folder_outputs_that_are_files_are_refused_first(tmp_path, capsys, argv):
    # F10: validate --plot FILE gave a FileExistsError traceback after the work; sweep --out FILE
    # ran every trial before refusing, in Python words (out_dir).
    from physid.cli import main

    existing = tmp_path / "notadir.txt"
    existing.write_text("mine\n")
    result = tmp_path / "r.json"
    result.write_text("{}")  # never read: the output is refused first
    rec = tmp_path / "h.csv"
    rec.write_text("t,q1\n0,0\n0.1,0\n")
    subst = {"RESULT": str(result), "REC": str(rec), "FILE": str(existing)}
    assert main([subst.get(a, a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert "is an existing file, not a folder" in err and "Traceback" not in err
    assert existing.read_text() == "mine\n"


def test_rls_bias_compensation_flag_and_its_mention_in_cli_words(tmp_path, capsys):
    # issue 15: the withholding reason named a Python keyword that had no flag.
    import json

    from physid.cli import main

    rec = tmp_path / "m30.csv"
    assert main(["simulate", "msd", "--out", str(rec), "--snr", "30", "--seed", "1"]) == 0
    capsys.readouterr()
    base = ["estimate", str(rec), "--model", "msd", "--method", "rls", "--json"]
    assert main(base) == 0
    plain = json.loads(capsys.readouterr().out)
    assert plain["stderr"] is None
    assert "--bias-compensation" in plain["stderr_reason"]
    assert "bias_compensation=" not in plain["stderr_reason"]
    assert main([*base, "--bias-compensation"]) == 0
    comp = json.loads(capsys.readouterr().out)
    assert set(comp["stderr"]) == {"theta1", "theta2"}
    assert all(v > 0 for v in comp["stderr"].values())
    assert comp["parameters"]["theta2"] != plain["parameters"]["theta2"]
    argv = ["estimate", str(rec), "--model", "msd", "--method", "algebraic", "--bias-compensation"]
    assert main(argv) == 2
