"""Wave 4, room data: reading users' recordings (the model file's [recording] table on physid's
own files, error messages that name the right column and fix, --map/--decimal on simulate's
--reference, filter --cutoff auto)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from physid.errors import DataFileError
from physid.signals import Recording, load_recording, save_recording

_AXIS = Path()  # the example's prismatic axis; its [recording] maps q1 = "qm", tau1 = "gtau*vir"


@pytest.fixture(scope="module", autouse=True)
def _axis_model_file(tmp_path_factory, axis_example):
    """Write examples/linear_axis_drive.py's model file (AXIS_TOML) where the tests read it."""
    global _AXIS
    _AXIS = tmp_path_factory.mktemp("axis") / "axis.toml"
    _AXIS.write_text(axis_example.AXIS_TOML, encoding="utf-8")


def _main(argv, capsys):
    from physid.cli import main

    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


# ------------------------------------------------------------------ 1. the [recording] table
def test_identify_reads_the_recording_simulate_wrote_from_a_model_with_a_recording_table(
    tmp_path, capsys
):
    # old: "--map q1=qm: the file has no variable 'qm'" though the file has q1 and nobody typed
    # --map; now the table's entries are skipped (with a note) and the truth comes back
    sim = tmp_path / "sim.csv"
    code, _, _ = _main(["simulate", "model", _AXIS, "--out", sim], capsys)
    assert code == 0
    code, out, err = _main(["identify", sim, "--model", _AXIS], capsys)
    assert code == 0, err
    assert "physid: note: the [recording] table of" in err and "q1 = 'qm'" in err
    values = {line.split()[0]: float(line.split()[2]) for line in out.splitlines() if " = " in line}
    # truth m1 = 12 kg, Fv1 = 8 N·s/m, Fc1 = 4 N, OF1 = 1.5 N (measured: 3.99988, 1.50004)
    assert values["Fc1"] == pytest.approx(4.0, abs=0.01)
    assert values["OF1"] == pytest.approx(1.5, abs=0.01)


def test_a_table_entry_whose_source_and_target_are_both_absent_names_the_table(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("t [s],pos [m],F [N]\n0,0,1\n0.1,0.1,2\n0.2,0.3,1\n")
    with pytest.raises(DataFileError) as info:
        load_recording(
            path,
            channel_defaults={"q1": "qm"},
            channel_defaults_source="the [recording] table of axis.toml",
        )
    text = str(info.value)
    assert "the [recording] table of axis.toml maps q1 = 'qm'" in text
    assert "no variable 'qm' and no channel 'q1'" in text and "['pos', 'F']" in text


def test_the_table_applies_where_the_file_has_its_sources_and_map_entries_stay_strict(tmp_path):
    path = tmp_path / "drive.csv"
    path.write_text("t [s],qm [m],vir [V],gtau\n0,0,1,2\n0.1,0.1,2,2\n0.2,0.3,1,2\n")
    table = {"q1": "qm", "tau1": "gtau*vir [N]"}
    rec = load_recording(path, channel_defaults=table)
    assert rec.names == ("q1", "tau1") and rec["tau1"].tolist() == [2.0, 4.0, 2.0]
    assert rec.metadata["channel_map"] == table
    # an explicit map is strict: a missing source is an error even though q1 could be found
    sim = tmp_path / "sim.csv"
    sim.write_text("t,q1\n0,0\n0.1,1\n")
    with pytest.raises(Exception, match="no variable 'qm'"):
        load_recording(sim, {"q1": "qm"})


def test_cli_error_for_an_absent_table_source_names_the_model_file_not_map(tmp_path, capsys):
    path = tmp_path / "log.csv"
    path.write_text("t [s],pos [m],F [N]\n0,0,1\n0.1,0.1,2\n0.2,0.3,1\n")
    code, _, err = _main(["identify", path, "--model", _AXIS], capsys)
    assert code == 2
    assert f"the [recording] table of {_AXIS} maps q1 = 'qm'" in err
    assert "--map q1=qm:" not in err and "--map 'q1=NAME'" in err


# ------------------------------------------------------------------ 2. error messages
def test_mapping_the_time_column_says_it_is_the_time(tmp_path):
    path = tmp_path / "logger.csv"
    path.write_text("Zeit [s],Weg [m],Kraft [N]\n0,0,1\n0.1,0.1,2\n0.2,0.3,1\n")
    with pytest.raises(DataFileError) as info:
        load_recording(path, {"t": "Zeit", "x": "Zeit", "u": "Kraft"})
    text = str(info.value)
    assert "is the file's time column" in text and "2-D variable with 0 columns" not in text


def test_an_unknown_unit_suggests_a_map_over_the_actual_column(tmp_path, capsys):
    path = tmp_path / "enc.csv"
    path.write_text("t [s],q1 [counts],tau1 [N]\n0,0,1\n0.1,10,2\n0.2,30,1\n")
    code, _, err = _main(["filter", path, "--out", tmp_path / "o.csv"], capsys)
    assert code == 2
    assert "--map 'q1=2*pi/4096*q1 [rad]'" in err and "0.001*pos" not in err
    # and that suggestion reads the file: 4096 counts are one turn
    rec = load_recording(path, {"q1": "2*pi/4096*q1 [rad]"})
    assert rec["q1"][1] == pytest.approx(2 * np.pi * 10 / 4096, rel=1e-15)


def test_a_degree_channel_on_a_prismatic_joint_names_the_headers_unit_and_file(tmp_path, capsys):
    path = tmp_path / "d.csv"
    path.write_text("t [s],q1 [deg],tau1 [N]\n0,0,1\n0.1,10,2\n0.2,30,1\n")
    code, _, err = _main(["identify", path, "--model", _AXIS], capsys)
    assert code == 2
    assert f"{path}: channel 'q1' is in deg (read as rad)" in err


def test_the_msd_force_refusal_names_the_file(tmp_path, capsys):
    path = tmp_path / "f.csv"
    path.write_text("t [s],u [N],x [m]\n0,0,1\n0.1,10,2\n0.2,30,1\n0.3,20,0\n")
    code, _, err = _main(["estimate", path, "--model", "msd"], capsys)
    assert code == 2
    assert err.startswith(f"physid: error: {path}: channel 'u' is in N")


def test_a_bad_map_entry_has_single_spaces(tmp_path, capsys):
    path = tmp_path / "f.csv"
    path.write_text("t,x\n0,0\n0.1,1\n")
    code, _, err = _main(["filter", path, "--map", "x=x,bad", "--out", tmp_path / "o.csv"], capsys)
    assert code == 2 and "--map expects NAME=SOURCE" in err and "  " not in err


# ------------------------------------------------------------------ 3. simulate, filter
def test_simulate_model_reads_a_reference_with_map_and_decimal(tmp_path, capsys):
    ref = tmp_path / "ref.csv"
    ref.write_text("Zeit;Soll [mm]\n0;0\n0,5;1,5\n1;3\n1,5;2\n2;0\n")
    out = tmp_path / "sim.csv"
    argv = ["simulate", "model", _AXIS, "--out", out, "--reference", ref]
    code, _, err = _main([*argv, "--map", "t=Zeit,r1=Soll", "--decimal", ","], capsys)
    assert code == 0, err
    rec = load_recording(out)
    # the reference is interpolated from the file (mm → m): 1.5 mm at 0.5 s, 3 mm at 1 s
    assert rec["r1"][np.searchsorted(rec.t, 0.5)] == pytest.approx(1.5e-3, rel=1e-9)
    assert rec["r1"][np.searchsorted(rec.t, 1.0)] == pytest.approx(3e-3, rel=1e-9)
    # without a reference file, --map has nothing to apply to: refused
    code, _, err = _main(["simulate", "model", _AXIS, "--out", out, "--map", "r1=x"], capsys)
    assert code == 2 and "--map applies to a --reference file" in err


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
