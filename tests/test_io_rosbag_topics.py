"""ROS bags beyond JointState (physid.signals.io.rosbag_reader): Float64MultiArray effort topics,
and several topics of one run joined on their stamps like the same topics exported to files and
read with --join."""

from __future__ import annotations

import json

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

import physid
from _helpers import PLANAR2, planar2_pd_run
from physid.cli import main
from physid.errors import DataFileError, InputError
from physid.signals import join_recordings, load_recording

T0 = 1_700_000_000_123_456_789  # epoch nanoseconds
JOINT_STATE = "sensor_msgs/msg/JointState"
ARRAY = "std_msgs/msg/Float64MultiArray"
EFFORT = "/effort_controller/commands"
BOTH = f"/joint_states,{EFFORT}"
MAP = "tau1=effort_controller.commands.data1,tau2=effort_controller.commands.data2"


def _header(types, ros1, k, s):
    time = types["builtin_interfaces/msg/Time"](sec=s // 10**9, nanosec=s % 10**9)
    header = types["std_msgs/msg/Header"]
    return header(seq=k, stamp=time, frame_id="") if ros1 else header(stamp=time, frame_id="")


def _messages(store, ros1, run):
    """(topic, log time, message): JointState (elbow first, no effort) and the efforts as a
    Float64MultiArray in the controller's order (shoulder, elbow), logged a little later."""
    types = store.types
    layout = types["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
    empty = np.zeros(0)
    for k, s in enumerate(run["stamps"]):
        s = int(s)
        q, qd = run["q"][k], run["qd"][k]
        state = types[JOINT_STATE](
            header=_header(types, ros1, k, s), name=["elbow", "shoulder"],
            position=q[::-1].copy(), velocity=qd[::-1].copy(), effort=empty,
        )  # fmt: skip
        yield "/joint_states", s, state
    for k, s in enumerate(run["effort_stamps"]):
        yield EFFORT, int(s), types[ARRAY](layout=layout, data=run["tau"][k].copy())


def _write(path, run, kind):
    if kind == "ros1":
        store = get_typestore(Stores.ROS1_NOETIC)
        writer = Writer1(path)
    else:
        store = get_typestore(Stores.ROS2_HUMBLE)
        writer = Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP)
    with writer:
        conns = {
            "/joint_states": writer.add_connection("/joint_states", JOINT_STATE, typestore=store),
            EFFORT: writer.add_connection(EFFORT, ARRAY, typestore=store),
        }
        count = writer.add_connection("/count", "std_msgs/msg/Int32", typestore=store)
        items = sorted(_messages(store, kind == "ros1", run), key=lambda m: m[1])
        for topic, s, msg in items:
            kind_of = JOINT_STATE if topic == "/joint_states" else ARRAY
            raw = (store.serialize_ros1 if kind == "ros1" else store.serialize_cdr)(msg, kind_of)
            writer.write(conns[topic], s, raw)
        one = store.types["std_msgs/msg/Int32"](data=1)
        raw = (store.serialize_ros1 if kind == "ros1" else store.serialize_cdr)(
            one, "std_msgs/msg/Int32"
        )
        writer.write(count, int(run["stamps"][0]), raw)
    return path


def _csv(path, header, stamps, columns):
    lines = [header]
    for k, s in enumerate(stamps):
        lines.append(f"{int(s)}," + ",".join(repr(float(c[k])) for c in columns))
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """The planar arm's PD run: positions at 500 Hz with ±10 % jitter, efforts logged 37 µs
    (± 20 µs) after them; as a ROS 2 (MCAP) and a ROS 1 bag, and as two CSV files."""
    folder = tmp_path_factory.mktemp("topics")
    sim = planar2_pd_run(physid.load_model(PLANAR2), duration=4.0)
    rng = np.random.default_rng(11)
    n = 1900
    stamps = T0 + np.arange(n, dtype=np.int64) * 2_000_000 + rng.integers(-200_000, 200_000, n)
    late = stamps + 37_000 + rng.integers(-20_000, 20_000, n)

    def at(st, c):
        return np.interp((st - T0).astype(float) * 1e-9 + 0.05, sim.t, sim[c])

    run = {
        "stamps": stamps,
        "effort_stamps": late,
        "q": np.column_stack([at(stamps, "q1"), at(stamps, "q2")]),
        "qd": np.column_stack([at(stamps, "qd1"), at(stamps, "qd2")]),
        "tau": np.column_stack([at(late, "tau1"), at(late, "tau2")]),
    }
    pos = _csv(folder / "pos.csv", "header.stamp [ns],q1,q2,qd1,qd2", stamps,
               [run["q"][:, 0], run["q"][:, 1], run["qd"][:, 0], run["qd"][:, 1]])  # fmt: skip
    eff = _csv(folder / "eff.csv", "header.stamp [ns],tau1,tau2", late,
               [run["tau"][:, 0], run["tau"][:, 1]])  # fmt: skip
    return {
        "pos": pos,
        "eff": eff,
        "mcap": _write(folder / "run_mcap", run, "mcap"),
        "ros1": _write(folder / "run.bag", run, "ros1"),
        "run": run,
    }


def _base(argv):
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv] + ["--json"])
    assert code == 0, err.getvalue()
    return {b["name"]: b["value"] for b in json.loads(out.getvalue())["base_parameters"]}, err


@pytest.fixture(scope="module")
def csv_fit(files):
    return _base(["identify", files["pos"], files["eff"], "--join", "--model", PLANAR2])[0]


@pytest.mark.parametrize("kind", ["mcap", "ros1"])
def test_two_topics_give_the_joined_csv_base_parameters(files, csv_fit, kind):
    got, err = _base(["identify", files[kind], "--model", PLANAR2, "--topic", BOTH, "--map", MAP])
    assert got.keys() == csv_fit.keys()
    diff = max(abs(got[k] - csv_fit[k]) for k in csv_fit)
    assert diff <= 1e-9, diff
    assert "joined 2 topics (joint_states, effort_controller.commands) on their time stamps" in (
        err.getvalue()
    )


def test_the_joined_topics_equal_the_joined_files(files):
    rec = load_recording(files["mcap"], {"tau1": "effort_controller.commands.data1"},
                         topic=BOTH, joint_names=("shoulder", "elbow"))  # fmt: skip
    pos = load_recording(files["pos"], uniform_rtol=None)
    eff = load_recording(files["eff"], uniform_rtol=None)
    (seg,) = join_recordings([pos, eff], ["pos", "eff"]).segments
    np.testing.assert_array_equal(rec.t, seg.t)
    for mine, theirs in (("q1", "q1"), ("q2", "q2"), ("qd2", "qd2"), ("tau1", "tau1")):
        np.testing.assert_allclose(rec[mine], seg[theirs], rtol=0, atol=1e-12)
    # the array's values in the controller's order, named by index, never guessed to joints
    assert "effort_controller.commands.data2" in rec.names and "tau2" not in rec.names
    assert rec.metadata["topic"] == BOTH


def test_an_array_topic_alone(files):
    rec = load_recording(files["ros1"], topic=EFFORT, uniform_rtol=None)
    run = files["run"]
    np.testing.assert_array_equal(rec["effort_controller.commands.data2"], run["tau"][:, 1])
    stamps = run["effort_stamps"]
    np.testing.assert_array_equal(rec.t, (stamps - stamps[0]).astype(float) * 1e-9)


def test_bad_topics_are_named(files):
    with pytest.raises(DataFileError, match=r"carries std_msgs/msg/Int32, not sensor_msgs/"):
        load_recording(files["mcap"], topic="/joint_states,/count")
    with pytest.raises(DataFileError, match=r"no topic '/efort'.*/effort_controller/commands"):
        load_recording(files["mcap"], topic="/joint_states,/efort")
    with pytest.raises(InputError, match=r"topic names a topic twice"):
        load_recording(files["mcap"], topic="/joint_states,/joint_states")
    with pytest.raises(InputError, match=r"several separated by commas"):
        load_recording(files["mcap"], topic="/joint_states,")


def test_a_gap_in_one_topic_is_refused_naming_it(files, tmp_path):
    """20 effort messages lost in the middle: a gap the join would split at; never bridged."""
    run = dict(files["run"])
    keep = np.r_[0:900, 920 : run["tau"].shape[0]]
    run["effort_stamps"], run["tau"] = run["effort_stamps"][keep], run["tau"][keep]
    bag = _write(tmp_path / "gap_mcap", run, "mcap")
    with pytest.raises(DataFileError, match=r"have gaps: 1 gap\(s\) longer than 5 periods.*"
                       r"in effort_controller\.commands"):  # fmt: skip
        load_recording(bag, topic=BOTH)


# ------------------------------------------------- control_msgs/JointTrajectoryControllerState
JTC = "control_msgs/msg/JointTrajectoryControllerState"
JTC_ROS1 = """std_msgs/Header header
string[] joint_names
trajectory_msgs/JointTrajectoryPoint desired
trajectory_msgs/JointTrajectoryPoint actual
trajectory_msgs/JointTrajectoryPoint error
"""
JTC_HUMBLE = (
    JTC_ROS1
    + """trajectory_msgs/JointTrajectoryPoint reference
trajectory_msgs/JointTrajectoryPoint feedback
trajectory_msgs/JointTrajectoryPoint output
"""
)


def _write_jtc(path, kind, stamps, cols):
    """The controller state, joints (elbow, shoulder): ROS 1 fills desired/actual; ROS 2 Humble
    fills reference/feedback and leaves the deprecated desired/actual empty."""
    from rosbags.typesys import get_types_from_msg

    ros1 = kind == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(JTC_ROS1 if ros1 else JTC_HUMBLE, JTC))
    types = store.types
    point = types["trajectory_msgs/msg/JointTrajectoryPoint"]
    zero = types["builtin_interfaces/msg/Duration"](sec=0, nanosec=0)
    empty = np.zeros(0)

    def pt(pos=empty, vel=empty, eff=empty):
        return point(positions=pos, velocities=vel, accelerations=empty, effort=eff,
                     time_from_start=zero)  # fmt: skip

    writer = Writer1(path) if ros1 else Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    with writer:
        conn = writer.add_connection("/arm_controller/state", JTC, typestore=store)
        for k, s in enumerate(stamps):
            s = int(s)

            def two(c, k=k):
                return np.array([cols[f"{c}2"][k], cols[f"{c}1"][k]])  # elbow, shoulder

            measured = pt(two("q"), two("qd"), two("tau"))
            commanded = pt(two("r"))
            err = pt(two("r") - two("q"))
            if ros1:
                msg = types[JTC](header=_header(types, True, k, s), joint_names=["elbow", "shoulder"],
                                 desired=commanded, actual=measured, error=err)  # fmt: skip
            else:
                msg = types[JTC](header=_header(types, False, k, s),
                                 joint_names=["elbow", "shoulder"], desired=pt(), actual=pt(),
                                 error=err, reference=commanded, feedback=measured, output=pt())  # fmt: skip
            writer.write(conn, s, serialize(msg, JTC))
    return path


@pytest.fixture(scope="module")
def jtc(tmp_path_factory):
    folder = tmp_path_factory.mktemp("jtc")
    sim = planar2_pd_run(physid.load_model(PLANAR2), duration=4.0)
    rng = np.random.default_rng(5)
    n = 1900
    stamps = T0 + np.arange(n, dtype=np.int64) * 2_000_000 + rng.integers(-200_000, 200_000, n)
    t = (stamps - T0).astype(float) * 1e-9 + 0.05
    names = ("q1", "q2", "qd1", "qd2", "tau1", "tau2", "r1", "r2")
    cols = {c: np.interp(t, sim.t, sim[c]) for c in names}
    csv = _csv(folder / "state.csv", "header.stamp [ns]," + ",".join(names), stamps,
               [cols[c] for c in names])  # fmt: skip
    return {
        "csv": csv,
        "mcap": _write_jtc(folder / "state_mcap", "mcap", stamps, cols),
        "ros1": _write_jtc(folder / "state.bag", "ros1", stamps, cols),
    }


@pytest.mark.parametrize("kind", ["mcap", "ros1"])
def test_controller_state_by_name_with_references(jtc, kind):
    """No map: q, q̇, τ from the measured point and r from the commanded one, matched by name;
    the same channels as the equivalent CSV; and the same fit to 1e-9."""
    rec = load_recording(jtc[kind], topic="/arm_controller/state",
                         joint_names=("shoulder", "elbow"), resample=True)  # fmt: skip
    ref = load_recording(jtc["csv"], resample=True)
    np.testing.assert_array_equal(rec.t, ref.t)
    for c in ("q1", "q2", "qd1", "qd2", "tau1", "tau2", "r1", "r2"):
        np.testing.assert_allclose(rec[c], ref[c], rtol=0, atol=1e-12)
    point = "feedback" if kind == "mcap" else "actual"
    assert rec.metadata["channel_map"]["q2"] == f"{point}.positions.elbow"
    got, _ = _base(["identify", jtc[kind], "--model", PLANAR2, "--topic", "/arm_controller/state"])
    want, _ = _base(["identify", jtc["csv"], "--model", PLANAR2, "--resample"])
    assert max(abs(got[k] - want[k]) for k in want) <= 1e-9
