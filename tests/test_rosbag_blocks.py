"""ROS bags read in blocks (physid.signals.io.open_blocks, rosbag_blocks): one topic of a ROS 1
or ROS 2 bag, message by message, gives what load_recording gives, and a fit streamed from it the
in-memory fit's base parameters; bad bags give load_recording's errors.

Kinds of test (docs STYLE.md): equivalence of forms (blocks end to end == the whole bag, bit for
bit; the streamed IDIM fit == the in-memory one to 1e-10 relative; the command line's block
sources and fleets == the Python fits) and error paths (pytest.raises with the message).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

import physid
from physid.cli import main
from physid.errors import DataFileError, InputError
from physid.estimators.idim import IDIMEstimator
from physid.estimators.idim.stream import fit_streamed
from physid.signals import load_recording
from physid.signals.io import open_blocks
from physid.simulate.closed_loop import simulate_closed_loop

T0 = 1_700_000_000_123_456_789  # epoch nanoseconds: beyond a float64's exact integers
PERIOD = 1_000_000  # 1 kHz [ns]
JOINT_STATE = "sensor_msgs/msg/JointState"
ARRAY = "std_msgs/msg/Float64MultiArray"
KP = (3800.0, 40000.0, 10000.0, 500.0)
KD = (159.5, 120.0, 50.0, 2.0)
W0 = 2 * np.pi * np.array([0.2, 0.3, 0.5, 0.7])


@pytest.fixture(scope="module")
def model():
    return physid.load_model("manipulator")


@pytest.fixture(scope="module")
def run(model):
    """The 4-joint manipulator under PD control, 4 s at 1 kHz (4000 samples), noisy q."""
    t = np.arange(0.0, 4.0, 1e-3)
    ramp = np.clip(t, 0.0, 1.0)[:, None] ** 3
    ref = ramp * (0.8 * np.sin(np.outer(t, W0)) + 0.3 * np.sin(np.outer(t, 2.3 * W0) + 1))
    rec = simulate_closed_loop(model, kp=KP, kd=KD, reference=ref, t=t, noise_std=1e-4, rng=1)
    q = np.column_stack([rec[f"q{j}"] for j in range(1, 5)])
    tau = np.column_stack([rec[f"tau{j}"] for j in range(1, 5)])
    return {"q": q, "tau": tau, "stamps": T0 + np.arange(t.size, dtype=np.int64) * PERIOD}


def _header(types, ros1, k, s):
    time = types["builtin_interfaces/msg/Time"](sec=s // 10**9, nanosec=s % 10**9)
    header = types["std_msgs/msg/Header"]
    return header(seq=k, stamp=time, frame_id="") if ros1 else header(stamp=time, frame_id="")


def write_bag(
    path, kind, names, q, tau, stamps, *, topics=("/joint_states",), arrays=False, logged=None
):
    """JointState messages (the joints in the order ``names``, no velocity) on each of
    ``topics``, and with ``arrays`` the efforts as a Float64MultiArray ``/effort``; logged at
    ``logged`` [ns] (default the stamps)."""
    ros1 = kind == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if ros1:
        writer = Writer1(path)
    else:
        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    types = store.types
    with writer:
        conns = [writer.add_connection(tp, JOINT_STATE, typestore=store) for tp in topics]
        effort = writer.add_connection("/effort", ARRAY, typestore=store) if arrays else None
        layout = types["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
        for k, s in enumerate(stamps):
            s, log = int(s), int(stamps[k] if logged is None else logged[k])
            msg = types[JOINT_STATE](
                header=_header(types, ros1, k, s), name=list(names), position=q[k].copy(),
                velocity=np.zeros(0), effort=tau[k].copy(),
            )  # fmt: skip
            for conn in conns:
                writer.write(conn, log, serialize(msg, JOINT_STATE))
            if effort is not None:
                writer.write(
                    effort, log, serialize(types[ARRAY](layout=layout, data=tau[k]), ARRAY)
                )
    return path


@pytest.fixture(scope="module")
def bags(tmp_path_factory, run, model):
    """The run as a ROS 2 MCAP, a ROS 2 sqlite3 and a ROS 1 bag, the joints in the reverse of the
    model's order (matched by name)."""
    folder = tmp_path_factory.mktemp("bag_blocks")
    names = list(model.joint_names)[::-1]
    q, tau = run["q"][:, ::-1], run["tau"][:, ::-1]
    return {
        kind: write_bag(folder / name, kind, names, q, tau, run["stamps"])
        for kind, name in (("mcap", "run_mcap"), ("sqlite3", "run_db3"), ("ros1", "run.bag"))
    }


@pytest.mark.parametrize("kind", ["mcap", "sqlite3", "ros1"])
def test_blocks_end_to_end_are_the_whole_bag(bags, model, kind):
    whole = load_recording(bags[kind], joint_names=model.joint_names)
    with open_blocks(bags[kind], joint_names=model.joint_names) as src:
        assert src.format == "rosbag" and src.n_samples == 4000 and src.dt == pytest.approx(1e-3)
        blocks = list(src.blocks(700))
    # 4000 samples in blocks of 700: five blocks, the last holding the remainder (1200)
    assert [b.n_samples for b in blocks] == [700, 700, 700, 700, 1200]
    assert (
        blocks[0].names == whole.names == ("q1", "tau1", "q2", "tau2", "q3", "tau3", "q4", "tau4")
    )
    np.testing.assert_array_equal(np.vstack([b.data for b in blocks]), whole.data)
    # times t0 + k·dt against the whole load's grid: equal up to rounding
    t = np.concatenate([b.t for b in blocks])
    np.testing.assert_allclose(t, whole.t, rtol=0, atol=1e-15)
    meta = blocks[0].metadata
    assert meta["time_origin"] == {"first_stamp": T0, "unit": "ns"} == whole.metadata["time_origin"]
    assert meta["topic"] == "/joint_states" and meta["bag_joint_names"][0] == "joint4"
    assert meta["channel_map"] == whole.metadata["channel_map"]


def test_streamed_fit_equals_the_in_memory_fit(bags, model):
    rec = load_recording(bags["mcap"], joint_names=model.joint_names)
    mem = IDIMEstimator(model, "ols").fit(rec).result_
    with open_blocks(bags["mcap"], joint_names=model.joint_names) as src:
        st = fit_streamed(model, src, method="ols", block_samples=700, progress=False)
    assert st.names == mem.names and st.decimate == mem.decimate
    ref = np.array([mem.parameters[n] for n in mem.names])
    got = np.array([st.parameters[n] for n in st.names])
    assert np.max(np.abs(got - ref) / np.abs(ref)) <= 1e-10


def test_a_block_of_a_bag_is_checked_against_the_memory(bags, model, monkeypatch):
    import physid._resources as resources

    with open_blocks(bags["ros1"], joint_names=model.joint_names) as src:
        monkeypatch.setattr(resources, "available_memory", lambda: 1_000_000)
        # a message is taken as ~1.3 kB (raw, decoded, 3 copies of its values; twice over in
        # the check): 700 of them need over the half of the 1 MB said to be free, 50 do not
        with pytest.raises(DataFileError, match=r"one block of 700 samples .* more than half"):
            next(iter(src.blocks(700)))
        assert len(list(src.blocks(50))) == 80  # 50 samples a block fit


def test_an_array_topic_is_read_in_blocks(tmp_path, run, model):
    path = write_bag(
        tmp_path / "arrays", "mcap", model.joint_names, run["q"], run["tau"], run["stamps"],
        arrays=True,
    )  # fmt: skip
    whole = load_recording(path, topic="/effort")
    with open_blocks(path, topic="/effort") as src:
        blocks = list(src.blocks(1000))
    assert len(blocks) == 4 and blocks[0].names == tuple(f"effort.data{k}" for k in range(1, 5))
    np.testing.assert_array_equal(np.vstack([b.data for b in blocks]), whole.data)
    np.testing.assert_array_equal(whole["effort.data3"], run["tau"][:, 2])


def test_several_topics_are_refused_with_the_fix(tmp_path, run, model):
    path = write_bag(
        tmp_path / "two", "mcap", model.joint_names, run["q"], run["tau"], run["stamps"],
        arrays=True,
    )  # fmt: skip
    with pytest.raises(DataFileError, match=r"joined .* not read in blocks; fit the bag in memory"):
        open_blocks(path, topic="/joint_states,/effort", joint_names=model.joint_names)


def _same_error(path, **kw):
    with pytest.raises(DataFileError) as whole:
        load_recording(path, **kw)
    with pytest.raises(DataFileError) as blocks:
        open_blocks(path, **kw)
    assert str(blocks.value) == str(whole.value)
    return str(whole.value)


def test_bad_bags_give_the_whole_reads_errors(tmp_path, run, model, bags):
    names, q, tau, stamps = model.joint_names, run["q"][:50], run["tau"][:50], run["stamps"][:50]
    arrays_only = write_bag(tmp_path / "a", "mcap", names, q, tau, stamps, topics=(), arrays=True)
    assert "the bag has no sensor_msgs/JointState topic" in _same_error(arrays_only)
    two = write_bag(tmp_path / "b", "mcap", names, q, tau, stamps, topics=("/js1", "/js2"))
    assert "2 sensor_msgs/JointState topics" in _same_error(two)
    assert "no topic '/nope'" in _same_error(bags["mcap"], topic="/nope")
    assert "joint(s) ['joint9']" in _same_error(bags["mcap"], joint_names=("joint1", "joint9"))
    damaged = tmp_path / "damaged.bag"
    damaged.write_bytes(Path(bags["ros1"]).read_bytes()[:5000])
    assert "cannot be read as a ROS bag" in _same_error(damaged)
    data = bytearray(Path(bags["ros1"]).read_bytes())
    mid = len(data) // 2
    data[mid : mid + 200] = b"\xff" * 200  # a chunk's header overwritten
    damaged.write_bytes(bytes(data))
    assert "the bag is damaged: reading its messages failed" in _same_error(damaged)
    one = write_bag(tmp_path / "c", "mcap", names, q[:1], tau[:1], stamps[:1])
    assert "holds 1 message(s); physid needs at least 2" in _same_error(one)
    with pytest.raises(InputError, match="topic= applies to ROS bags only"):
        open_blocks(tmp_path / "r.csv", topic="/joint_states")


def _write_rows(path, rows):
    """A ROS 2 MCAP bag of JointState messages ``(names, position, effort)``, 1 kHz."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types
    with Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/joint_states", JOINT_STATE, typestore=store)
        for k, (names, position, effort) in enumerate(rows):
            s = T0 + k * PERIOD
            msg = types[JOINT_STATE](
                header=_header(types, False, k, s), name=list(names),
                position=np.asarray(position, float), velocity=np.zeros(0),
                effort=np.asarray(effort, float),
            )  # fmt: skip
            writer.write(conn, s, store.serialize_cdr(msg, JOINT_STATE))
    return path


def test_a_joint_set_changing_mid_bag_is_named_at_its_message(tmp_path):
    rows = [(("a", "b") if k < 700 else ("a", "c"), [k, -k], [1.0, 2.0]) for k in range(1000)]
    path = _write_rows(tmp_path / "switch", rows)
    # the whole read and the open (whose scan sees other joints in the last messages) agree
    assert "from ['a', 'b'] to ['a', 'c'] at message 700;" in _same_error(path)


def test_a_field_the_first_messages_leave_empty_is_dropped_as_the_whole_read_drops_it(tmp_path):
    rows = [(("a", "b"), [k, -k], [] if k == 1 else [1.0 + k, 2.0]) for k in range(1000)]
    path = _write_rows(tmp_path / "late", rows)
    whole = load_recording(path)
    with open_blocks(path) as src:
        blocks = list(src.blocks(300))
    assert whole.names == blocks[0].names == ("position.a", "position.b")
    np.testing.assert_array_equal(np.vstack([b.data for b in blocks]), whole.data)


def test_a_field_left_empty_after_the_first_messages_is_named_with_its_block(tmp_path):
    rows = [(("a", "b"), [k, -k], [] if k == 650 else [1.0 + k, 2.0]) for k in range(1000)]
    path = _write_rows(tmp_path / "early", rows)
    assert load_recording(path).names == ("position.a", "position.b")  # dropped when whole
    with (
        open_blocks(path) as src,
        pytest.raises(
            DataFileError,
            match=r"fills \['effort'\] in its first messages but leaves it empty in some "
            r"message of samples 600\.\.999; .* fill effort in every message\. Or read the bag "
            r"whole \(load_recording\)",
        ),
    ):
        list(src.blocks(300))


def test_a_stamp_going_back_or_a_gap_is_refused_at_its_sample(tmp_path, run, model):
    names, q, tau = model.joint_names, run["q"][:3000], run["tau"][:3000]
    back = run["stamps"][:3000].copy()
    back[2000] = back[1999] - 10  # non-monotone stamps (the log time stays in order)
    path = write_bag(tmp_path / "back", "mcap", names, q, tau, back, logged=run["stamps"])
    with (
        open_blocks(path, joint_names=names) as src,
        pytest.raises(DataFileError, match=r"not strictly increasing: .* at sample 2000 follows"),
    ):
        list(src.blocks(500))
    gap = np.concatenate([run["stamps"][:1700], run["stamps"][1701:3001]])  # one message lost
    path = write_bag(tmp_path / "gap", "mcap", names, q, tau, gap)
    with (
        open_blocks(path, joint_names=names) as src,
        pytest.raises(DataFileError, match=r"from sample 1699 .* to sample 1700 is 0\.002 s") as e,
    ):
        list(src.blocks(500))
    assert "jitter" not in str(e.value)  # a lost message: no hint on resampling jitter
    jitter = run["stamps"][:3000].copy()
    jitter[1:-1] += np.random.default_rng(2).integers(-50_000, 50_001, 2998)  # ±5 % of a period
    path = write_bag(tmp_path / "jitter.bag", "ros1", names, q, tau, jitter)
    with (
        open_blocks(path, joint_names=names) as src,
        pytest.raises(
            DataFileError, match=r"not uniformly sampled from .*jitter .*resample=True\) reads it"
        ),
    ):
        list(src.blocks(500))


def test_the_command_lines_block_sources_read_a_bag(bags, model, capsys):
    """The sources `identify --stream` opens (the model's joints, --topic) fit as in memory."""
    import argparse

    from physid.cli._streaming import open_sources

    code = main(["identify", str(bags["sqlite3"]), "--model", "manipulator", "--method",
                 "idim-ols", "--stream", "off", "--json"])  # fmt: skip
    mem = json.loads(capsys.readouterr().out)
    assert code == 0
    args = argparse.Namespace(topic="/joint_states", model="manipulator", channel_map=None)
    (src,) = open_sources(args, [str(bags["sqlite3"])], model)
    st = fit_streamed(model, src, method="ols", block_samples=1000, progress=False)
    ref = np.array([p["value"] for p in mem["base_parameters"]])
    got = np.array([st.parameters[p["name"]] for p in mem["base_parameters"]])
    assert np.max(np.abs(got - ref) / np.abs(ref)) <= 1e-10


def test_a_fleet_of_bags(bags, model, tmp_path, capsys, monkeypatch):
    """Bags too large for memory stream (the fit in blocks, counted here), as one fit each."""
    import physid.estimators.idim.stream as stream

    streamed = []
    fit = stream.fit_streamed
    monkeypatch.setattr(stream, "streams_better", lambda paths, model, **k: (True, 0, 0))
    monkeypatch.setattr(stream, "fit_streamed", lambda *a, **k: streamed.append(1) or fit(*a, **k))
    out = tmp_path / "fleet"
    code = main(["identify", str(bags["mcap"]), str(bags["ros1"]), "--model", "manipulator",
                 "--method", "idim-ols", "--each", "--out", str(out), "--json",
                 "--scheduler", "serial"])  # fmt: skip
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert len(streamed) == 2
    mem = IDIMEstimator(model, "ols").fit(
        load_recording(bags["ros1"], joint_names=model.joint_names, uniform_rtol=1e-3)
    )
    ref = np.array([mem.result_.parameters[n] for n in mem.result_.names])
    for name in ("run", "run_mcap"):  # run.bag, and a ROS 2 bag's folder
        table = json.loads((out / "results" / f"{name}.json").read_text())
        got = np.array([table["parameters"][n] for n in mem.result_.names])
        np.testing.assert_allclose(got, ref, rtol=1e-12)


@pytest.mark.parametrize("kind", ["mcap", "ros1"])
def test_a_controller_state_topic_is_read_in_blocks(tmp_path, kind):
    """JointTrajectoryControllerState by name (q, q̇, τ measured, r commanded) in blocks."""
    from test_io_rosbag_topics import _write_jtc

    n = 1500
    stamps = T0 + np.arange(n, dtype=np.int64) * 2_000_000
    rng = np.random.default_rng(3)
    cols = {c: rng.normal(size=n) for c in ("q1", "q2", "qd1", "qd2", "tau1", "tau2", "r1", "r2")}
    path = _write_jtc(tmp_path / ("s.bag" if kind == "ros1" else "s"), kind, stamps, cols)
    keys = {"topic": "/arm_controller/state", "joint_names": ("shoulder", "elbow")}
    whole = load_recording(path, **keys)
    with open_blocks(path, **keys) as src:
        blocks = list(src.blocks(400))
    assert len(blocks) == 3 and blocks[0].names == whole.names and set(cols) <= set(whole.names)
    for c in cols:
        got = np.concatenate([b[c] for b in blocks])
        np.testing.assert_array_equal(got, whole[c])
        np.testing.assert_array_equal(got, cols[c])
    np.testing.assert_array_equal(np.vstack([b.data for b in blocks]), whole.data)


def test_closing_the_source_ends_a_pass_left_halfway(bags, model, monkeypatch):
    import physid.signals.io.rosbag_blocks as rb

    opened, closed = [], []

    def counted(path):
        reader = _open(path)
        opened.append(reader)
        close = reader.close
        reader.close = lambda: (closed.append(reader), close())[1]
        return reader

    _open = rb._open
    monkeypatch.setattr(rb, "_open", counted)
    src = open_blocks(bags["ros1"], joint_names=model.joint_names)
    blocks = src.blocks(500)
    next(blocks)  # a pass left halfway: the bag's reader open
    assert len(opened) == 2 and len(closed) == 1  # the scan's, then the pass's
    src.close()
    assert closed == opened  # the pass's reader closed with the source
    with pytest.raises(StopIteration):
        next(blocks)


def test_a_change_to_a_bag_folders_storage_file_is_seen(tmp_path, run, model):
    import os

    names = model.joint_names
    path = write_bag(tmp_path / "live", "mcap", names, run["q"], run["tau"], run["stamps"])
    (storage,) = path.glob("*.mcap")
    src = open_blocks(path, joint_names=names)
    st = storage.stat()
    os.utime(storage, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))  # rewritten, same size
    with pytest.raises(DataFileError, match=r"the file changed since it was opened"):
        next(iter(src.blocks(500)))


def _jittered(tmp_path, run, model, name="jitter.bag"):
    """The run as a ROS 1 bag whose stamps jitter by up to ±5 % of the period."""
    stamps = run["stamps"].copy()
    stamps[1:-1] += np.random.default_rng(4).integers(-50_000, 50_001, stamps.size - 2)
    names = list(model.joint_names)
    return write_bag(tmp_path / name, "ros1", names, run["q"], run["tau"], stamps)


def test_identify_stream_on_fits_a_bag_in_blocks(bags, model, capsys):
    base = ["identify", str(bags["mcap"]), "--model", "manipulator", "--method", "idim-ols"]
    assert main([*base, "--stream", "off", "--json"]) == 0
    mem = json.loads(capsys.readouterr().out)
    code = main([*base, "--stream", "on", "--block-samples", "1000", "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "streamed in blocks of 1000 samples): 4000 samples of" in captured.err
    st = json.loads(captured.out)
    ref = np.array([p["value"] for p in mem["base_parameters"]])
    got = np.array([p["value"] for p in st["base_parameters"]])
    assert np.max(np.abs(got - ref) / np.abs(ref)) <= 1e-10


def test_identify_stream_on_refuses_joined_topics_and_names_the_fix_for_jitter(
    tmp_path, run, model, capsys
):
    two = write_bag(
        tmp_path / "two", "mcap", model.joint_names, run["q"], run["tau"], run["stamps"],
        arrays=True,
    )  # fmt: skip
    code = main(["identify", str(two), "--model", "manipulator", "--method", "idim-ols",
                 "--topic", "/joint_states,/effort", "--stream", "on"])  # fmt: skip
    err = capsys.readouterr().err
    assert code != 0
    assert "--stream on cannot stream this fit: --topic /joint_states,/effort joins" in err
    bag = _jittered(tmp_path, run, model)
    base = ["identify", str(bag), "--model", "manipulator", "--method", "idim-ols"]
    assert main(base) == 0  # read whole, resampled onto its mean period
    capsys.readouterr()
    assert main([*base, "--stream", "on"]) != 0
    err = capsys.readouterr().err
    assert "not uniformly sampled" in err
    assert "--resample without --stream on reads it whole and resamples" in err


def test_a_fleet_reads_a_jittered_bag_resampled_as_identify_does(tmp_path, run, model, capsys):
    bag = _jittered(tmp_path, run, model)
    assert main(["identify", str(bag), "--model", "manipulator", "--method", "idim-ols",
                 "--json"]) == 0  # fmt: skip
    one = json.loads(capsys.readouterr().out)
    out = tmp_path / "fleet"
    code = main(["identify", str(bag), "--model", "manipulator", "--method", "idim-ols",
                 "--each", "--out", str(out), "--scheduler", "serial"])  # fmt: skip
    captured = capsys.readouterr()
    assert code == 0, captured.err
    table = json.loads((out / "results" / "jitter.json").read_text())
    for p in one["base_parameters"]:
        assert table["parameters"][p["name"]] == pytest.approx(p["value"], rel=1e-12)


def test_estimate_stream_on_reads_a_bag_in_blocks_as_identify_does(tmp_path, capsys):
    from scipy import signal

    t = np.arange(6000) * 1e-3
    u = np.sin(10 * t) + 0.5 * np.sin(23 * t)
    x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]  # ẍ + 2 ẋ + 100 x = u
    stamps = T0 + np.arange(t.size, dtype=np.int64) * PERIOD
    ux = np.c_[u, x]
    bag = write_bag(tmp_path / "msd", "mcap", ["a", "b"], ux, ux, stamps, topics=(), arrays=True)
    base = ["estimate", str(bag), "--method", "rls", "--topic", "/effort", "--map",
            "u=effort.data1,x=effort.data2", "--json"]  # fmt: skip
    assert main([*base, "--stream", "off"]) == 0
    mem = json.loads(capsys.readouterr().out)
    assert main([*base, "--stream", "on", "--block-samples", "1000"]) == 0
    captured = capsys.readouterr()
    assert "streamed: read in blocks of 1000 samples" in captured.err
    st = json.loads(captured.out)
    for name, value in mem["parameters"].items():
        assert st["parameters"][name] == pytest.approx(value, rel=1e-9)
    joined = [*base[:5], "/effort,/other", *base[6:], "--stream", "on"]
    assert main(joined) != 0
    assert "--stream on: --topic /effort,/other joins several topics" in capsys.readouterr().err


def test_a_bag_is_sized_by_its_index_message_count(bags, model):
    """4000 messages of 4 positions and 4 efforts (no velocity): three float64 copies of 9
    values each, and 3 regressors of 4000 × 4 × 8 parameters; whatever the bag's file size."""
    from physid.estimators.idim.stream import in_memory_peak
    from physid.signals.io import in_memory_bytes, in_memory_samples

    n_par = len(model.parameter_names)
    for path in bags.values():
        assert in_memory_samples(path) == 4000
        assert in_memory_bytes(path) == 3 * 8 * 4000 * (8 + 1)
        assert in_memory_peak([path], model) == 3 * 8 * 4000 * 9 + 3 * 4000 * 4 * n_par * 8
    assert in_memory_samples(bags["ros1"], "/joint_states") == 4000
    with pytest.raises(DataFileError, match="no topic '/nope'"):
        in_memory_samples(bags["ros1"], "/nope")


def test_identify_auto_fits_a_jittered_bag_in_memory_below_the_limit(
    tmp_path, run, model, capsys, monkeypatch
):
    """With a limit of 8 MB (the fit in memory needs about 3.9 MB; sized from the file, about
    18 MB), plain identify on a jittered bag reads it whole and resampled, as with --stream
    off; a limit below the fit's need streams it (and the jitter is refused)."""
    import physid._resources as resources

    bag = _jittered(tmp_path, run, model)
    base = ["identify", str(bag), "--model", "manipulator", "--method", "idim-ols", "--json"]
    assert main([*base, "--stream", "off"]) == 0
    mem = json.loads(capsys.readouterr().out)
    monkeypatch.setattr(resources, "STREAM_ABOVE", 8_000_000)
    monkeypatch.setattr(resources, "available_memory", lambda: 10**12)
    code = main(base)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "block by block" not in captured.err
    got = json.loads(captured.out)
    for p, q in zip(mem["base_parameters"], got["base_parameters"], strict=True):
        assert q["value"] == pytest.approx(p["value"], rel=1e-12)
    monkeypatch.setattr(resources, "STREAM_ABOVE", 3_000_000)
    assert main(base) != 0
    assert "fitting block by block (--stream auto)" in capsys.readouterr().err


def test_a_fleet_sizes_a_bag_by_its_message_count(tmp_path, run, model, monkeypatch):
    import physid._resources as resources
    from physid.analysis.fleet import _streamable

    bag = _jittered(tmp_path, run, model)
    monkeypatch.setattr(resources, "available_memory", lambda: 10**12)
    monkeypatch.setattr(resources, "STREAM_ABOVE", 8_000_000)
    assert not _streamable(bag, model, "idim-ols", {}, {})
    monkeypatch.setattr(resources, "STREAM_ABOVE", 3_000_000)
    assert _streamable(bag, model, "idim-ols", {}, {})


def test_a_fleet_keeps_a_bags_stamps_when_asked(tmp_path, run, model):
    """load_options={"resample": False}: the jittered stamps are kept (then refused as not
    uniform at the default tolerance), not resampled behind the caller's back."""
    from physid.analysis.fleet import fit_one_log

    bag = _jittered(tmp_path, run, model)
    names = {"joint_names": model.joint_names}
    row = fit_one_log("manipulator", bag, "idim-ols", load_options={**names, "resample": False})
    assert row["status"] == "failed"
    assert "not uniformly sampled" in row["reason"]
    assert fit_one_log("manipulator", bag, "idim-ols", load_options=names)["status"] == "ok"


def test_estimate_auto_reads_a_small_bag_once(tmp_path, capsys, monkeypatch):
    """estimate --stream auto sizes a bag by its index's message count (identify's rule): a
    small bag is read whole without being scanned in blocks first; above the limit it streams."""
    import physid._resources as resources
    import physid.signals.io as signals_io

    t = np.arange(6000) * 1e-3
    ux = np.c_[np.sin(10 * t), np.cos(7 * t)]
    stamps = T0 + np.arange(t.size, dtype=np.int64) * PERIOD
    bag = write_bag(tmp_path / "msd", "mcap", ["a", "b"], ux, ux, stamps, topics=(), arrays=True)
    opened = []
    real = signals_io.open_blocks
    monkeypatch.setattr(
        signals_io, "open_blocks", lambda *a, **k: opened.append(1) or real(*a, **k)
    )
    monkeypatch.setattr(resources, "available_memory", lambda: 10**12)
    base = ["estimate", str(bag), "--method", "rls", "--topic", "/effort", "--map",
            "u=effort.data1,x=effort.data2", "--json"]  # fmt: skip
    monkeypatch.setattr(resources, "STREAM_ABOVE", 6000 * 400)  # 6000 samples × 400 B: fits
    assert main(base) == 0
    assert opened == []
    capsys.readouterr()
    monkeypatch.setattr(resources, "STREAM_ABOVE", 6000 * 400 - 1)
    assert main(base) == 0
    assert opened == [1]
    assert "streaming" in capsys.readouterr().err


def test_a_bag_jittered_from_a_sample_is_named_at_its_first_irregular_interval(
    tmp_path, run, model
):
    """Stamps regular to sample 3000, then jittering by up to ±5 % of the period: the error
    leads with the jitter, names the first interval off by more than 1e-3 (not the worst) and
    the memory the whole read takes (3 × 8 bytes × 4000 × 9 values = 864 kB)."""
    names, q, tau = model.joint_names, run["q"], run["tau"]
    stamps = run["stamps"].copy()
    stamps[3000:-1] += np.random.default_rng(5).integers(-50_000, 50_001, 999)
    path = write_bag(tmp_path / "late.bag", "ros1", names, q, tau, stamps)
    off = np.abs(np.diff(stamps) - PERIOD) / PERIOD
    first, worst = int(np.argmax(off > 1e-3)), int(off.argmax())
    assert 2999 <= first < worst
    with open_blocks(path, joint_names=names) as src, pytest.raises(DataFileError) as e:
        list(src.blocks(4000))
    text = str(e.value)
    assert f"not uniformly sampled from sample {first}: its stamps jitter (the interval from " \
        f"sample {first} (t = " in text  # fmt: skip
    assert "a gap or a jump" not in text
    assert (
        "(about 864 kB for its 4000 messages, and the fit's arrays); where the memory is "
        "short of that, split the bag into shorter runs (rosbag filter, ros2 bag convert)" in text
    )


def test_joint_scheduler_names_its_own_fix_for_a_jittered_bag(tmp_path, run, model, capsys):
    """--joint --scheduler refuses --resample and --join: its fix is to leave --scheduler out."""
    bag = _jittered(tmp_path, run, model)
    code = main(["identify", str(bag), str(bag), "--model", "manipulator", "--method",
                 "idim-ols", "--joint", "--scheduler", "serial"])  # fmt: skip
    err = capsys.readouterr().err
    assert code != 0
    assert "not uniformly sampled from sample" in err
    assert "With --joint --scheduler each worker reads its log in blocks as it is: leave " \
        "--scheduler out to fit in this process" in err  # fmt: skip
    assert "--resample reads it whole" not in err and "--join, in memory" not in err


def test_an_emptied_effort_is_worded_for_each_way_the_command_line_reads_a_bag(
    tmp_path, run, model, capsys, monkeypatch
):
    """A bag whose effort goes empty partway: the fix first (fill effort in every message);
    --stream on and --stream auto (above the limit) add the whole read as a flag of theirs
    (--stream off, the user may never have passed --stream); a fleet and --joint --scheduler,
    which take neither --stream nor joined topics, only the fill."""
    import physid._resources as resources
    import physid.estimators.idim.stream as stream

    names = model.joint_names
    rows = [(names, run["q"][k], [] if k == 2500 else run["tau"][k]) for k in range(4000)]
    path = _write_rows(tmp_path / "empty", rows)
    base = ["identify", str(path), "--model", "manipulator", "--method", "idim-ols"]
    fill = "must be filled in every message: fill effort in every message."
    whole = (
        "Or read the bag whole (--stream off), which drops such a field (and with effort the "
        "torques: take them from another topic, --topic /joint_states,/TORQUES)."
    )
    assert main([*base, "--stream", "on", "--block-samples", "1000"]) == 2
    err = capsys.readouterr().err
    assert fill in err and whole in err and "load_recording" not in err
    monkeypatch.setattr(resources, "available_memory", lambda: 10**12)
    monkeypatch.setattr(resources, "STREAM_ABOVE", 1024)
    assert main(base) == 2
    err = capsys.readouterr().err
    assert "(--stream auto)" in err and fill in err and whole in err
    assert "leave --stream on out" not in err
    monkeypatch.setattr(stream, "streams_better", lambda paths, model, **k: (True, 0, 0))
    out = tmp_path / "fleet"
    assert main([*base, "--each", "--out", str(out), "--json", "--scheduler", "serial"]) == 1
    (row,) = json.loads(capsys.readouterr().out)["rows"]
    assert row["reason"].endswith(fill), row["reason"]
    code = main([*base[:2], str(path), *base[2:], "--joint", "--scheduler", "serial"])
    err = capsys.readouterr().err
    assert code == 2 and err.rstrip().endswith(fill), err
    assert "--stream" not in err and "--topic" not in err


def test_a_topic_without_messages_is_refused_by_its_count_under_auto(tmp_path, capsys):
    """A /joint_states connection holding no message: identify and estimate under --stream auto
    and a fleet's row give the count, not a crash in the sizing (the first message's width)."""
    from physid.analysis.fleet import fit_one_log
    from physid.signals.io.rosbag_reader import bag_extent

    path = _write_rows(tmp_path / "none", [])
    count = "topic '/joint_states' holds 0 message(s); physid needs at least 2"
    with pytest.raises(DataFileError, match=re.escape(count)):
        bag_extent(path)
    for argv in (
        ["identify", str(path), "--model", "manipulator", "--method", "idim-ols"],
        ["estimate", str(path), "--method", "rls", "--map", "u=effort.a,x=position.a"],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert count in err and "Traceback" not in err
    row = fit_one_log("manipulator", path, "idim-ols")
    assert row["status"] == "failed" and count in row["reason"]


def test_a_lost_message_keeps_its_split_under_joint_scheduler_and_stream_on(
    tmp_path, run, model, capsys
):
    """One message lost at sample 2000: the fix is the split at sample 2000, with no --join
    (refused with one file; with --joint it joins logs as channels) and no --resample."""
    names = model.joint_names
    gap = np.concatenate([run["stamps"][:2000], run["stamps"][2001:]])
    path = write_bag(tmp_path / "gap", "mcap", names, run["q"][:3999], run["tau"][:3999], gap)
    base = ["identify", str(path), "--model", "manipulator", "--method", "idim-ols"]
    split = (
        "a gap or a jump in the time. Split the file at sample 2000 and fit the parts as "
        "separate experiments."
    )
    for argv in (
        [*base[:2], str(path), *base[2:], "--joint", "--scheduler", "serial"],
        [*base, "--stream", "on"],
    ):
        assert main(argv) == 2
        (err,) = [s for s in capsys.readouterr().err.splitlines() if "error:" in s]
        assert split in err, err
        assert "--join" not in err and "join_recordings" not in err and "--resample" not in err


def test_a_lone_step_of_a_bags_stamps_is_a_jump_not_jitter(tmp_path, run, model):
    """Regular stamps but one interval of 1.4 periods (from sample 1999): a jump in the time,
    named with its split, not jitter to resample."""
    names = model.joint_names
    stamps = run["stamps"].copy()
    stamps[2000:] += 4 * PERIOD // 10
    path = write_bag(tmp_path / "jump", "mcap", names, run["q"], run["tau"], stamps)
    for size in (4000, 500):
        with open_blocks(path, joint_names=names) as src, pytest.raises(DataFileError) as e:
            list(src.blocks(size))
        text = str(e.value)
        assert "from sample 1999 (t = 1.999 s) to sample 2000 is 0.0014 s" in text, text
        assert "a gap or a jump in the time. Split the file at sample 2000" in text
        assert "jitter" not in text and "resample" not in text


def test_a_bag_is_sized_from_one_opening_and_counted_without_a_message_decoded(
    bags, model, monkeypatch
):
    """in_memory_samples decodes no message; in_memory_peak opens the bag once (its first
    message decoded once) for the same sizes as in_memory_bytes and in_memory_samples."""
    import physid.signals.io.rosbag_reader as reader
    from physid.estimators.idim.stream import in_memory_peak
    from physid.signals.io import in_memory_bytes, in_memory_extent, in_memory_samples

    path = bags["mcap"]
    n_par = len(model.parameter_names)
    assert in_memory_extent(path) == (in_memory_bytes(path), in_memory_samples(path))
    assert in_memory_extent(path) == (3 * 8 * 4000 * 9, 4000)
    opened, decoded = [], []
    real_open, real_decode = reader._open, reader._Decoder.decode
    monkeypatch.setattr(reader, "_open", lambda p: opened.append(p) or real_open(p))
    monkeypatch.setattr(
        reader._Decoder, "decode", lambda self, *a: decoded.append(1) or real_decode(self, *a)
    )
    assert in_memory_samples(path) == 4000
    assert (len(opened), decoded) == (1, [])
    opened.clear()
    assert in_memory_peak([path], model) == 3 * 8 * 4000 * 9 + 3 * 4000 * 4 * n_par * 8
    assert (len(opened), decoded) == (1, [1])
