"""Several files, one run (physid.signals.join, ``physid identify --join``): files without time
joined sample by sample (``--rate``), files with time stamps joined on them onto one grid, gaps
that split the run, and the errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

import physid
from _helpers import PLANAR2, planar2_pd_run
from physid.cli import main
from physid.errors import DataFileError, InputError
from physid.signals import Recording, join_recordings

KT = 0.5  # N·m/A: the currents are tau / KT
T0 = 1_700_000_000_000_000_000


@pytest.fixture(scope="module")
def sim():
    return planar2_pd_run(physid.load_model(PLANAR2), duration=4.0)


def _write(path, header, columns):
    rows = [",".join(repr(float(v)) if not isinstance(v, (int, np.integer)) else str(int(v))
                     for v in row) for row in zip(*columns, strict=True)]  # fmt: skip
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def _fit(capsys, argv):
    code = main([str(a) for a in argv] + ["--json"])
    captured = capsys.readouterr()
    assert code in (0, 1), captured.err
    return json.loads(captured.out), captured.err


MAP = "q1=pos.Joint_1,q2=pos.Joint_2,tau1=0.5*cur.Joint_1 [Nm],tau2=0.5*cur.Joint_2 [Nm]"


def test_two_files_at_a_rate_fit_as_their_merged_csv_bit_for_bit(sim, tmp_path, capsys):
    q, tau = sim.select(["q1", "q2"]), sim.select(["tau1", "tau2"]) / KT
    pos = _write(tmp_path / "pos.csv", "Joint_1,Joint_2", [q[:, 0], q[:, 1]])
    cur = _write(tmp_path / "cur.csv", "Joint_1,Joint_2", [tau[:, 0], tau[:, 1]])
    merged = _write(
        tmp_path / "merged.csv",
        "pos.Joint_1,pos.Joint_2,cur.Joint_1,cur.Joint_2",
        [q[:, 0], q[:, 1], tau[:, 0], tau[:, 1]],
    )
    common = ["--model", PLANAR2, "--rate", "1000", "--map", MAP]
    joined, err = _fit(capsys, ["identify", pos, cur, "--join", *common])
    alone, _ = _fit(capsys, ["identify", merged, *common])
    assert "sample by sample at 1000 Hz" in err
    for key in ("parameters", "stderr", "relative_error", "condition_number"):
        assert joined[key] == alone[key]  # bit for bit
    assert joined["success"]
    truth = physid.load_model(PLANAR2)
    assert joined["parameters"]["mcx2"] == pytest.approx(truth.parameters["mcx2"], rel=1e-4)


def test_files_at_a_rate_need_the_same_length(sim, tmp_path, capsys):
    a = _write(tmp_path / "a.csv", "x", [np.arange(10.0)])
    b = _write(tmp_path / "b.csv", "y", [np.arange(12.0)])
    code = main(["identify", str(a), str(b), "--join", "--rate", "100", "--model", str(PLANAR2)])
    err = capsys.readouterr().err
    assert code == 2 and "{'a': 10, 'b': 12}" in err and "same rows" in err
    code = main(["identify", str(a), "--join", "--rate", "100", "--model", str(PLANAR2)])
    assert code == 2 and "give at least 2 files" in capsys.readouterr().err


def _stamped(sim, rng, offset_ns, n, drop=None):
    """Stamps at 500 Hz with jitter (epoch ns) and the run's time at each."""
    k = np.arange(n, dtype=np.int64)
    stamps = T0 + offset_ns + k * 2_000_000 + rng.integers(-100_000, 100_000, n)
    if drop is not None:
        stamps = np.delete(stamps, drop)
    return stamps, (stamps - T0).astype(float) * 1e-9 + 0.05


def test_files_with_stamps_are_joined_on_one_grid(sim, tmp_path, capsys):
    rng = np.random.default_rng(3)
    sp, tp = _stamped(sim, rng, 0, 1900)
    sc, tc = _stamped(sim, rng, 700_000, 1900)  # another clock phase: 0.7 ms later
    pos = _write(tmp_path / "pos.csv", "header.stamp [ns],Joint_1,Joint_2",
                 [sp, np.interp(tp, sim.t, sim["q1"]), np.interp(tp, sim.t, sim["q2"])])  # fmt: skip
    cur = _write(tmp_path / "cur.csv", "header.stamp [ns],Joint_1,Joint_2",
                 [sc, np.interp(tc, sim.t, sim["tau1"]) / KT,
                  np.interp(tc, sim.t, sim["tau2"]) / KT])  # fmt: skip
    out, err = _fit(capsys, ["identify", pos, cur, "--join", "--model", PLANAR2, "--map", MAP])
    assert "onto a uniform grid of 2." in err and "jitter up to" in err
    assert out["success"] and out["n_recordings"] == 1
    truth = physid.load_model(PLANAR2).parameters
    for name in ("mcx2", "YY2"):
        assert out["parameters"][name] == pytest.approx(truth[name], rel=2e-3)


def test_a_gap_splits_the_run_into_segments(sim, tmp_path, capsys):
    rng = np.random.default_rng(4)
    sp, tp = _stamped(sim, rng, 0, 1900)
    sc, tc = _stamped(sim, rng, 300_000, 1900, drop=np.arange(900, 960))  # 120 ms lost
    pos = _write(tmp_path / "pos.csv", "t [ns],q1,q2",
                 [sp, np.interp(tp, sim.t, sim["q1"]), np.interp(tp, sim.t, sim["q2"])])  # fmt: skip
    cur = _write(tmp_path / "cur.csv", "t [ns],tau1,tau2",
                 [sc, np.interp(tc, sim.t, sim["tau1"]), np.interp(tc, sim.t, sim["tau2"])])  # fmt: skip
    out, err = _fit(capsys, ["identify", pos, cur, "--join", "--model", PLANAR2])
    assert "1 gap(s) longer than 5 periods" in err and "in cur" in err
    assert "into 2 segment(s), fitted as separate experiments" in err
    assert out["n_recordings"] == 2
    # no sample of the joined run lies inside the gap
    raw = [physid.load_recording(p, uniform_rtol=None) for p in (pos, cur)]
    run = join_recordings(raw, ["pos", "cur"])
    ((a, b, label),) = run.gaps
    assert label == "cur" and b - a == pytest.approx(0.122, abs=5e-4)
    assert run.segments[0].t[-1] <= a and run.segments[1].t[0] >= b
    np.testing.assert_allclose(np.diff(run.segments[1].t), run.period, rtol=1e-9)


def test_colliding_names_take_the_file_stem():
    a = Recording(np.arange(20) * 0.1, np.ones((20, 2)), ["Joint_1", "x"])
    b = Recording(np.arange(20) * 0.1, np.zeros((20, 1)), ["Joint_1"])
    run = join_recordings([a, b], ["pos", "cur"])
    assert run.segments[0].names == ("pos.Joint_1", "x", "cur.Joint_1")


def test_files_that_do_not_overlap_are_refused(sim, tmp_path, capsys):
    t = np.arange(100) * 0.01
    a = _write(tmp_path / "early.csv", "t,q1", [t, np.sin(t)])
    b = _write(tmp_path / "late.csv", "t,tau1", [t + 5.0, np.cos(t)])
    code = main(["identify", str(a), str(b), "--join", "--model", str(PLANAR2)])
    err = capsys.readouterr().err
    assert code == 2
    assert "the time ranges of late (5 to 5.99 s) and early (0 to 0.99 s) do not overlap" in err
    with pytest.raises(InputError, match="at least 2 Recordings"):
        join_recordings([Recording(t, t, ["x"])])


def test_a_rate_and_stamps_do_not_mix():
    a = Recording([0.0, 0.1], [1.0, 2.0], ["x"], metadata={"rate": 10.0})
    b = Recording([0.0, 0.1], [1.0, 2.0], ["y"])
    with pytest.raises(DataFileError, match=r"\['a'\] have no time column.*\['b'\] have time"):
        join_recordings([a, b], ["a", "b"])
