"""The ``physid filter`` verb."""

from __future__ import annotations

import re

import numpy as np
import pytest

from _helpers import cli_output as _main
from physid.cli import main
from physid.cli.verb_filter import derivative_unit
from physid.filters import design_filter
from physid.signals import Recording, load_recording, save_recording

DT = 1e-3


@pytest.fixture
def csv_file(tmp_path):
    t = DT * np.arange(400)
    data = np.column_stack([t**2, 3 * t, np.sin(2 * np.pi * 5 * t)])
    # qd2: a rate in m/s (a q channel must be an angle or a length: the loader checks it)
    rec = Recording(t, data, ("q1", "qd2", "tau1"), ("rad", "m/s", "N·m"))
    return save_recording(rec, tmp_path / "in.csv")


def test_second_derivative_of_selected_channels(tmp_path, csv_file, capsys):
    out = tmp_path / "out.csv"
    argv = [
        "filter",
        str(csv_file),
        "--kind",
        "second",
        "--half-width",
        "50",
        "--cutoff",
        "0.3",
        "--channels",
        "q1,qd2",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    assert capsys.readouterr().out.strip() == str(out)
    res = load_recording(out)
    assert res.names == ("q1_ddot", "qd2_ddot")
    assert res.units == ("rad/s^2", "m/s^3")
    np.testing.assert_allclose(res.t, DT * np.arange(50, 350), rtol=0, atol=1e-15)
    np.testing.assert_allclose(res["q1_ddot"], 2.0, rtol=1e-9)  # d²/dt² t² = 2 exactly
    np.testing.assert_allclose(res["qd2_ddot"], 0.0, atol=1e-6)
    assert res.metadata["filter"]["half_width"] == 50


def test_lowpass_all_channels_paper_length_matches_api(tmp_path, csv_file):
    out = tmp_path / "out.npz"
    assert (
        main(
            [
                "filter",
                str(csv_file),
                "--kind",
                "lowpass",
                "--half-width",
                "20",
                "--paper",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    res = load_recording(out)
    assert res.names == ("q1", "qd2", "tau1") and res.units == ("rad", "m/s", "N·m")
    src = load_recording(csv_file)
    want = design_filter("lowpass", 20, 0.2, src.dt).apply(src.data, paper=True)
    np.testing.assert_array_equal(res.data, want)
    assert res.n_samples == 400 - 40 - 1


def test_first_derivative_units(tmp_path, csv_file):
    out = tmp_path / "d.csv"
    assert (
        main(["filter", str(csv_file), "--kind", "first", "--half-width", "10", "--out", str(out)])
        == 0
    )
    res = load_recording(out)
    assert res.units == ("rad/s", "m/s^2", "N·m/s")
    np.testing.assert_allclose(res["qd2_dot"], 3.0, rtol=1e-9)


@pytest.mark.parametrize(
    ("extra", "pattern"),
    [
        (["--half-width", "300"], r"in\.csv: .*needs at least 601 samples but the record has 400"),
        (["--half-width", "0"], r"--half-width must be an integer >= 1"),
        (["--cutoff", "4"], r"cutoff \(Ω_g, rad/sample\) must lie in \(0, π\]"),
        (["--channels", "q9"], r"lacks channel\(s\) \['q9'\]"),
        (["--channels", ","], r"--channels expects names"),
    ],
)
def test_bad_input_exits_2_with_message(tmp_path, csv_file, capsys, extra, pattern):
    code = main(["filter", str(csv_file), "--out", str(tmp_path / "o.csv"), *extra])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("physid: error:")
    assert re.search(pattern, err), err


def test_bad_file_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,x\n0,1\n1,oops\n", encoding="utf-8")
    assert main(["filter", str(bad), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("physid: error:")
    assert "non-numeric cell 'oops' in column 'x' at line 3" in err


def test_resample_option_interpolates_non_uniform_file(tmp_path, capsys):
    t = DT * np.arange(200.0)
    t[100:] += 0.5 * DT  # one interval of 1.5 DT: not uniform
    src = tmp_path / "jitter.csv"
    src.write_text("t,x\n" + "".join(f"{ti:.17g},{3 * ti:.17g}\n" for ti in t), encoding="utf-8")
    out = tmp_path / "o.csv"
    argv = ["filter", str(src), "--kind", "first", "--half-width", "20", "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err  # CLI users are told the flag, not the Python keyword
    assert "Pass --resample to interpolate" in err and "resample=True" not in err
    assert main([*argv, "--resample"]) == 0
    res = load_recording(out)
    # linear data: interpolation onto the uniform grid is exact, and the slope is 3
    np.testing.assert_allclose(res["x_dot"], 3.0, rtol=1e-9)
    period = (t[-1] - t[0]) / (t.size - 1)
    np.testing.assert_allclose(np.diff(res.t), period, rtol=1e-9)


@pytest.mark.parametrize(
    ("unit", "order", "expected"),
    [
        ("rad", 1, "rad/s"),
        ("rad", 2, "rad/s^2"),
        ("m/s", 1, "m/s^2"),
        ("m/s²", 1, "m/s^3"),
        ("", 1, "1/s"),
        ("", 2, "1/s^2"),
        ("N m", 1, "(N m)/s"),
        ("rad", 0, "rad"),
    ],
)
def test_derivative_unit(unit, order, expected):
    assert derivative_unit(unit, order) == expected


def test_filter_cutoff_auto_prints_the_choice_and_uses_choose_filter(tmp_path, capsys):
    from physid.filters import choose_filter

    t = 1e-3 * np.arange(8000)
    q = np.sin(2 * np.pi * 2 * t) + 1e-4 * np.random.default_rng(1).normal(size=t.size)
    path = save_recording(Recording(t, q[:, None], ["q1"], ["rad"]), tmp_path / "n.csv")
    out = tmp_path / "f.csv"
    code, _, err = _main(["filter", path, "--cutoff", "auto", "--out", out], capsys)
    assert code == 0, err
    want = choose_filter(load_recording(path).data, 1e-3, half_width=100).cutoff
    meta = load_recording(out).metadata["filter"]
    assert meta["cutoff_rad_per_sample"] == pytest.approx(want, rel=1e-12)
    assert meta["cutoff_auto"] is True
    assert 0.05 < want < 0.3  # measured 0.1147 rad/sample (18.3 Hz) for a 2 Hz motion, M = 100
    assert "--cutoff auto, from q1: filter M = 100" in err
