"""``physid simulate manipulator|msd``: files written, values, seeds and error messages."""

import re

import numpy as np
import pytest

import physid
from physid.cli import main
from physid.signals import load_recording
from physid.simulate import msd_paper_scenario


def test_simulate_msd_writes_the_paper_scenario(tmp_path, capsys):
    out = tmp_path / "msd.csv"
    assert (
        main(["simulate", "msd", "--out", str(out), "--ratio", "10", "--snr", "25", "--seed", "4"])
        == 0
    )
    captured = capsys.readouterr()
    assert captured.out.strip() == str(out)
    assert "ω0 = 11.547" in captured.err
    rec = load_recording(out)
    assert rec.names == ("u", "x", "x_true")
    assert rec.unit("u") == "m/s^2" and rec.unit("x") == "m"
    ref = msd_paper_scenario(ratio=10.0, snr_db=25.0, seed=4)
    np.testing.assert_array_equal(rec.t, ref.t)
    np.testing.assert_array_equal(rec.data, ref.data)  # CSV round-trips bit for bit


def test_simulate_msd_clean_force_and_system_options(tmp_path, capsys):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["simulate", "msd", "--out", str(a), "--mass", "3", "--force", "1000"]) == 0
    assert main(["simulate", "msd", "--out", str(b), "--amplitude", str(1000 / 3)]) == 0
    ra, rb = load_recording(a), load_recording(b)
    assert ra.names == ("u", "x")
    np.testing.assert_allclose(ra["x"], rb["x"], rtol=0, atol=1e-12)
    c = tmp_path / "c.npz"
    args = [
        "simulate",
        "msd",
        "--out",
        str(c),
        "--natural-frequency",
        "20",
        "--damping-ratio",
        "0.1",
        "--duration",
        "1",
        "--dt",
        "0.002",
        "--initial",
        "0.01,0",
        "--jumps",
        "0.5:2400",
    ]
    assert main(args) == 0
    rc = load_recording(c)
    assert rc.n_samples == 501 and rc.dt == pytest.approx(0.002)
    assert rc["x"][0] == pytest.approx(0.01)
    assert rc.metadata["jumps"][0]["natural_frequency"] == pytest.approx(np.sqrt(2400 / 3.0))
    capsys.readouterr()


def test_simulate_msd_disturbance_reports_the_alias(tmp_path, capsys):
    out = tmp_path / "d.csv"
    assert main(["simulate", "msd", "--out", str(out), "--disturbance", "paper"]) == 0
    assert "appears at 509.683 rad/s" in capsys.readouterr().err
    rec = load_recording(out)
    np.testing.assert_allclose(
        rec["x"] - rec["x_true"], 0.1 * np.sin(500 * np.sqrt(400 / 3) * rec.t), atol=1e-12
    )


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        (["--force", "3"], "--force \\[N\\] needs --mass"),
        (["--snr", "loud"], "--snr \\[dB\\] expects a number"),
        (["--jumps", "0.5=300"], "--jumps expects TIME:STIFFNESS"),
        (["--disturbance", "0.1"], "--disturbance expects A2,W2"),
        (["--stiffness", "300", "--damping-ratio", "0.1"], "not both"),
        (["--seed", "-1"], "non-negative integer"),
        (["--duration", "1", "--dt", "0.3"], "whole number of sample periods"),
        (["--ratio", "-2"], "--ratio must be >= 0"),
        (["--initial", "1,2,3"], "--initial expects X0,V0"),
        # STYLE: never a silently ignored option — a seed without noise seeds nothing
        (["--seed", "4"], "--seed only seeds the measurement noise; give --snr"),
        (["--seed", "4", "--disturbance", "paper"], "--seed only seeds the measurement noise"),
    ],
)
def test_simulate_msd_bad_options_exit_2(tmp_path, capsys, extra, match):
    assert main(["simulate", "msd", "--out", str(tmp_path / "x.csv"), *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("physid: error:")
    assert re.search(match, err)
    assert not (tmp_path / "x.csv").exists()


def test_simulate_manipulator_with_noise(tmp_path, capsys):
    out = tmp_path / "arm.csv"
    args = ["simulate", "manipulator", "--out", str(out), "--noise-std", "1e-4", "--seed", "2"]
    assert main(args) == 0
    assert capsys.readouterr().out.strip() == str(out)
    rec = load_recording(out)
    assert rec.n_samples == 9701
    assert rec.channels("q") == ["q1", "q2", "q3", "q4"] and rec.channels("r") == [
        "r1",
        "r2",
        "r3",
        "r4",
    ]
    assert rec.metadata["noise"]["std"] == [1e-4] and rec.metadata["noise"]["seed"] == 2
    # the recorded torque is the PD law on the *clean* q, so it differs from the law on noisy q
    kp = np.array(rec.metadata["kp"])
    kd = np.array(rec.metadata["kd"])
    q, qd, r, tau = (rec.select(rec.channels(p)) for p in ("q", "qd", "r", "tau"))
    residual = tau - (kp * (r - q) - kd * qd)  # = −Kp · noise
    assert np.std(residual[:, 1] / kp[1]) == pytest.approx(1e-4, rel=0.05)
    assert main(["simulate", "manipulator", "--out", str(out), "--seed", "2"]) == 2
    assert "give --noise-std" in capsys.readouterr().err


def test_simulate_msd_help_states_each_default_once(capsys):
    with pytest.raises(SystemExit):
        main(["simulate", "msd", "--help"])
    text = capsys.readouterr().out
    assert "(default: None)" not in text
    assert "(default: 3)" in text and "(default 3)" not in text
    assert text.count("default:") == len(re.findall(r"\(default: [^)]*\)", text))


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
    # --duration must not be silently ignored with --reference F, nor the sample guard bypassed.
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
