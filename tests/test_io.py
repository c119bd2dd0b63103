"""Recording file I/O: round trips and every error path of `physid.signals.load_recording`."""

from __future__ import annotations

import sys

import h5py
import numpy as np
import pytest
import scipy.io
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import physid
from physid.errors import DataFileError, InputError, MissingDependencyError, PhysidError
from physid.signals import Recording, load_recording, save_recording


@pytest.fixture
def rec():
    rng = np.random.default_rng(3)
    t = 1e-3 * np.arange(50)
    data = np.column_stack([np.sin(t), rng.standard_normal(50), 1e-9 * rng.standard_normal(50)])
    return Recording(
        t, data, ("q1", "q2", "tau1"), ("rad", "rad", "N·m"), {"seed": 3, "note": "ünïcode"}
    )


def _write(tmp_path, text, name="r.csv"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _assert_same(a: Recording, b: Recording):
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.data, b.data)
    assert a.names == b.names
    assert a.units == b.units


# ------------------------------------------------------------------------------- round trips
@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_round_trip_is_bit_exact(tmp_path, rec, suffix):
    path = save_recording(rec, tmp_path / f"r{suffix}")
    back = load_recording(path)
    _assert_same(rec, back)
    assert back.metadata["seed"] == 3 and back.metadata["note"] == "ünïcode"
    assert back.metadata["format"] == suffix[1:] and back.metadata["source"] == str(path)


def test_recording_save_method_and_top_level_loader(tmp_path, rec):
    rec.save(tmp_path / "r.csv")
    _assert_same(rec, physid.load_recording(tmp_path / "r.csv"))


def test_csv_header_has_units(tmp_path, rec):
    path = save_recording(rec, tmp_path / "r.csv")
    lines = path.read_text(encoding="utf-8").splitlines()
    assert lines[1] == "t [s],q1 [rad],q2 [rad],tau1 [N·m]"


def test_mat_v5_round_trip_per_variable(tmp_path):
    t = 0.01 * np.arange(20)
    q = np.column_stack([np.cos(t), np.sin(t)])
    scipy.io.savemat(
        tmp_path / "r.mat", {"t": t[:, None], "q": q, "u": t**2, "fs": 100.0, "note": "bench"}
    )
    back = load_recording(tmp_path / "r.mat")
    assert back.names == ("q1", "q2", "u")
    assert back.metadata["ignored_variables"] == ["fs", "note"]
    np.testing.assert_array_equal(back.t, t)
    np.testing.assert_array_equal(back.data, np.column_stack([q, t**2]))
    assert back.dt == pytest.approx(0.01)


def test_mat_v5_data_names_units(tmp_path):
    t = 0.5 * np.arange(4)
    data = np.arange(8.0).reshape(4, 2)
    names = np.array(["x", "u"], dtype=object)
    units = np.array(["m", "m/s^2"], dtype=object)
    scipy.io.savemat(tmp_path / "r.mat", {"t": t, "data": data, "names": names, "units": units})
    back = load_recording(tmp_path / "r.mat")
    assert back.names == ("x", "u") and back.units == ("m", "m/s^2")
    np.testing.assert_array_equal(back.data, data)


def test_mat_v73_is_read_through_h5py(tmp_path):
    # A MATLAB v7.3 file is HDF5 with a 512-byte user block whose header says version 0x0200;
    # MATLAB stores arrays column-major, so an (n, 2) matrix appears as (2, n) to h5py.
    path = tmp_path / "r73.mat"
    t = 0.1 * np.arange(10)
    q = np.column_stack([t, 2 * t])
    with h5py.File(path, "w", userblock_size=512) as f:
        f["t"] = t[None, :]  # MATLAB column vector (n, 1) -> (1, n)
        f["q"] = q.T
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: test HDF5 schema 1.00 ."
    with open(path, "r+b") as fh:
        fh.write(header.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM")
    with pytest.raises(NotImplementedError):
        scipy.io.loadmat(path)  # proves the file is what scipy calls v7.3
    back = load_recording(path)
    assert back.names == ("q1", "q2")
    np.testing.assert_array_equal(back.data, q)
    np.testing.assert_array_equal(back.t, t)


def test_hdf5_with_unit_attributes(tmp_path):
    path = tmp_path / "r.h5"
    t = 0.2 * np.arange(6)
    with h5py.File(path, "w") as f:
        f["t"] = t
        f["x"] = np.sqrt(t)
        f["x"].attrs["unit"] = "m"
        f["u"] = -t
    back = load_recording(path)
    assert set(back.names) == {"x", "u"}
    assert back.unit("x") == "m"
    np.testing.assert_array_equal(back["x"], np.sqrt(t))


def test_missing_h5py_gives_clear_error(tmp_path, monkeypatch):
    path = tmp_path / "r.h5"
    with h5py.File(path, "w") as f:
        f["t"] = np.arange(3.0)
    monkeypatch.setitem(sys.modules, "h5py", None)  # import h5py now raises ImportError
    with pytest.raises(
        MissingDependencyError,
        match=r"r\.h5: reading HDF5 files needs h5py, which is not installed; run "
        r'pip install "physid\[io\]"',
    ) as info:
        load_recording(path)
    assert isinstance(info.value, ImportError) and not isinstance(info.value, DataFileError)
    mat = tmp_path / "r.mat"  # the v7.3 header scipy refuses with NotImplementedError
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: test HDF5 schema 1.00 ."
    mat.write_bytes(header.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM" + b"\x00" * 384)
    with pytest.raises(MissingDependencyError, match=r"reading MATLAB v7\.3 files needs h5py"):
        load_recording(mat)


def test_csv_variants_semicolon_comments_blank_lines_quotes_and_ms(tmp_path):
    text = '# a comment\n\n"t [ms]";"x [m]"\n0;1\n\n1;"2"\n2;3\n# trailing comment\n'
    back = load_recording(_write(tmp_path, text))
    np.testing.assert_allclose(back.t, [0.0, 1e-3, 2e-3])
    np.testing.assert_array_equal(back["x"], [1.0, 2.0, 3.0])
    assert back.unit("x") == "m"


def test_small_time_rounding_is_snapped_onto_the_grid(tmp_path):
    # times written with 4 decimals: intervals deviate ~1e-4 relative, within the 1e-3 default
    t = np.round(np.arange(30) / 3.0, 4)
    text = "t,x\n" + "\n".join(f"{ti},{i}" for i, ti in enumerate(t))
    back = load_recording(_write(tmp_path, text))
    assert back.dt == pytest.approx(t[-1] / 29, rel=1e-12)
    assert 0 < back.metadata["max_sampling_deviation"] < 1e-3


def test_resample_and_keep_non_uniform(tmp_path):
    text = "t,x\n0,0\n0.1,1\n0.3,3\n0.4,4\n"
    path = _write(tmp_path, text)
    back = load_recording(path, resample=True)
    np.testing.assert_allclose(back.t, [0.0, 0.4 / 3, 0.8 / 3, 0.4])
    np.testing.assert_allclose(back["x"], 10 * back.t)  # linear data: interpolation is exact
    kept = load_recording(path, uniform_rtol=None)
    np.testing.assert_array_equal(kept.t, [0.0, 0.1, 0.3, 0.4])


# ------------------------------------------------------------------------------- error paths
@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("", r"r\.csv: the file is empty \(no header row\)"),
        ("# only a comment\n\n", r"the file is empty"),
        ("t,x\n", r"the header is there but there are no data rows"),
        ("t,x\n0,1\n", r"holds only 1 sample"),
        ("a,x\n0,1\n1,2\n", r"no time column or variable: .* the file has \['a', 'x'\]"),
        ("time,Time,x\n0,0,1\n1,1,2\n", r"several variables could be the time: \['time', 'Time'\]"),
        ("t\n0\n1\n", r"has a time column 't' but no channels"),
        ("t,x\n0,1\n1,abc\n2,3\n", r"non-numeric cell 'abc' in column 'x' at line 3"),
        ("t,x\n0,1\n1,\n", r"empty cell in column 'x' at line 3"),
        ("t,x,y\n0,1,2\n1,2\n", r"line 3 has 2 cell\(s\) but the header has 3 column\(s\)"),
        ("t,x\n0,1\n1,nan\n2,3\n", r"channel 'x' holds nan at data row 2 \(line 3\)"),
        ("t,x,y\n0,1,2\n1,2,3\n2,3,-inf\n", r"channel 'y' holds -inf at data row 3 \(line 4\)"),
        ("t,x\n0,1\nnan,2\n", r"time column 't' holds nan at data row 2"),
        ("t,x\n0,1\n0.2,2\n0.1,3\n", r"not strictly increasing: t = 0\.1 at data row 3 \(line 4\)"),
        ("t,x\n0,1\n0,2\n", r"not strictly increasing"),
        ("t,x,x\n0,1,2\n1,2,3\n", r"duplicate channel name 'x' \(channels 1 and 2\)"),
        ("t,x,t\n0,1,2\n1,2,3\n", r"'t' appears twice"),
        ("t [m],x\n0,1\n1,2\n", r"time column has unit 'm' \(a length\), not a time.*seconds"),
        ("t [fortnight],x\n0,1\n1,2\n", r"time column has unit 'fortnight': unknown unit"),
        ("t, x \n0,1\n1,2\n2,3\n", None),  # spaces around names are stripped: loads
    ],
)
def test_csv_errors_name_file_row_and_column(tmp_path, text, pattern):
    path = _write(tmp_path, text)
    if pattern is None:
        assert load_recording(path).names == ("x",)
        return
    with pytest.raises(DataFileError, match=pattern):
        load_recording(path)


def test_non_uniform_sampling_reports_worst_deviation(tmp_path):
    text = "t,x\n0,0\n0.1,1\n0.2,2\n0.35,3\n0.4,4\n"
    with pytest.raises(
        DataFileError,
        match=r"not uniformly sampled: the interval from data row 3 \(line 4\) to data row 4 "
        r"\(line 5\) is 0\.15 s against a mean period of 0\.1 s \(worst relative deviation 0\.5, "
        r"tolerance 0\.001\)\. "
        r"Pass resample=True to interpolate onto a uniform grid",
    ) as info:
        load_recording(_write(tmp_path, text))
    assert "--resample" not in str(info.value)  # Python users get the keyword, the CLI its flag


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        ({"uniform_rtol": "abc"}, r"uniform_rtol must be None or a finite number >= 0, got 'abc'"),
        ({"uniform_rtol": float("nan")}, r"uniform_rtol must be .* got nan; pass e\.g\."),
        ({"uniform_rtol": float("inf")}, r"uniform_rtol must be .* got inf"),
        ({"uniform_rtol": -1e-3}, r"uniform_rtol must be .* got -0\.001"),
        ({"uniform_rtol": True}, r"uniform_rtol must be .* got True of type bool"),
        ({"resample": "no"}, r"resample must be True or False, got 'no' of type str"),
        ({"resample": 1}, r"resample must be True or False, got 1 of type int"),
    ],
)
def test_load_options_are_validated(tmp_path, kwargs, pattern):
    # non-uniform times: a NaN tolerance used to snap them onto a grid without moving the data
    path = _write(tmp_path, "t,x\n0,0\n0.1,1\n0.3,3\n0.4,4\n")
    with pytest.raises(InputError, match=pattern):
        load_recording(path, **kwargs)


def test_zero_tolerance_requires_exact_grid(tmp_path):
    exact = load_recording(_write(tmp_path, "t,x\n0,0\n0.5,1\n1,2\n"), uniform_rtol=0)
    np.testing.assert_array_equal(exact.t, [0.0, 0.5, 1.0])
    path = tmp_path / "jitter.csv"
    path.write_text("t,x\n0,0\n0.5,1\n1.001,2\n")
    with pytest.raises(DataFileError, match=r"tolerance 0\)"):
        load_recording(path, uniform_rtol=0)


def test_unknown_suffix_missing_file_and_bad_bytes(tmp_path):
    with pytest.raises(DataFileError, match=r"cannot read files with suffix '\.xlsx'; supported"):
        load_recording(tmp_path / "r.xlsx")
    with pytest.raises(DataFileError, match=r"nope\.csv: no such file"):
        load_recording(tmp_path / "nope.csv")
    bad = tmp_path / "latin1.csv"
    bad.write_bytes(b"t,x\n0,\xe9\n")
    with pytest.raises(DataFileError, match="is not UTF-8 text"):
        load_recording(bad)


def test_save_errors(tmp_path, rec):
    with pytest.raises(DataFileError, match=r"cannot save to suffix '\.mat'"):
        save_recording(rec, tmp_path / "r.mat")
    save_recording(rec, tmp_path / "r.npz")
    with pytest.raises(DataFileError, match="exists; pass overwrite=True"):
        save_recording(rec, tmp_path / "r.npz", overwrite=False)
    with pytest.raises(DataFileError, match="does not exist; create it first"):
        save_recording(rec, tmp_path / "missing" / "r.csv")
    with pytest.raises(DataFileError, match="expects a Recording"):
        save_recording({"t": [0, 1]}, tmp_path / "r.csv")


def test_npz_and_mat_structure_errors(tmp_path):
    np.savez(tmp_path / "a.npz", x=np.arange(3.0))
    with pytest.raises(DataFileError, match=r"no time column or variable: .*the file has \['x'\]"):
        load_recording(tmp_path / "a.npz")
    np.savez(tmp_path / "b.npz", t=np.arange(3.0), x=np.arange(4.0))
    with pytest.raises(DataFileError, match=r"variable 'x' has shape \(4,\); channels must have"):
        load_recording(tmp_path / "b.npz")
    np.savez(tmp_path / "c.npz", t=np.arange(3.0), data=np.zeros((3, 2)), names=np.array(["a"]))
    with pytest.raises(DataFileError, match=r"'data' has shape \(3, 2\) but 'names' lists 1"):
        load_recording(tmp_path / "c.npz")
    np.savez(tmp_path / "d.npz", t=np.arange(3.0), x=np.array([1.0, np.inf, 2.0]))
    with pytest.raises(DataFileError, match=r"channel 'x' holds inf at sample 1"):
        load_recording(tmp_path / "d.npz")
    (tmp_path / "e.mat").write_bytes(b"not a mat file at all")
    with pytest.raises(DataFileError, match="e.mat"):
        load_recording(tmp_path / "e.mat")


# ------------------------------------------------------------------------------- fuzzing
_CSV_ALPHABET = st.sampled_from(list("t,;x01.-e+n a\n\r\t#[]\"'") + ["nan", "inf", "1e999", "é"])


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(text=st.one_of(st.text(max_size=80), st.lists(_CSV_ALPHABET, max_size=60).map("".join)))
def test_csv_loader_loads_or_raises_physid_error(tmp_path, text):
    path = tmp_path / "fuzz.csv"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    try:
        rec = load_recording(path)
    except PhysidError:
        return
    assert isinstance(rec, Recording)
    assert np.all(np.isfinite(rec.data)) and np.all(np.diff(rec.t) > 0)


# ------------------------------------------------------------------------------- hostile files
# (each of these is a file a careless loader gets wrong)
def test_npz_is_never_unpickled_and_object_channels_are_named(tmp_path):
    t = np.arange(5.0)
    np.savez(tmp_path / "o.npz", t=t, x=np.array([1, "a", None, 2, 3], dtype=object))
    with pytest.raises(DataFileError, match=r"'x' holds a Python object array \(physid never"):
        load_recording(tmp_path / "o.npz")


@pytest.mark.parametrize("kind", ["garbage", "truncated", "npy", "empty"])
def test_damaged_npz_files_give_a_clear_error_without_allow_pickle(tmp_path, kind):
    path = tmp_path / f"{kind}.npz"
    good = tmp_path / "good.npz"
    np.savez(good, t=np.arange(50.0), x=np.arange(50.0))
    payload = {
        "garbage": bytes(range(256)) * 3,
        "truncated": good.read_bytes()[: good.stat().st_size // 2],
        "npy": b"\x93NUMPY\x01\x00" + b"\x00" * 40,
        "empty": b"",
    }[kind]
    path.write_bytes(payload)
    with pytest.raises(DataFileError, match=r"(not an NPZ|not a readable NPZ|single \.npy)") as e:
        load_recording(path)
    assert "allow_pickle" not in str(e.value)


@pytest.mark.parametrize(
    ("value", "pattern"),
    [
        (np.ones(5) + 1j, r"variable 'x' holds complex numbers \(dtype complex128\)"),
        (np.array(["a"] * 5), r"variable 'x' holds text \(shape \(5,\)\)"),
    ],
)
def test_complex_and_string_channels_are_refused_naming_channel_and_type(tmp_path, value, pattern):
    np.savez(tmp_path / "c.npz", t=np.arange(5.0), x=value, y=np.arange(5.0))
    with pytest.raises(DataFileError, match=pattern):
        load_recording(tmp_path / "c.npz")
    scipy.io.savemat(tmp_path / "c.mat", {"t": np.arange(5.0), "x": value, "y": np.arange(5.0)})
    with pytest.raises(DataFileError, match=r"variable 'x' holds (complex numbers|text)"):
        load_recording(tmp_path / "c.mat")


def test_matlab_cell_channel_is_refused_and_a_text_note_ignored(tmp_path):
    cells = np.empty((5, 1), dtype=object)
    cells[:, 0] = ["a", "b", "c", "d", "e"]
    scipy.io.savemat(tmp_path / "c.mat", {"t": np.arange(5.0), "x": cells, "y": np.arange(5.0)})
    with pytest.raises(DataFileError, match=r"variable 'x' holds (text|a cell)"):
        load_recording(tmp_path / "c.mat")
    scipy.io.savemat(tmp_path / "n.mat", {"t": np.arange(5.0), "y": np.arange(5.0), "note": "hi"})
    rec = load_recording(tmp_path / "n.mat")
    assert rec.names == ("y",) and rec.metadata["ignored_variables"] == ["note"]


def test_huge_values_are_named_not_blamed_as_nan(tmp_path):
    path = tmp_path / "big.csv"
    path.write_text("t,u,x\n0,1,0\n0.1,1e308,1\n0.2,1,2\n")
    with pytest.raises(
        DataFileError,
        match=r"channel 'u' holds 1e\+308 at data row 2 \(line 3\) .*beyond ±1e\+150.*fill value",
    ) as e:
        load_recording(path)
    assert "nan" not in str(e.value)


def test_two_dimensional_time_blames_t(tmp_path):
    np.savez(tmp_path / "t2.npz", t=np.zeros((5, 2)), u=np.ones(5))
    with pytest.raises(
        DataFileError, match=r"the time 't' has shape \(5, 2\); it must be a vector"
    ):
        load_recording(tmp_path / "t2.npz")


def test_unreadable_file_says_how_to_fix_it(tmp_path, monkeypatch):
    path = tmp_path / "locked.csv"
    path.write_text("t,x\n0,1\n1,2\n")

    def denied(*args, **kwargs):  # what open() does on a chmod 000 file for a non-root user
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(physid.signals.io, "_open", denied)
    with pytest.raises(DataFileError, match=r"permission denied.*chmod u\+r .*locked\.csv"):
        load_recording(path)


_NAME = st.text(
    alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\r\x00"),
    min_size=1,
    max_size=12,
).filter(lambda s: s.strip() == s and s != "t" and not physid.signals.io._READ_CHANNEL.match(s))
_SI_UNITS = st.sampled_from(["", "m", "rad", "N", "N·m", "N*m", "m/s", "rad/s^2", "V", "kg", "Hz"])
_VALUE = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e150, max_value=1e150)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    names=st.lists(_NAME, min_size=1, max_size=4, unique_by=lambda s: s.lower()),
    units=st.lists(_SI_UNITS, min_size=4, max_size=4),
    values=st.lists(_VALUE, min_size=12, max_size=12),
    suffix=st.sampled_from([".csv", ".npz"]),
)
@example(names=["data", "names", "units", "metadata"], units=["m"] * 4, values=[1.5] * 12,
         suffix=".npz")  # fmt: skip
@example(names=["metadata", "data"], units=["N"] * 4, values=[-2.0] * 12, suffix=".csv")
def test_write_read_round_trips_names_units_and_values_bit_for_bit(
    tmp_path, names, units, values, suffix
):
    # names with commas, quotes, newlines, brackets ('pos [deg]' without unit) all come back
    names = [n for n in names if n.lower() not in ("t", "time")] or ["x"]
    k = len(names)
    n = len(values) // k
    data = np.array(values[: n * k]).reshape(n, k)
    rec = Recording(1e-3 * np.arange(n), data, names, units[:k])
    back = load_recording(save_recording(rec, tmp_path / f"r{suffix}"))
    assert back.names == rec.names and back.units == rec.units
    np.testing.assert_array_equal(back.t, rec.t)
    assert back.data.tobytes() == rec.data.tobytes()


def test_csv_names_with_separators_and_brackets_are_quoted(tmp_path):
    rec = Recording([0.0, 1.0], np.zeros((2, 3)), ["a,b", 'say "hi"', "pos [deg]"], ["m", "", ""])
    path = save_recording(rec, tmp_path / "q.csv")
    assert path.read_text().splitlines()[1] == 't [s],"a,b [m]","say ""hi""",pos [deg] []'
    assert load_recording(path).names == rec.names
    with pytest.raises(DataFileError, match=r"a carriage return in a name"):
        save_recording(Recording([0.0, 1.0], [0.0, 1.0], ["a\rb"]), tmp_path / "r.csv")
