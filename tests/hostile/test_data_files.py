"""Hostile data files (HDF5, MATLAB v5 and v7.3): a data file never makes physid read another
file, its declared sizes are checked before anything is read, and what is not read as a channel
is named with the reason — never followed, never a MemoryError, never dropped silently."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.io
import scipy.sparse

from ._cases import case_ids, check_case

h5py = pytest.importorskip("h5py")

_SECRET = np.array([3.25, -7.5, 11.0, 42.0])  # values of "another local file"
_N = 300  # samples of the files that load
_NOT_FOLLOWED = r"never follows"

CASES = [
    # (case_id, argv, expected_exit, message_regex)
    ("h5-external-storage", ["filter", "{ext_h5}", "--out", "{tmp}/o.csv"], 2,
     r"dataset 'x' keeps its values in the external file '.*secret\.bin'.*" + _NOT_FOLLOWED),
    ("h5-external-link", ["filter", "{elink_h5}", "--out", "{tmp}/o.csv"], 2,
     r"'x' is an external link to '/x' in the file '.*other\.h5'.*" + _NOT_FOLLOWED),
    ("h5-external-link-in-group", ["filter", "{elinkgrp_h5}", "--out", "{tmp}/o.csv"], 2,
     r"'grp\.x' is an external link .*other\.h5"),
    ("h5-soft-link-through-external", ["filter", "{softext_h5}", "--out", "{tmp}/o.csv"], 2,
     r"'x' is an external link .*other\.h5.*" + _NOT_FOLLOWED),
    ("h5-virtual-dataset", ["filter", "{vds_h5}", "--out", "{tmp}/o.csv"], 2,
     r"dataset 'x' is a virtual dataset \(its values are read from \['.*other\.h5'\]\)"),
    ("mat73-external-link", ["filter", "{elink73_mat}", "--out", "{tmp}/o.csv"], 2,
     r"'x' is an external link .*other\.h5"),
    ("h5-dangling-link-reported", ["filter", "{dangling_h5}", "--kind", "lowpass",
                                   "--out", "{tmp}/o.csv"], 0,
     r"physid: warning: .*'y': a soft link to '/nothere', which is not in the file "
     r"\(a dangling link\)"),
    ("h5-dangling-link-mapped", ["filter", "{dangling_h5}", "--map", "x=y",
                                 "--out", "{tmp}/o.csv"], 2,
     r"--map x=y holds a soft link to '/nothere'.*dangling"),
    ("h5-soft-link-loop", ["filter", "{loop_h5}", "--kind", "lowpass", "--out", "{tmp}/o.csv"],
     0, r"'a': a chain of more than 16 soft links \(a loop\)"),
    ("h5-huge-declared-shape", ["filter", "{huge_h5}", "--out", "{tmp}/o.csv"], 2,
     r"declare [\d.]+ [TPE]B of values to read \(the largest, 'x': shape \(100000000000,\), "
     r"float64\).*copy a slice"),
    ("h5-compound-channel", ["filter", "{compound_h5}", "--out", "{tmp}/o.csv"], 2,
     r"variable 'x' holds compound records \(fields \['a', 'b'\]\)"),
    ("h5-reference-channel", ["filter", "{refs_h5}", "--map", "x=r", "--out", "{tmp}/o.csv"], 2,
     r"--map x=r holds object references"),
    ("h5-long-double-channel", ["filter", "{f128_h5}", "--out", "{tmp}/o.csv"], 2,
     r"variable 'x' holds values of HDF5 type float128"),
    ("h5-huge-int-channel", ["filter", "{bigint_h5}", "--out", "{tmp}/o.csv"], 2,
     r"variable 'x' holds integers up to 9007199254740993 .*beyond 2\*\*53"),
    ("npz-huge-int-channel", ["filter", "{bigint_npz}", "--out", "{tmp}/o.csv"], 2,
     r"variable 'x' holds integers up to 9007199254740993"),
    ("h5-null-dataspace", ["filter", "{null_h5}", "--kind", "lowpass", "--out", "{tmp}/o.csv"],
     0, r"'e': an empty \(null\) HDF5 dataspace"),
    ("mat-cell-sparse-char-struct-named",
     ["filter", "{kinds_mat}", "--kind", "lowpass", "--out", "{tmp}/o.csv"], 0,
     r"physid: warning: .*4 variable\(s\) not read as channels.*'c': a MATLAB cell array.*"
     r"'ch': text.*'s': a MATLAB sparse matrix of shape \(3, 3\).*'sa': a MATLAB struct array"),
    ("mat-sparse-mapped", ["filter", "{kinds_mat}", "--map", "x=s", "--out", "{tmp}/o.csv"], 2,
     r"--map x=s holds a MATLAB sparse matrix .*full\(\)"),
    ("mat-cell-mapped", ["filter", "{kinds_mat}", "--map", "x=c", "--out", "{tmp}/o.csv"], 2,
     r"--map x=c holds a MATLAB cell array"),
    ("mat73-cell-and-sparse-named",
     ["filter", "{kinds73_mat}", "--kind", "lowpass", "--out", "{tmp}/o.csv"], 0,
     r"'c': a MATLAB cell array \(HDF5 references\).*'s': a MATLAB sparse"),
]  # fmt: skip


def _h5(path, build, **kwargs):
    with h5py.File(path, "w", **kwargs) as f:
        f["t"] = 1e-3 * np.arange(_N)
        build(f)
    if path.suffix == ".mat":
        _matlab_header(path)
    return path


def _matlab_header(path):
    """The 128-byte header by which scipy (and physid) tell MATLAB v7.3 (HDF5) files."""
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, test".ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM")


def _files(env):
    tmp = env.tmp
    secret = tmp / "secret.bin"
    secret.write_bytes(_SECRET.tobytes())
    other = tmp / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = _SECRET
    n = _N
    made = {
        "ext_h5": _h5(tmp / "ext.h5", lambda f: f.create_dataset(
            "x", shape=(4,), dtype="f8", external=[(str(secret), 0, 32)])),
        "elink_h5": _h5(tmp / "elink.h5", lambda f: f.__setitem__(
            "x", h5py.ExternalLink(str(other), "/x"))),
        "elinkgrp_h5": _h5(tmp / "elinkgrp.h5", lambda f: f.create_group("grp").__setitem__(
            "x", h5py.ExternalLink(str(other), "/x"))),
        "softext_h5": _h5(tmp / "softext.h5", lambda f: (
            f.create_group("#refs#").__setitem__("ext", h5py.ExternalLink(str(other), "/")),
            f.__setitem__("x", h5py.SoftLink("/#refs#/ext/x")))),
        "dangling_h5": _h5(tmp / "dangling.h5", lambda f: (
            f.__setitem__("x", np.sin(np.arange(n))), f.__setitem__("y", h5py.SoftLink("/nothere")))),
        "loop_h5": _h5(tmp / "loop.h5", lambda f: (
            f.__setitem__("x", np.sin(np.arange(n))), f.__setitem__("a", h5py.SoftLink("/b")),
            f.__setitem__("b", h5py.SoftLink("/a")))),
        "huge_h5": _h5(tmp / "huge.h5", lambda f: f.create_dataset(
            "x", shape=(10**11,), dtype="f8", chunks=(10**6,))),
        "compound_h5": _h5(tmp / "compound.h5", lambda f: f.__setitem__(
            "x", np.zeros(n, dtype=[("a", "f8"), ("b", "i4")]))),
        "refs_h5": _h5(tmp / "refs.h5", lambda f: (
            f.__setitem__("y", np.ones(n)), f.create_dataset("r", (n,), dtype=h5py.ref_dtype))),
        "f128_h5": _h5(tmp / "f128.h5", lambda f: f.__setitem__(
            "x", np.zeros(n, dtype=np.longdouble))),
        "bigint_h5": _h5(tmp / "bigint.h5", lambda f: f.__setitem__(
            "x", np.arange(n, dtype=np.int64) + 2**53 - n + 2)),
        "null_h5": _h5(tmp / "null.h5", lambda f: (
            f.__setitem__("x", np.ones(n)), f.create_dataset("e", data=h5py.Empty("f8")))),
        "elink73_mat": _h5(tmp / "elink73.mat", lambda f: f.__setitem__(
            "x", h5py.ExternalLink(str(other), "/x")), userblock_size=512),
    }  # fmt: skip
    np.savez(tmp / "bigint.npz", t=1e-3 * np.arange(n), x=np.arange(n) + 2**53 - n + 2)
    made["bigint_npz"] = tmp / "bigint.npz"
    t = 1e-3 * np.arange(n)
    scipy.io.savemat(
        tmp / "kinds.mat",
        {"t": t, "x": np.sin(t), "c": np.array([[1, "a"]], dtype=object),
         "s": scipy.sparse.csc_matrix(np.eye(3)), "ch": "a note",
         "sa": np.array([[(t,)], [(t,)]], dtype=[("f", "O")])},
    )  # fmt: skip
    made["kinds_mat"] = tmp / "kinds.mat"
    made["kinds73_mat"] = _mat73(tmp / "kinds73.mat")
    for name, path in made.items():
        env.add_file(name, path)
    env.add_file("secret", secret)
    env.add_file("other", other)
    _vds(env)


def _mat73(path):
    """A MATLAB v7.3 file as MATLAB writes it: a cell array (references into #refs#) and a
    sparse matrix (a group of data, ir, jc)."""
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, value in (("t", 1e-3 * np.arange(_N)), ("x", np.sin(np.arange(_N)))):
            f.create_dataset(name, data=value[None, :]).attrs["MATLAB_class"] = np.bytes_("double")
        refs = f.create_group("#refs#")
        refs["a"] = np.ones((1, 3))
        c = f.create_dataset("c", (1, 1), dtype=h5py.ref_dtype)
        c[0, 0] = refs["a"].ref
        c.attrs["MATLAB_class"] = np.bytes_("cell")
        s = f.create_group("s")
        s.attrs["MATLAB_class"] = np.bytes_("double")
        s.attrs["MATLAB_sparse"] = np.uint64(3)
        s["data"], s["ir"], s["jc"] = np.ones(3), np.arange(3), np.arange(4)
        s.attrs["MATLAB_class"] = np.bytes_("sparse")
    _matlab_header(path)
    return path


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=case_ids(CASES)
)
def test_data_file(case_id, argv, expected_exit, message_regex, hostile):
    _files(hostile)
    check_case(hostile, argv, expected_exit, message_regex)
    out = hostile.tmp / "o.csv"
    if out.exists():  # never a value of another file in the output
        text = out.read_text()
        assert not any(repr(float(v)) in text for v in _SECRET[1:]), text[:500]


@pytest.mark.parametrize("name", ["ext_h5", "elink_h5", "softext_h5", "vds_h5", "elink73_mat"])
def test_linked_data_never_reaches_the_library_caller(name, hostile):
    """The library refuses too (not only the command line), naming the dataset."""
    from physid.errors import DataFileError
    from physid.signals import load_recording

    _files(hostile)
    with pytest.raises(DataFileError, match=r"'x'.*never follows"):
        load_recording(hostile.path(name))


def test_skipped_variables_are_listed_in_the_metadata(hostile):
    from physid.signals import load_recording
    from physid.signals.io import DataFileWarning

    _files(hostile)
    with pytest.warns(DataFileWarning, match=r"'y': a soft link to '/nothere'"):
        rec = load_recording(hostile.path("dangling_h5"))
    assert rec.names == ("x",)
    assert rec.metadata["skipped_variables"] == {
        "y": "a soft link to '/nothere', which is not in the file (a dangling link)"
    }


def _vds(env):
    other = env.files["other"]
    path = env.tmp / "vds.h5"
    with h5py.File(path, "w") as f:
        f["t"] = 1e-3 * np.arange(_N)
        layout = h5py.VirtualLayout(shape=(_SECRET.size,), dtype="f8")
        layout[:] = h5py.VirtualSource(str(other), "x", shape=(_SECRET.size,))
        f.create_virtual_dataset("x", layout)
    env.add_file("vds_h5", path)


def _link_bomb(path, levels=4, parts=40):
    """Soft links whose targets run through other soft links: ``s_k`` names ``s_(k-1)``
    ``parts`` times, so resolving ``s_levels`` naively takes ``parts**levels`` steps."""
    with h5py.File(path, "w") as f:
        f["t"] = 1e-3 * np.arange(_N)
        f["s0"] = h5py.SoftLink("/")
        for k in range(1, levels + 1):
            f[f"s{k}"] = h5py.SoftLink("/" + "/".join([f"s{k - 1}"] * parts))
    return path


def test_soft_links_that_multiply_the_work_are_refused(tmp_path):
    """40**4 steps are refused after the file's budget of link steps, naming file and link."""
    from physid.errors import DataFileError
    from physid.signals import load_recording
    from physid.signals.io.hdf5_reader import MAX_HDF5_LINK_STEPS

    path = _link_bomb(tmp_path / "bomb.h5")
    with pytest.raises(
        DataFileError,
        match=rf"bomb\.h5: resolving the soft link '[\w.]+' took .* past {MAX_HDF5_LINK_STEPS} steps",
    ):
        load_recording(path)


def test_a_few_chained_soft_links_still_load(tmp_path):
    """Below the budget, links through links resolve as before (3**2 steps)."""
    from physid.signals import load_recording
    from physid.signals.io import DataFileWarning

    path = _link_bomb(tmp_path / "small.h5", levels=2, parts=3)
    with h5py.File(path, "a") as f:
        f["x"] = np.sin(np.arange(_N))
        f["y"] = h5py.SoftLink("/s2/s2/x")
    with pytest.warns(DataFileWarning):
        rec = load_recording(path)
    assert "y" in rec.names and "x" in rec.names
    np.testing.assert_array_equal(rec["y"], np.sin(np.arange(_N)))


def test_text_references_that_multiply_the_characters_are_refused(tmp_path):
    """20 references to one text of 100 000 characters: 2e6 characters, over the file's budget."""
    from physid.errors import DataFileError
    from physid.signals import load_recording
    from physid.signals.io.hdf5_reader import MAX_HDF5_TEXT

    path = tmp_path / "textbomb.h5"
    with h5py.File(path, "w") as f:
        f["t"] = 1e-3 * np.arange(_N)
        f["x"] = np.ones(_N)
        f["#refs#/long"] = np.full(100_000, ord("a"), dtype=np.uint16)
        names = f.create_dataset("names", (20,), dtype=h5py.ref_dtype)
        names[:] = [f["#refs#/long"].ref] * 20
    with pytest.raises(
        DataFileError,
        match=rf"textbomb\.h5: its text \('names'.*more than {MAX_HDF5_TEXT} elements and "
        r"characters \(at least 1000020\)",
    ):
        load_recording(path)
