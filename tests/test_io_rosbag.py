"""ROS bags (physid.signals.io.rosbag_reader): JointState topics of ROS 1 and ROS 2 (MCAP and
sqlite3) bags, written here with the rosbags writer, matched to the URDF's joints by name."""

from __future__ import annotations

import json
import re
import sys

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

import physid
from _helpers import PLANAR2, planar2_pd_run
from physid.cli import main
from physid.errors import DataFileError, InputError, MissingDependencyError
from physid.signals import load_recording

T0 = 1_700_000_000_123_456_789  # epoch nanoseconds: beyond a float64's exact integers
JOINT_STATE = "sensor_msgs/msg/JointState"


def _messages(store, ros1, stamps, rec_at):
    """JointState messages, joints in the order elbow, shoulder (the URDF's is reversed)."""
    types = store.types
    for k, stamp in enumerate(stamps):
        s = int(stamp)
        time = types["builtin_interfaces/msg/Time"](sec=s // 10**9, nanosec=s % 10**9)
        header = types["std_msgs/msg/Header"]
        header = header(seq=k, stamp=time, frame_id="") if ros1 else header(stamp=time, frame_id="")
        q, qd, tau = rec_at[k]
        yield (
            s,
            types[JOINT_STATE](
                header=header,
                name=["elbow", "shoulder"],
                position=q[::-1].copy(),
                velocity=qd[::-1].copy(),
                effort=tau[::-1].copy(),
            ),
        )


def _write_ros2(folder, plugin, stamps, rows):
    store = get_typestore(Stores.ROS2_HUMBLE)
    with Writer2(folder, version=9, storage_plugin=plugin) as writer:
        conn = writer.add_connection("/joint_states", JOINT_STATE, typestore=store)
        other = writer.add_connection("/tf_static_count", "std_msgs/msg/Int32", typestore=store)
        for s, msg in _messages(store, False, stamps, rows):
            writer.write(conn, s, store.serialize_cdr(msg, JOINT_STATE))
        count = store.types["std_msgs/msg/Int32"](data=1)
        writer.write(other, int(stamps[0]), store.serialize_cdr(count, "std_msgs/msg/Int32"))
    return folder


def _write_ros1(path, stamps, rows):
    store = get_typestore(Stores.ROS1_NOETIC)
    with Writer1(path) as writer:
        conn = writer.add_connection("/joint_states", JOINT_STATE, typestore=store)
        for s, msg in _messages(store, True, stamps, rows):
            writer.write(conn, s, store.serialize_ros1(msg, JOINT_STATE))
    return path


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    """The planar arm's PD run at 500 Hz with ±10 % jitter, as 3 bags and the equivalent CSV."""
    folder = tmp_path_factory.mktemp("rosbags")
    sim = planar2_pd_run(physid.load_model(PLANAR2), duration=4.0)
    rng = np.random.default_rng(7)
    n = 1900
    stamps = T0 + np.arange(n, dtype=np.int64) * 2_000_000 + rng.integers(-200_000, 200_000, n)
    t = (stamps - T0).astype(float) * 1e-9 + 0.05  # the simulation's time of each stamp
    cols = {c: np.interp(t, sim.t, sim[c]) for c in ("q1", "q2", "qd1", "qd2", "tau1", "tau2")}
    rows = [
        tuple(np.array([cols[f"{s}1"][k], cols[f"{s}2"][k]]) for s in ("q", "qd", "tau"))
        for k in range(n)
    ]
    csv = folder / "run.csv"
    lines = ["header.stamp [ns],q1,q2,qd1,qd2,tau1,tau2"]
    for k in range(n):
        values = ",".join(
            repr(float(cols[c][k])) for c in ("q1", "q2", "qd1", "qd2", "tau1", "tau2")
        )
        lines.append(f"{int(stamps[k])},{values}")
    csv.write_text("\n".join(lines) + "\n")
    return {
        "csv": csv,
        "mcap": _write_ros2(folder / "run_mcap", StoragePlugin.MCAP, stamps, rows),
        "sqlite3": _write_ros2(folder / "run_sqlite", StoragePlugin.SQLITE3, stamps, rows),
        "ros1": _write_ros1(folder / "run.bag", stamps, rows),
        "stamps": stamps,
    }


def _fit(capsys, argv):
    code = main([str(a) for a in argv] + ["--json"])
    captured = capsys.readouterr()
    assert code in (0, 1), captured.err
    return json.loads(captured.out), captured.err


@pytest.fixture(scope="module")
def csv_fit(bags):
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        main(["identify", str(bags["csv"]), "--model", str(PLANAR2), "--resample", "--json"])
    return json.loads(out.getvalue())


@pytest.mark.parametrize("kind", ["mcap", "sqlite3", "ros1"])
def test_bag_without_map_gives_the_csv_base_parameters(bags, csv_fit, capsys, kind):
    out, err = _fit(
        capsys, ["identify", bags[kind], "--model", PLANAR2, "--topic", "/joint_states"]
    )
    assert "joints elbow, shoulder" in err  # the bag's order, matched by name
    assert re.search(
        r"up to \d+(\.\d+)? % of the mean period; resampled onto a uniform grid of [12]\.99\d* ms",
        err,
    )
    ref = {b["name"]: b["value"] for b in csv_fit["base_parameters"]}
    got = {b["name"]: b["value"] for b in out["base_parameters"]}
    assert got.keys() == ref.keys()
    diff = max(abs(got[k] - ref[k]) for k in ref)
    assert diff <= 1e-9, diff
    assert csv_fit["success"]


def test_bag_stamps_are_exact_nanoseconds(bags):
    rec = load_recording(bags["ros1"], joint_names=("shoulder", "elbow"), uniform_rtol=None)
    stamps = bags["stamps"]
    assert rec.metadata["time_origin"] == {"first_stamp": int(stamps[0]), "unit": "ns"}
    # t = (stamp - first) · 1e-9 exactly: the integers differ by < 2**53
    np.testing.assert_array_equal(rec.t, (stamps - stamps[0]).astype(float) * 1e-9)
    # a float64 of the epoch stamp itself would have lost the last digits
    assert int(float(stamps[0])) != int(stamps[0])


def test_joints_are_matched_by_name(bags):
    rec = load_recording(bags["mcap"], joint_names=("shoulder", "elbow"), resample=True)
    flipped = load_recording(bags["mcap"], joint_names=("elbow", "shoulder"), resample=True)
    np.testing.assert_array_equal(rec["q1"], flipped["q2"])
    np.testing.assert_array_equal(rec["tau2"], flipped["tau1"])
    raw = load_recording(bags["mcap"], resample=True)  # no model: the bag's own names
    np.testing.assert_array_equal(raw["position.shoulder"], rec["q1"])


def test_a_topic_not_in_the_bag_lists_the_topics(bags):
    with pytest.raises(DataFileError, match=r"no topic '/joints'.*/joint_states \(sensor_msgs"):
        load_recording(bags["mcap"], topic="/joints")
    with pytest.raises(DataFileError, match="carries std_msgs/msg/Int32, not sensor_msgs"):
        load_recording(bags["mcap"], topic="/tf_static_count")


def test_a_joint_not_in_the_bag_lists_the_bag_joints(bags, capsys):
    with pytest.raises(
        DataFileError, match=r"\['wrist'\] are not in topic.*\['elbow', 'shoulder'\]"
    ):
        load_recording(bags["ros1"], joint_names=("shoulder", "wrist"), resample=True)
    # mapped by hand, the missing one is no error
    rec = load_recording(
        bags["ros1"], {"q2": "position.elbow"}, joint_names=("shoulder", "wrist"), resample=True
    )
    assert "q1" in rec.names and "q2" in rec.names
    code = main(["identify", str(bags["ros1"]), "--model", str(PLANAR2), "--topic", "/nope"])
    err = capsys.readouterr().err
    assert code == 2 and "--topic" in err and "/joint_states" in err


def test_a_bag_too_large_is_refused_with_the_size(bags, monkeypatch):
    import physid._resources as resources

    monkeypatch.setattr(resources, "available_memory", lambda: 10_000)
    with pytest.raises(InputError, match=r"1900 messages of 2 joints\) needs about .* of memory"):
        load_recording(bags["mcap"])


def test_missing_rosbags_names_the_extra(bags, monkeypatch):
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)
    with pytest.raises(MissingDependencyError, match=r"physid\[ros\]"):
        load_recording(bags["ros1"])
