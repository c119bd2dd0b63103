"""Hostile recordings: each case ends in exit 2 with a message naming the
channel or file and the fix — never a traceback, a silent wrong unit, or an API-only keyword."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.io

from ._cases import case_ids, check_case

CASES = [
    # (case_id, argv, expected_exit, message_regex)
    ("npz-garbage", ["filter", "{garbage_npz}", "--out", "{tmp}/o.csv"], 2,
     r"not an NPZ file: it is not a zip archive"),
    ("npz-truncated", ["filter", "{truncated_npz}", "--out", "{tmp}/o.csv"], 2,
     r"not a readable NPZ file .*damaged, truncated"),
    ("npz-pickled-objects", ["filter", "{object_npz}", "--out", "{tmp}/o.csv"], 2,
     r"'x' holds a Python object array \(physid never unpickles data\)"),
    ("npz-complex-channel", ["filter", "{complex_npz}", "--out", "{tmp}/o.csv"], 2,
     r"variable 'x' holds complex numbers \(dtype complex128\)"),
    ("npz-string-channel", ["filter", "{string_npz}", "--out", "{tmp}/o.csv"], 2,
     r"variable 'x' holds text"),
    ("mat-complex-channel", ["filter", "{complex_mat}", "--out", "{tmp}/o.csv"], 2,
     r"variable 'x' holds complex numbers"),
    ("npz-2d-time", ["filter", "{t2d_npz}", "--out", "{tmp}/o.csv"], 2,
     r"the time 't' has shape \(5, 2\); it must be a vector"),
    ("csv-1e308", ["estimate", "{big_csv}"], 2,
     r"channel 'u' holds 1e\+308 at data row 3 \(line 4\).*fill value"),
    ("csv-non-uniform-says-flag", ["estimate", "{jitter_csv}"], 2,
     r"Pass --resample to interpolate(?!.*resample=True)"),
    ("csv-volts-on-torque", ["identify", "{volt_csv}", "--model", "{model_toml}"], 2,
     r"channel 'tau1' is in V \(a voltage\).*--map 'tau1=35\.15\*tau1'"),
    ("csv-force-for-normalised-msd", ["estimate", "{force_csv}", "--model", "msd"], 2,
     r"channel 'u' is in N \(a force\).*--model msd-force"),
    ("csv-unknown-unit", ["estimate", "{counts_csv}"], 2,
     r"channel 'x' has unit 'counts', which physid cannot convert"),
    ("map-missing-name", ["estimate", "{msd_csv}", "--map", "x=pos"], 2,
     r"--map x=pos: the file has no variable 'pos'; its channels are \['u', 'x', 'x_true'\]"),
    ("map-forbidden-construct", ["estimate", "{msd_csv}", "--map", "x=__import__('os')"], 2,
     r"not allowed in the expression"),
    ("map-struct-path-missing", ["estimate", "{struct_mat}", "--map", "x=data.poss,u=data.F"], 2,
     r"no variable 'data\.poss'; its channels are \[.*'data\.pos'"),
    ("map-malformed", ["estimate", "{msd_csv}", "--map", "x"], 2, r"NAME=SOURCE pairs"),
    ("no-time-column", ["estimate", "{notime_csv}"], 2,
     r"no time column or variable.*--map 't=NAME'"),
    ("decimal-comma-without-flag", ["estimate", "{comma_csv}"], 2, r"pass --decimal ,"),
    ("decimal-comma-and-comma-delimiter",
     ["estimate", "{comma_csv}", "--decimal", ",", "--delimiter", ","], 2,
     r"decimal=',' and delimiter=','|--decimal , and"),
]  # fmt: skip


def _files(env):
    tmp = env.tmp
    t = np.arange(5.0)
    good = tmp / "good.npz"
    np.savez(good, t=1e-3 * np.arange(100), x=np.ones(100))
    (tmp / "garbage.npz").write_bytes(bytes(range(256)) * 4)
    (tmp / "truncated.npz").write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    np.savez(tmp / "object.npz", t=t, x=np.array([1, "a", None, 2, 3], dtype=object))
    np.savez(tmp / "complex.npz", t=t, x=np.ones(5) + 1j, y=t)
    np.savez(tmp / "string.npz", t=t, x=np.array(["a"] * 5), y=t)
    scipy.io.savemat(tmp / "complex.mat", {"t": t, "x": np.ones(5) + 1j, "y": t})
    np.savez(tmp / "t2d.npz", t=np.zeros((5, 2)), u=np.ones(5))
    rows = "".join(f"{0.001 * i},{1e308 if i == 2 else 1.0},{np.sin(i)}\n" for i in range(50))
    (tmp / "big.csv").write_text("t,u,x\n" + rows)
    (tmp / "jitter.csv").write_text("t,u,x\n0,0,0\n0.1,1,1\n0.35,2,3\n0.4,3,4\n")
    (tmp / "volt.csv").write_text(
        "t,q1 [rad],tau1 [V]\n" + "".join(f"{0.001 * i},{i},{i}\n" for i in range(300))
    )
    (tmp / "force.csv").write_text(
        "t,u [N],x [m]\n" + "".join(f"{0.001 * i},{np.sin(i)},{np.cos(i)}\n" for i in range(300))
    )
    (tmp / "counts.csv").write_text(
        "t,u,x [counts]\n" + "".join(f"{0.001 * i},{np.sin(i)},{i}\n" for i in range(300))
    )
    (tmp / "notime.csv").write_text("stamp,u,x\n0,1,2\n1,2,3\n")
    (tmp / "comma.csv").write_text("t;u;x\n0,0;1,5;2\n0,1;1,6;3\n0,2;1,7;4\n")
    tt = 1e-3 * np.arange(300)
    scipy.io.savemat(tmp / "struct.mat", {"data": {"time": tt, "pos": tt, "F": tt}})
    for name in (
        "garbage_npz truncated_npz object_npz complex_npz string_npz complex_mat t2d_npz "
        "big_csv jitter_csv volt_csv force_csv counts_csv notime_csv comma_csv struct_mat"
    ).split():
        stem, ext = name.rsplit("_", 1)
        env.add_file(name, tmp / f"{stem}.{ext}")


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=case_ids(CASES)
)
def test_recording(case_id, argv, expected_exit, message_regex, hostile):
    _files(hostile)
    check_case(hostile, argv, expected_exit, message_regex)


def test_unreadable_file_names_the_fix(hostile, monkeypatch):
    """chmod 000 (simulated: the suite may run as root, whom permissions do not stop)."""
    import physid.signals.io

    path = hostile.add_file("locked", hostile.tmp / "locked.csv")
    path.write_text("t,x\n0,1\n1,2\n")

    def denied(*args, **kwargs):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(physid.signals.io, "_open", denied)
    check_case(
        hostile,
        ["filter", "{locked}", "--out", "{tmp}/o.csv"],
        2,
        r"permission denied: the file cannot be read by this user; make it readable "
        r"\(chmod u\+r .*locked\.csv\)",
    )


def test_hdf5_time_unit_attribute_is_honoured(hostile):
    """An HDF5 time in ms used to be read as seconds (dt = 1 s): now converted, one rule."""
    h5py = pytest.importorskip("h5py")
    from physid.signals import load_recording

    path = hostile.add_file("ms_h5", hostile.tmp / "ms.h5")
    with h5py.File(path, "w") as f:
        f.create_dataset("t", data=np.arange(300.0)).attrs["unit"] = "ms"
        f.create_dataset("x", data=np.sin(np.arange(300.0))).attrs["unit"] = "mm"
    res = check_case(
        hostile,
        ["filter", "{ms_h5}", "--kind", "lowpass", "--out", "{tmp}/o.csv"],
        0,
        r"o\.csv",
    )
    assert res.code == 0
    out = load_recording(hostile.tmp / "o.csv")
    assert out.dt == pytest.approx(1e-3) and out.unit("x") == "m"
