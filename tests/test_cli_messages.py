"""The command line speaks its own words: flags and ``--map`` lines, never Python arguments.

Every hostile-input case (tests/hostile) also checks its stderr with `python_words`; this module
checks the rewording itself, the documented errors, and the ``--map`` line that a "needs
channel" error shows, guessed from the file's own columns.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from hostile._cases import python_words, run_cli
from physid._hints import guess_map, joint_hint, map_hint, unit_kind
from physid.cli._common import cli_words
from physid.errors import InputError

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(
    ("library", "command_line"),
    [
        (
            "Pass --resample to interpolate onto a uniform grid with the mean period (or "
            "uniform_rtol=None to keep the time vector as it is).",
            "Pass --resample to interpolate onto a uniform grid with the mean period.",
        ),
        (
            "a 95 % interval would not cover. Use final='bias-compensated' for an estimate",
            "a 95 % interval would not cover. Use --final bias-compensated for an estimate",
        ),
        ("map it with channels={'t': 'NAME'}.", "map it with --map 't=NAME'."),
        (
            "e.g. channels={'u': 'Force', 'x': 'pos [mm]'}",
            "e.g. --map 'u=Force,x=pos [mm]'",
        ),
        ("Map them with channels={NAME: COLUMN}.", "Map them with --map NAME=COLUMN."),
        ("and delimiter=',' cannot both hold", "and --delimiter ',' cannot both hold"),
    ],
)
def test_cli_words_rewords_python_arguments(library, command_line):
    assert python_words(library)
    assert cli_words(library) == command_line
    assert python_words(cli_words(library)) == []


def test_python_words_finds_each_kind_and_spares_command_line_syntax():
    text = "x uniform_rtol=None, final='median', kp=[...], fixed={'l1': 1}, {NAME: COLUMN}"
    assert python_words(text) == [
        "uniform_rtol=None",
        "final='",
        "kp=[",
        "fixed={",
        "{NAME: COLUMN}",
    ]
    assert python_words("--map 'tau1=35.15*vir [N]' --fix l1=0.4 --kp 1,2") == []


def test_unit_kind_and_guess_map_by_unit_then_name():
    assert [unit_kind(u) for u in ("N", "mm", "deg", "N·m", "V", "")] == [
        "force",
        "length",
        "angle",
        "torque",
        None,
        None,
    ]
    # by unit: a column named oddly but in N is the force
    names = ["Temperature", "F1", "Weg"]
    units = {"Temperature": "degC", "F1": "N", "Weg": "mm"}
    assert guess_map({"u": ("force",), "x": ("length",)}, names, units) == {"u": "F1", "x": "Weg"}
    # by name when there are no units; a channel the file has is not mapped
    assert guess_map({"u": ("force",), "x": ("length",)}, ["Force", "x"]) == {"u": "Force"}
    # nothing likely: no guess
    assert guess_map({"u": ("force",)}, ["Temperature"]) == {}


def test_map_hint_renders_in_each_interface():
    e = InputError("no u. " + map_hint({"u": "Force", "x": "Displacement"}))
    assert str(e).endswith("channels={'u': 'Force', 'x': 'Displacement'}.")
    assert e.render({"channels": "--map"}).endswith("--map u=Force,x=Displacement.")
    placeholder = InputError(map_hint({}, {"u": "COLUMN"}))
    assert placeholder.render({"channels": "--map"}) == (
        "Map them from the file's columns, e.g. --map u=COLUMN."
    )
    text = InputError(joint_hint(2, ["t", "angle 1", "angle 2", "torque 1", "torque 2"]))
    assert text.render({"channels": "--map"}) == (
        "The file's columns suggest --map 'q1=angle 1,q2=angle 2,tau1=torque 1,tau2=torque 2'."
    )


def _force_log(path: Path) -> Path:
    t = np.arange(0, 1.0, 0.001)
    u = np.sin(7 * t) + 0.5 * np.sin(31 * t) + 0.3 * np.sin(83 * t)
    x = 1e-3 * np.sin(7 * t - 0.3) + 2e-4 * np.sin(31 * t - 1.0) + 5e-5 * np.sin(83 * t - 2.0)
    rows = "\n".join(f"{a:.4f},{b:.6f},{c:.8f},21.5" for a, b, c in zip(t, u, x, strict=True))
    path.write_text("time [s],Force [N],Displacement [m],Temperature [degC]\n" + rows + "\n")
    return path


def test_needs_channel_error_shows_the_map_line_that_fixes_it(tmp_path):
    log = _force_log(tmp_path / "rig.csv")
    res = run_cli(["estimate", str(log), "--model", "msd-force", "--method", "rls"])
    assert res.code == 2
    assert "it has ['Force', 'Displacement', 'Temperature']" in res.err
    assert "--map u=Force,x=Displacement" in res.err
    assert python_words(res.err) == []
    # and the line works: with it, the estimate runs
    fixed = run_cli(
        ["estimate", str(log), "--model", "msd-force", "--method", "rls"]
        + ["--map", "u=Force,x=Displacement"]
    )
    assert fixed.code in (0, 1), fixed.err
    assert "needs an input channel" not in fixed.err


def test_needs_channel_error_in_python_names_channels(tmp_path):
    from physid.estimators.registry import make
    from physid.models import load_model
    from physid.signals import load_recording

    rec = load_recording(_force_log(tmp_path / "rig.csv"))
    with pytest.raises(InputError, match=r"channels=\{'u': 'Force', 'x': 'Displacement'\}"):
        make("rls", load_model("msd-force")).fit(rec)


def test_arm_error_suggests_joint_columns(tmp_path):
    t = np.arange(0, 0.5, 0.001)
    cols = "\n".join(f"{a:.4f},{np.sin(a):.6f},{np.cos(a):.6f}" for a in t)
    log = tmp_path / "arm.csv"
    log.write_text("t [s],angle [rad],torque [N·m]\n" + cols + "\n")
    res = run_cli(["identify", str(log), "--model", str(ROOT / "tests/data/pendulum1.toml")])
    assert res.code == 2
    assert "--map q1=angle,tau1=torque" in res.err
    assert python_words(res.err) == []


def _documented_errors() -> list[str]:
    lines = []
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for line in doc.read_text(encoding="utf-8").splitlines():
            if re.search(r"physid: (error|warning): \S", line):
                lines.append(line.strip())
    return lines


def test_documented_errors_speak_command_line():
    lines = _documented_errors()
    assert len(lines) >= 5
    leaks = {line: python_words(line) for line in lines if python_words(line)}
    assert leaks == {}


def test_zero_signal_with_snr_names_no_python_argument(tmp_path):
    res = run_cli(
        ["simulate", "msd", "--out", str(tmp_path / "z.csv"), "--amplitude", "0", "--snr", "40"]
    )
    assert res.code == 2
    assert "Give the system a non-zero input." in res.err
    assert python_words(res.err) == [] and "noise_std" not in res.err
    from physid.signals.noise import noise_std_for_snr  # the library names its argument

    with pytest.raises(InputError, match=r"noise_std=\.\.\."):
        noise_std_for_snr(np.zeros((10, 1)), 40.0)
