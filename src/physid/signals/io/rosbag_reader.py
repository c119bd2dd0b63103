"""ROS bags: ``sensor_msgs/JointState`` messages of ROS 1 (``.bag``) and ROS 2 (MCAP or sqlite3)
bags, read with `rosbags <https://gitlab.com/ternaris/rosbags>`_ (pure Python, optional:
``pip install "physid[ros]"``).

Each joint of the messages becomes the variables ``position.<joint>``, ``velocity.<joint>`` and
``effort.<joint>`` (those the messages fill), the time ``t`` is ``header.stamp`` in integer
nanoseconds (the bag's receive time where the stamp is unset), kept exact. Given the model's
joint names, the joints are matched **by name** (in any order in the bag) and a channel map
``q<j> = position.<name>``, ``qd<j> = velocity.<name>``, ``tau<j> = effort.<name>`` is made, so a
bag whose names match the URDF needs no map at all.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..._resources import check_memory
from ...errors import DataFileError, InputError, MissingDependencyError
from .variables import _Source, _Var

__all__ = ["is_rosbag", "read_rosbag", "ROSBAG_SUFFIXES"]

#: File suffixes read as ROS bags (a ROS 2 bag may also be given as its folder).
ROSBAG_SUFFIXES = (".bag", ".mcap", ".db3")

_JOINT_STATE = ("sensor_msgs/msg/JointState", "sensor_msgs/JointState")
_FIELDS = (("position", "q"), ("velocity", "qd"), ("effort", "tau"))


def is_rosbag(path) -> bool:
    """True for a ``.bag``/``.mcap``/``.db3`` file or a ROS 2 bag folder (with metadata.yaml).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bool
    """
    path = Path(path)
    if path.suffix.lower() in ROSBAG_SUFFIXES:
        return True
    return path.is_dir() and (path / "metadata.yaml").is_file()


def _reader_class():
    try:
        from rosbags.highlevel import AnyReader
    except ImportError:
        raise MissingDependencyError(
            "reading ROS bags needs rosbags, which is not installed; run pip install "
            '"physid[ros]" (or pip install rosbags), or export the topics to CSV.'
        ) from None
    return AnyReader


def _open(path: Path):
    """An open `rosbags` reader of the bag (a ROS 2 bag's .mcap/.db3 is opened as its folder)."""
    reader_class = _reader_class()
    if not path.exists():
        raise DataFileError(f"{path}: no such file or folder; check the path.")
    target = path
    if path.suffix.lower() in (".mcap", ".db3") and (path.parent / "metadata.yaml").is_file():
        target = path.parent
    try:
        reader = reader_class([target])
        reader.open()
    except Exception as exc:  # rosbags raises its own classes for damaged or foreign files
        raise DataFileError(
            f"{path}: cannot be read as a ROS bag ({type(exc).__name__}: {exc}); a ROS 2 bag is "
            "read from its folder (with metadata.yaml) or its .mcap/.db3 file, a ROS 1 bag from "
            "its .bag file."
        ) from None
    return reader


def _connections(path, reader, topic):
    """The connections of the JointState topic to read (``topic`` or the only one)."""
    topics = sorted({(c.topic, c.msgtype) for c in reader.connections})
    listed = ", ".join(f"{t} ({m})" for t, m in topics) or "none"
    states = sorted({t for t, m in topics if m in _JOINT_STATE})
    if topic is None:
        if len(states) != 1:
            which = "no sensor_msgs/JointState topic" if not states else (
                f"{len(states)} sensor_msgs/JointState topics"
            )  # fmt: skip
            raise DataFileError(
                f"{path}: the bag has {which}; its topics are {listed}. Choose one with "
                f"topic='{states[0] if states else '/joint_states'}'."
            )
        topic = states[0]
    chosen = [c for c in reader.connections if c.topic == topic]
    if not chosen:
        raise DataFileError(
            f"{path}: the bag has no topic {topic!r}; its topics are {listed}. Choose one of "
            f"them with topic=."
        )
    if chosen[0].msgtype not in _JOINT_STATE:
        raise DataFileError(
            f"{path}: topic {topic!r} carries {chosen[0].msgtype}, not sensor_msgs/JointState; "
            f"physid reads JointState topics ({', '.join(states) or 'none in this bag'})."
        )
    return topic, chosen


def _stamp(msg, logtime: int) -> int:
    """``header.stamp`` in integer ns (ROS 1 and 2 field names); the log time where unset."""
    stamp = msg.header.stamp
    sec = getattr(stamp, "sec", getattr(stamp, "secs", 0))
    nsec = getattr(stamp, "nanosec", getattr(stamp, "nsecs", 0))
    value = int(sec) * 1_000_000_000 + int(nsec)
    return value if value > 0 else int(logtime)


def read_rosbag(path, *, topic=None, joint_names=None, mapped=()) -> _Source:
    """The JointState messages of one topic as variables (see the module's docstring).

    Parameters
    ----------
    path : str or Path
        A ``.bag`` (ROS 1), ``.mcap`` or ``.db3`` file, or a ROS 2 bag folder.
    topic : str, optional
        The JointState topic; default the bag's only one.
    joint_names : sequence of str, optional
        The model's joints, in its order (q1 is the first).
    mapped : collection of str
        Channels the caller maps itself (a model joint missing from the bag is then no error).

    Returns
    -------
    _Source
        Variables ``t`` [ns] (int64) and ``position.<joint>`` etc.; metadata ``topic``,
        ``bag_joint_names`` and ``joint_map`` (the channel map by name).

    Raises
    ------
    DataFileError
        Not a bag, no such topic (the message lists the bag's topics), a model joint not in the
        messages (the message lists the bag's joint names), messages without samples.
    InputError
        The bag does not fit in memory (the message gives the size).
    MissingDependencyError
        rosbags is not installed.
    """
    path = Path(path)
    if topic is not None and (not isinstance(topic, str) or not topic.strip()):
        raise InputError(f"topic must be a topic name such as '/joint_states'; got {topic!r}.")
    reader = _open(path)
    try:
        topic, connections = _connections(path, reader, topic)
        columns, stamps, names = _read_messages(path, reader, connections, topic)
    finally:
        reader.close()
    variables = {"t": _Var("t", stamps, "ns", size=stamps.size)}
    for field, values in columns.items():
        for j, name in enumerate(names):
            key = f"{field}.{name}"
            variables[key] = _Var(key, values[:, j], "", size=stamps.size)
    joint_map = _joint_map(path, topic, names, columns, joint_names, set(mapped))
    metadata = {"topic": topic, "bag_joint_names": list(names), "joint_map": joint_map}
    return _Source(variables, metadata)


def _read_messages(path, reader, connections, topic):
    """(field → (n_messages, n_joints) array, stamps [ns] int64, joint names of the first)."""
    count = sum(int(c.msgcount) for c in connections)
    if count < 2:
        raise DataFileError(
            f"{path}: topic {topic!r} holds {count} message(s); physid needs at least 2."
        )
    first = None
    rows: dict[str, list] = {f: [] for f, _ in _FIELDS}
    stamps = []
    for connection, logtime, raw in reader.messages(connections=connections):
        msg = reader.deserialize(raw, connection.msgtype)
        names = tuple(msg.name)
        if first is None:
            first = names
            width = len(first)
            check_memory(
                8.0 * count * (3 * width + 1) * 3,
                what=f"reading topic {topic!r} of {path} ({count} messages of {width} joints)",
                fix="split the bag (ros2 bag convert / rosbag filter) into shorter runs",
            )
            index = np.arange(width)
        elif names != first:
            if sorted(names) != sorted(first):
                raise DataFileError(
                    f"{path}: topic {topic!r} changes its joints from {list(first)} to "
                    f"{list(names)} at message {len(stamps)}; physid reads one set of joints."
                )
            index = np.array([names.index(n) for n in first])
        else:
            index = np.arange(len(first))
        stamps.append(_stamp(msg, logtime))
        for field, _ in _FIELDS:
            values = np.asarray(getattr(msg, field), dtype=float)
            rows[field].append(values[index] if values.size == len(first) else None)
    columns = {
        field: np.vstack(values) for field, values in rows.items()
        if all(v is not None for v in values)
    }  # fmt: skip
    return columns, np.asarray(stamps, dtype=np.int64), first


def _joint_map(path, topic, names, columns, joint_names, mapped) -> dict:
    """``q<j>/qd<j>/tau<j>`` → ``position.<name>`` ... for the model's joints, by name."""
    if not joint_names:
        return {}
    out = {}
    missing = []
    for j, name in enumerate(joint_names, start=1):
        if name not in names:
            if f"q{j}" not in mapped:
                missing.append(name)
            continue
        for field, stem in _FIELDS:
            if field in columns:
                out[f"{stem}{j}"] = f"{field}.{name}"
    if missing:
        raise DataFileError(
            f"{path}: the model's joint(s) {missing} are not in topic {topic!r}, whose joints are "
            f"{list(names)}; rename them in the model, or map them, e.g. "
            f"channels={{'q1': 'position.{names[0]}'}}."
        )
    return out
