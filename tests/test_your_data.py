"""The user's own files: channel maps, units, structs, decimal commas, pandas (docs/your-data.md)."""

from __future__ import annotations

import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.io

import physid
from _helpers import cli_output as _main
from physid.cli import main
from physid.errors import (
    DataFileError,
    ExpressionError,
    InputError,
    MissingDependencyError,
)
from physid.signals import Recording, load_recording, save_recording

T = 1e-3 * np.arange(200)
QM = np.sin(3 * T)
VIR = np.cos(2 * T)
GTAU = 35.15


@pytest.fixture
def drive_mat(tmp_path):
    """A drive log as MATLAB writes it: column vectors, a scalar gain and a text note."""
    path = tmp_path / "drive.mat"
    scipy.io.savemat(
        path, {"t": T[:, None], "qm": QM[:, None], "vir": VIR[:, None], "gtau": GTAU, "note": "x"}
    )
    return path


# ------------------------------------------------------------------------------- channel maps
def test_channel_map_with_expression_over_a_scalar_of_the_file(drive_mat):
    rec = load_recording(drive_mat, {"q1": "qm", "tau1": "gtau*vir"})
    assert rec.names == ("q1", "tau1")
    np.testing.assert_array_equal(rec["q1"], QM)
    np.testing.assert_array_equal(rec["tau1"], GTAU * VIR)
    assert rec.metadata["channel_map"] == {"q1": "qm", "tau1": "gtau*vir"}
    assert "gtau" not in rec.names and "note" in rec.metadata["ignored_variables"]


def test_channel_map_as_cli_text_and_unmapped_channels_kept(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("time [ms],pos [mm],F [N],temp\n0,1,2,20\n1,2,3,21\n2,4,5,22\n")
    rec = load_recording(path, "x=pos, u=2*F [N]")
    assert rec.names == ("x", "u", "temp")  # pos and F are used by the map, temp is kept
    np.testing.assert_allclose(rec.t, [0.0, 1e-3, 2e-3])
    np.testing.assert_array_equal(rec["x"], [0.001, 0.002, 0.004])
    np.testing.assert_array_equal(rec["u"], [4.0, 6.0, 10.0])
    assert rec.units == ("m", "N", "")


def test_expressions_see_values_in_si(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("t,a [mm],b [mm]\n0,1,2\n1,2,3\n")
    rec = load_recording(path, {"x": "a + b"})
    np.testing.assert_allclose(rec["x"], [0.003, 0.005], rtol=1e-15)


def test_matlab_structs_are_reached_with_dots(tmp_path):
    path = tmp_path / "s.mat"
    scipy.io.savemat(
        path, {"data": {"time": T, "pos": QM, "F": VIR, "inner": {"v": 2 * QM}}, "gain": 2.0}
    )
    rec = load_recording(path, {"x": "data.pos", "u": "gain*data.F", "v": "data.inner.v"})
    assert rec.names == ("x", "u", "v")  # data.time is recognised as the time
    np.testing.assert_array_equal(rec.t, T)
    np.testing.assert_array_equal(rec["u"], 2.0 * VIR)
    np.testing.assert_array_equal(rec["v"], 2 * QM)
    with pytest.raises(
        ExpressionError, match=r"no variable 'data\.poss'; its channels are \[.*'data\.pos'"
    ):
        load_recording(path, {"x": "data.poss"})


@pytest.mark.parametrize("header", ["t", "time", "Time", "TIME", "t [s]", "time [ms]", "Time [s]"])
def test_time_is_recognised(tmp_path, header):
    path = tmp_path / "r.csv"
    path.write_text(f"{header},x\n0,1\n2,2\n4,3\n")
    rec = load_recording(path)
    scale = 1e-3 if "ms" in header else 1.0
    np.testing.assert_allclose(rec.t, [0.0, 2 * scale, 4 * scale])
    assert rec.names == ("x",)


def test_time_by_map_and_by_expression(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("stamp,x\n0,1\n2,2\n4,3\n")
    assert load_recording(path, {"t": "stamp"}).dt == 2.0
    assert load_recording(path, {"t": "stamp [ms]"}).dt == pytest.approx(2e-3)
    assert load_recording(path, {"t": "stamp/1000"}).dt == pytest.approx(2e-3)


@pytest.mark.parametrize(
    ("channels", "error", "pattern"),
    [
        (
            {"q1": "qmm"},
            ExpressionError,
            r"no variable 'qmm'; its channels are \['qm', 'vir'\] and its scalars \['gtau'\]",
        ),
        (
            {"tau1": "gtau*virr"},
            ExpressionError,
            r"channels\['tau1'\] = 'gtau\*virr': the file has no variable 'virr'",
        ),
        ({"q1": "__import__('os').system('x')"}, ExpressionError, r"not attribute calls"),
        ({"q1": "qm.real"}, ExpressionError, r"attribute|no variable .qm\.real."),
        ({"q1": "gtau"}, DataFileError, r"channels\['q1'\] = 'gtau' is a scalar \(35\.15\)"),
        ({"q1": "2*gtau"}, DataFileError, r"is a constant \(70\.3\)"),
        ({"q1": "1/(qm - qm)"}, DataFileError, r"is (nan|inf) at sample 0.*division by zero"),
        ({"q1": "note"}, DataFileError, r"'note' holds text"),
        ("q1", InputError, r"NAME=SOURCE pairs"),
        ({"q1": ""}, InputError, r"must be a variable name or an expression"),
        ({"q1": 3}, InputError, r"must be a variable name or an expression"),
        ([("q1", "qm")], InputError, r"must be a mapping"),
    ],
)
def test_channel_map_errors_name_the_channel_and_the_fix(drive_mat, channels, error, pattern):
    with pytest.raises(error, match=pattern):
        load_recording(drive_mat, channels)


# ------------------------------------------------------------------------------- units
def test_header_units_are_converted_to_si(tmp_path):
    path = tmp_path / "u.csv"
    path.write_text("Time [ms];pos [deg];F [kN];w [rpm]\n0;180;2;60\n1;90;3;60\n2;0;4;60\n")
    rec = load_recording(path)
    np.testing.assert_allclose(rec["pos"], [np.pi, np.pi / 2, 0.0], rtol=1e-15)
    np.testing.assert_array_equal(rec["F"], [2000.0, 3000.0, 4000.0])
    np.testing.assert_allclose(rec["w"], 2 * np.pi, rtol=1e-15)
    assert rec.units == ("rad", "N", "rad/s")
    assert rec.metadata["original_units"] == {"pos": "deg", "F": "kN", "w": "rpm"}


def test_one_unit_rule_for_csv_npz_mat_and_hdf5(tmp_path):
    """The same log with units [ms], [mm], [min] in each format gives the same recording."""
    t_ms, pos_mm, slow = 1000 * T, 1000 * QM, T / 60
    (tmp_path / "a.csv").write_text(
        "t [ms],pos [mm],slow [min]\n"
        + "".join(
            f"{a},{b},{c}\n"
            for a, b, c in zip(t_ms.tolist(), pos_mm.tolist(), slow.tolist(), strict=True)
        )
    )
    np.savez(
        tmp_path / "a.npz",
        t=t_ms,
        data=np.column_stack([pos_mm, slow]),
        names=np.array(["pos", "slow"]),
        units=np.array(["mm", "min"]),
    )
    with h5py.File(tmp_path / "a.h5", "w") as f:
        for name, values, unit in (("t", t_ms, "ms"), ("pos", pos_mm, "mm"), ("slow", slow, "min")):
            f.create_dataset(name, data=values).attrs["unit"] = unit
    scipy.io.savemat(
        tmp_path / "a.mat",
        {"t": t_ms, "data": np.column_stack([pos_mm, slow]), "names": ["pos", "slow"],
         "units": ["mm", "min"]},
    )  # fmt: skip
    # NPZ and MAT have no unit attribute for t: the map gives it ("t [ms]")
    recs = [load_recording(tmp_path / f"a.{ext}") for ext in ("csv", "h5")] + [
        load_recording(tmp_path / f"a.{ext}", {"t": "t [ms]"}) for ext in ("npz", "mat")
    ]
    for rec in recs:
        assert rec.names == ("pos", "slow") and rec.units == ("m", "s")
        assert rec.dt == pytest.approx(1e-3, rel=1e-9)
        np.testing.assert_allclose(rec["pos"], QM, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(rec["slow"], T, rtol=1e-12, atol=1e-15)


def test_hdf5_groups_and_time_unit_attribute(tmp_path):
    path = tmp_path / "g.h5"
    with h5py.File(path, "w") as f:
        log = f.create_group("log")
        log.create_dataset("time", data=1000 * T).attrs["unit"] = "ms"
        log.create_dataset("pos", data=QM).attrs["units"] = b"deg"
    rec = load_recording(path, {"t": "log.time", "q1": "log.pos"})
    assert rec.dt == pytest.approx(1e-3)  # the 'ms' attribute is honoured (was: dt = 1 s)
    np.testing.assert_allclose(rec["q1"], np.deg2rad(QM), rtol=1e-15)


def test_voltage_on_a_torque_channel_is_refused_with_the_map_that_fixes_it(tmp_path):
    path = tmp_path / "v.csv"
    path.write_text("t,q1 [rad],tau1 [V]\n0,1,2\n0.1,2,3\n0.2,3,4\n")
    with pytest.raises(
        DataFileError,
        match=r"channel 'tau1' is in V \(a voltage\), but tau1 must be a torque \[N·m\] or a "
        r"force \[N\]; .*channels=\{'tau1': '35\.15\*tau1'\}",
    ):
        load_recording(path)
    rec = load_recording(path, {"tau1": "35.15*tau1 [N·m]"})
    np.testing.assert_allclose(rec["tau1"], [70.3, 105.45, 140.6])
    assert rec.unit("tau1") == "N·m"


def test_unknown_units_refused_on_channels_physid_reads_kept_on_others(tmp_path):
    path = tmp_path / "c.csv"
    path.write_text("t,q1 [counts],temp [degC]\n0,1,20\n1,2,21\n")
    with pytest.raises(DataFileError, match=r"channel 'q1' has unit 'counts', which physid cannot"):
        load_recording(path)
    rec = load_recording(path, {"q1": "2*pi/4096*q1"})  # an expression: the raw counts scaled
    np.testing.assert_allclose(rec["q1"], [2 * np.pi / 4096, 4 * np.pi / 4096])
    assert rec.unit("temp") == "degC" and rec.metadata["unconverted_units"] == {"temp": "degC"}


# ------------------------------------------------------------------------------- CSV dialects
def test_decimal_comma_and_semicolons(tmp_path):
    path = tmp_path / "dc.csv"
    path.write_text("t;x [mm];u\n0,0;1,5;2\n0,1;1,6;3\n0,2;1,7;4\n")
    with pytest.raises(DataFileError, match=r"non-numeric cell '0,0'.*pass decimal=','"):
        load_recording(path)
    rec = load_recording(path, decimal=",")
    np.testing.assert_allclose(rec["x"], [1.5e-3, 1.6e-3, 1.7e-3])
    np.testing.assert_allclose(rec.t, [0.0, 0.1, 0.2])
    assert load_recording(path, decimal=",", delimiter=";").names == ("x", "u")


def test_explicit_delimiter_and_option_errors(tmp_path):
    path = tmp_path / "tab.csv"
    path.write_text("t\tx\n0\t1\n1\t2\n")
    assert load_recording(path, delimiter="\t").names == ("x",)
    with pytest.raises(InputError, match=r"decimal=',' and delimiter=',' cannot both hold"):
        load_recording(path, decimal=",", delimiter=",")
    with pytest.raises(InputError, match=r"decimal must be '\.' or ','"):
        load_recording(path, decimal=";")
    with pytest.raises(InputError, match=r"delimiter must be"):
        load_recording(path, delimiter="|")
    np.savez(tmp_path / "a.npz", t=T, x=QM)
    with pytest.raises(InputError, match=r"apply to CSV files only"):
        load_recording(tmp_path / "a.npz", decimal=",")


# ------------------------------------------------------------------------------- pandas, detrend
def test_dataframe_round_trip_with_units_in_column_names():
    pd = pytest.importorskip("pandas")  # the dev extra installs it; this guards odd installs
    df = pd.DataFrame({"time [ms]": [0.0, 1.0, 2.0], "pos [mm]": [1.0, 2.0, 3.0], "F": [4, 5, 6]})
    rec = Recording.from_dataframe(df, time="time [ms]", units={"F": "N"})
    np.testing.assert_allclose(rec.t, [0.0, 1e-3, 2e-3])
    assert rec.names == ("pos", "F") and rec.units == ("m", "N")
    back = rec.to_dataframe()
    assert list(back.columns) == ["pos", "F"] and back.index.name == "t"
    assert back.attrs["units"] == {"pos": "m", "F": "N"}
    again = Recording.from_dataframe(rec.to_dataframe(units_in_names=True))
    np.testing.assert_array_equal(again.data, rec.data)
    assert again.units == rec.units
    td = pd.DataFrame({"x": [1.0, 2.0]}, index=pd.to_timedelta([0, 5], unit="ms"))
    assert Recording.from_dataframe(td).t.tolist() == [0.0, 0.005]
    with pytest.raises(InputError, match=r"time='tt' is not a column"):
        Recording.from_dataframe(df, time="tt")
    with pytest.raises(InputError, match=r"holds object values"):
        Recording.from_dataframe(pd.DataFrame({"t": [0.0, 1.0], "s": ["a", "b"]}), time="t")


def test_pandas_missing_gives_the_install_command(monkeypatch):
    rec = Recording([0.0, 1.0], [1.0, 2.0], ["x"])
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(MissingDependencyError, match=r'pip install "physid\[pandas\]"'):
        rec.to_dataframe()
    with pytest.raises(MissingDependencyError, match=r"from_dataframe needs pandas"):
        Recording.from_dataframe(object())


def test_detrend_removes_means_or_lines():
    t = np.linspace(0.0, 1.0, 11)
    rec = Recording(t, np.column_stack([2 + 3 * t, 5 + 0 * t]), ["x", "u"], ["m", "N"])
    flat = rec.detrend()
    np.testing.assert_allclose(flat.data.mean(axis=0), 0.0, atol=1e-15)
    assert flat.metadata["detrended"] == pytest.approx({"x": 3.5, "u": 5.0})
    line = rec.detrend(["x"], kind="linear")
    np.testing.assert_allclose(line["x"], 0.0, atol=1e-14)
    np.testing.assert_array_equal(line["u"], rec["u"])
    with pytest.raises(InputError, match=r"no channel\(s\) \['y'\]"):
        rec.detrend(["y"])
    with pytest.raises(InputError, match=r"kind must be 'constant' or 'linear'"):
        rec.detrend(kind="quadratic")


# ------------------------------------------------------------------------------- the command line
@pytest.fixture
def force_log(tmp_path):
    """The paper's MSD (m = 3 kg) logged with a force sensor [N] and an encoder [mm]."""
    from physid.simulate import msd_paper_scenario

    rec = msd_paper_scenario(ratio=1.0)
    log = Recording(
        rec.t, np.column_stack([3.0 * rec["u"], 1000 * rec["x"]]), ("F", "pos"), ("N", "mm")
    )
    return save_recording(log, tmp_path / "force.csv")


def test_cli_map_and_the_force_input_msd(force_log, capsys):
    import json

    argv = ["estimate", str(force_log), "--model", "msd-force", "--map", "u=F,x=pos", "--json"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)["parameters"]
    assert out["theta2"] == pytest.approx(400 / 3, rel=1e-6)
    assert out["b0"] == pytest.approx(1 / 3, rel=1e-6)
    model = physid.load_model("msd-force")
    phys = model.physical_from_coefficients({k: out[k] for k in ("theta2", "theta1", "b0")})
    assert phys.values["m"] == pytest.approx(3.0, rel=1e-6)
    assert phys.values["k"] == pytest.approx(400.0, rel=1e-6)


def test_cli_refuses_a_force_for_the_normalised_msd(force_log, capsys):
    assert main(["estimate", str(force_log), "--model", "msd", "--map", "u=F,x=pos"]) == 2
    err = capsys.readouterr().err
    assert "channel 'u' is in N (a force), but model 'msd' takes its input u in m/s^2" in err
    assert "--model msd-force" in err and "--map 'u=F/MASS [m/s^2]'" in err
    assert "load_model" not in err  # CLI words only
    argv = ["estimate", str(force_log), "--model", "msd", "--map", "u=F/3 [m/s^2],x=pos"]
    assert main(argv) == 0


def test_cli_model_file_recording_table_and_decimal_comma(tmp_path, capsys):
    import json

    from physid.simulate import msd_paper_scenario

    rec = msd_paper_scenario(ratio=1.0)
    lines = ["zeit;weg [mm];kraft [N]"] + [
        f"{t};{1000 * x};{3 * u}".replace(".", ",")
        for t, x, u in zip(rec.t.tolist(), rec["x"].tolist(), rec["u"].tolist(), strict=True)
    ]
    data = tmp_path / "de.csv"
    data.write_text("\n".join(lines) + "\n")
    model = tmp_path / "msd_force.toml"
    model.write_text(
        'name = "msd_force"\nkind = "linear_ode"\n'
        "[parameters]\n"
        'm = { value = 1.0, unit = "kg" }\nc = { value = 0.1, unit = "N*s/m" }\n'
        'k = { value = 100.0, unit = "N/m" }\n'
        '[ode]\na = ["k/m", "c/m"]\nb = ["1/m"]\ninput_unit = "N"\noutput_unit = "m"\n'
        '[recording]\nt = "zeit"\nx = "weg"\nu = "kraft"\n'
    )
    argv = ["estimate", str(data), "--model", str(model), "--decimal", ",", "--json"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)["parameters"]
    fitted = physid.load_model(model).physical_from_coefficients(
        {k: out[k] for k in ("a0", "a1", "b0")}
    )
    assert fitted.values == pytest.approx({"m": 3.0, "c": 0.05, "k": 400.0}, rel=1e-4)


def test_cli_detrend_removes_a_sensor_offset(tmp_path, capsys):
    import json

    from physid.simulate import msd_paper_scenario

    rec = msd_paper_scenario(ratio=10.0)
    # a 1 cm encoder offset (the motion is ±0.1 m and about centred)
    biased = Recording(rec.t, np.column_stack([rec["u"], rec["x"] + 0.01]), ("u", "x"))
    path = save_recording(biased, tmp_path / "b.csv")
    argv = ["estimate", str(path), "--model", "msd", "--json"]
    assert main(argv) in (0, 1)
    raw = json.loads(capsys.readouterr().out)["parameters"]["theta2"]
    assert main([*argv, "--detrend"]) == 0
    fixed = json.loads(capsys.readouterr().out)["parameters"]["theta2"]
    assert abs(fixed - 400 / 3) < 0.2 * abs(raw - 400 / 3)


@pytest.fixture
def degree_csv(tmp_path):
    path = tmp_path / "u.csv"
    path.write_text("t [s],pos [deg],tq [N*m]\n0,0,1\n0.001,10,1\n0.002,20,1\n0.003,30,1\n")
    return path


def test_map_unit_that_contradicts_the_header_is_refused(degree_csv):
    # the map's [rad] must not relabel the file's degrees as radians (57x wrong angles)
    with pytest.raises(DataFileError, match=r"file says 'pos' is in \[deg\]"):
        physid.load_recording(degree_csv, {"q1": "pos [rad]", "tau1": "tq"})


@pytest.mark.parametrize("q1", ["pos", "pos [deg]", "pos*1 [rad]"])
def test_map_units_that_agree_convert_from_the_header(degree_csv, q1):
    rec = physid.load_recording(degree_csv, {"q1": q1, "tau1": "tq [N m]"})
    np.testing.assert_allclose(rec["q1"], np.deg2rad([0.0, 10.0, 20.0, 30.0]), rtol=1e-15)
    np.testing.assert_array_equal(rec["tau1"], np.ones(4))


# ---------------------------------------------------------------- a model file's [recording] table
_AXIS = Path()  # the example's prismatic axis; its [recording] maps q1 = "qm", tau1 = "gtau*vir"


@pytest.fixture(scope="module", autouse=True)
def _axis_model_file(tmp_path_factory, axis_example):
    """Write examples/linear_axis_drive.py's model file (AXIS_TOML) where the tests read it."""
    global _AXIS
    _AXIS = tmp_path_factory.mktemp("axis") / "axis.toml"
    _AXIS.write_text(axis_example.AXIS_TOML, encoding="utf-8")


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


# ------------------------------------------------- error messages that name the column and the fix
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


# ------------------------------------------------------------------ simulate's --reference file
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
