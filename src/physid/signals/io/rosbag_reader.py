"""ROS bags: ``sensor_msgs/JointState``, ``control_msgs/JointTrajectoryControllerState`` and
``std_msgs/Float64MultiArray`` messages of ROS 1 (``.bag``) and ROS 2 (MCAP or sqlite3) bags,
read with
`rosbags <https://gitlab.com/ternaris/rosbags>`_ (pure Python, optional:
``pip install "physid[ros]"``).

Each joint of the messages becomes the variables ``position.<joint>``, ``velocity.<joint>`` and
``effort.<joint>`` (those the messages fill), the time ``t`` is ``header.stamp`` in integer
nanoseconds (the bag's receive time where the stamp is unset), kept exact. Given the model's
joint names, the joints are matched **by name** (in any order in the bag) and a channel map
``q<j> = position.<name>``, ``qd<j> = velocity.<name>``, ``tau<j> = effort.<name>`` is made, so a
bag whose names match the URDF needs no map at all.

A ``Float64MultiArray`` (or ``Float32MultiArray``) topic, as ros2_control's effort and
forward-command controllers publish and many drivers log currents, carries values without joint
names, in an order the controller's configuration sets. Its values become ``<label>.data1`` …
``<label>.data<n>`` (``data[0]`` is ``data1``; ``<label>`` is the topic without its leading
slash, ``/`` read as ``.``), timed by the bag's receive time (the message has no header), and
are never assigned to joints by guess: the channel map says which is which
(``tau1 = effort_controller.commands.data2``), which is where the joint order is stated.

A ``control_msgs/JointTrajectoryControllerState`` topic (its definition is read from the bag)
names its joints: each filled array becomes ``<point>.<array>.<joint>``
(``feedback.positions.shoulder``), and by name ``q, q̇, τ`` come from the measured point
(``feedback``, else ``actual``) and the references ``r`` from the commanded one (``reference``,
else ``desired``).

Several topics of one run (``topic="/joint_states,/effort_controller/commands"``) are joined on
their stamps onto one uniform grid by `physid.signals.join_recordings`, exactly as the
equivalent files with ``--join``; a gap that would split the run is refused, naming it.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import chain, islice
from pathlib import Path
from typing import Any

import numpy as np

from ..._resources import check_memory
from ...errors import DataFileError, InputError, MissingDependencyError
from .variables import _Source, _Var

__all__ = ["is_rosbag", "read_rosbag", "ROSBAG_SUFFIXES"]

#: File suffixes read as ROS bags (a ROS 2 bag may also be given as its folder).
ROSBAG_SUFFIXES = (".bag", ".mcap", ".db3")

_JOINT_STATE = ("sensor_msgs/msg/JointState", "sensor_msgs/JointState")
_ARRAY = tuple(
    f"std_msgs{sep}{kind}MultiArray" for kind in ("Float64", "Float32") for sep in ("/msg/", "/")
)
_READABLE = (
    "sensor_msgs/JointState, control_msgs/JointTrajectoryControllerState, "
    "std_msgs/Float64MultiArray or std_msgs/Float32MultiArray"
)
_FIELDS = (("position", "q"), ("velocity", "qd"), ("effort", "tau"))
_TRAJECTORY_STATE = (
    "control_msgs/msg/JointTrajectoryControllerState",
    "control_msgs/JointTrajectoryControllerState",
)
_NAMED = _JOINT_STATE + _TRAJECTORY_STATE  # messages that name their joints
#: JointTrajectoryControllerState's points (ROS 2 Humble adds reference/feedback/output to
#: ROS 1's desired/actual/error) and their arrays.
_POINTS = ("reference", "feedback", "output", "desired", "actual", "error")
_ARRAYS = ("positions", "velocities", "accelerations", "effort")


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


def _topic_list(topic) -> list[str] | None:
    """``topic`` as a list of names (a comma-separated string gives several); None: default."""
    if topic is None:
        return None
    names = [t.strip() for t in topic.split(",")] if isinstance(topic, str) else []
    if not names or not all(names):
        raise InputError(
            f"topic must be a topic name such as '/joint_states', or several separated by "
            f"commas ('/joint_states,/effort_controller/commands'); got {topic!r}."
        )
    if len(set(names)) < len(names):
        raise InputError(f"topic names a topic twice: {topic!r}; give each once.")
    return names


def _connections(path, reader, topics):
    """``[(topic, connections)]`` of the topics to read (``topics`` or the only JointState)."""
    found = sorted({(c.topic, c.msgtype) for c in reader.connections})
    listed = ", ".join(f"{t} ({m})" for t, m in found) or "none"
    states = sorted({t for t, m in found if m in _JOINT_STATE})
    if topics is None:
        if len(states) != 1:
            which = "no sensor_msgs/JointState topic" if not states else (
                f"{len(states)} sensor_msgs/JointState topics"
            )  # fmt: skip
            raise DataFileError(
                f"{path}: the bag has {which}; its topics are {listed}. Choose one with "
                f"topic='{states[0] if states else '/joint_states'}'."
            )
        topics = states[:1]
    out = []
    for topic in topics:
        chosen = [c for c in reader.connections if c.topic == topic]
        if not chosen:
            raise DataFileError(
                f"{path}: the bag has no topic {topic!r}; its topics are {listed}. Choose one "
                f"of them with topic=."
            )
        if chosen[0].msgtype not in _NAMED + _ARRAY:
            readable = [t for t, m in found if m in _NAMED + _ARRAY]
            raise DataFileError(
                f"{path}: topic {topic!r} carries {chosen[0].msgtype}, not {_READABLE}; physid "
                f"reads those ({', '.join(readable) or 'none in this bag'})."
            )
        out.append((topic, chosen))
    return out


def _stamp(msg, logtime: int) -> int:
    """``header.stamp`` in integer ns (ROS 1 and 2 field names); the log time where unset."""
    stamp = msg.header.stamp
    sec = getattr(stamp, "sec", getattr(stamp, "secs", 0))
    nsec = getattr(stamp, "nanosec", getattr(stamp, "nsecs", 0))
    value = int(sec) * 1_000_000_000 + int(nsec)
    return value if value > 0 else int(logtime)


def read_rosbag(path, *, topic=None, joint_names=None, mapped=()) -> _Source:
    """The messages of one topic, or of several joined, as variables (see the module's docstring).

    Parameters
    ----------
    path : str or Path
        A ``.bag`` (ROS 1), ``.mcap`` or ``.db3`` file, or a ROS 2 bag folder.
    topic : str, optional
        The topic to read (JointState or Float64/Float32MultiArray), or several separated by
        commas, joined on their stamps; default the bag's only JointState topic.
    joint_names : sequence of str, optional
        The model's joints, in its order (q1 is the first).
    mapped : collection of str
        Channels the caller maps itself (a model joint missing from the bag is then no error).

    Returns
    -------
    _Source
        Variables ``t`` (one topic: [ns] int64; several: the joined grid [s]) and
        ``position.<joint>``, ``<label>.data<k>`` etc.; metadata ``topic``, ``bag_joint_names``,
        ``joint_map`` (the channel map by name) and, for several topics, ``bag_join`` (the
        grid, the jitter).

    Raises
    ------
    DataFileError
        Not a bag, no such topic (the message lists the bag's topics), a topic of another
        type, a model joint not in the messages (the message lists the bag's joint names),
        messages without samples, topics whose times do not overlap or that have a gap.
    InputError
        The bag does not fit in memory (the message gives the size); a bad ``topic``.
    MissingDependencyError
        rosbags is not installed.
    """
    path = Path(path)
    topics = _topic_list(topic)
    reader = _open(path)
    try:
        parts = [
            _read_topic(path, reader, name, connections)
            for name, connections in _connections(path, reader, topics)
        ]
    finally:
        reader.close()
    names = [n for p in parts if p.joints is not None for n in p.joints]
    fields = [p for p in parts if p.joints is not None]
    joint_map = _joint_map(path, [p.topic for p in parts], fields, joint_names, set(mapped))
    metadata = {
        "topic": ",".join(p.topic for p in parts),
        "bag_joint_names": list(dict.fromkeys(names)),
        "joint_map": joint_map,
    }
    if len(parts) == 1:
        return _topic_source(parts[0], metadata)
    grid, columns, notes = _join_topics(path, parts)
    variables = {"t": _Var("t", grid, "s", size=grid.size)}
    variables.update({k: _Var(k, v, "", size=grid.size) for k, v in columns.items()})
    metadata["bag_join"] = notes
    return _Source(variables, metadata)


def _topic_source(part, metadata: dict) -> _Source:
    """The `_Source` of one topic's messages: ``t`` the stamps [ns] (int64, exact), its values."""
    stamps = part.stamps
    variables = {"t": _Var("t", stamps, "ns", size=stamps.size)}
    variables.update({k: _Var(k, v, "", size=stamps.size) for k, v in part.values.items()})
    return _Source(variables, dict(metadata))


@dataclass
class _Topic:
    """One topic's messages: stamps [ns] (int64), variables, and its joints (JointState)."""

    topic: str
    stamps: np.ndarray
    values: dict  # variable name -> (n_messages,) float
    joints: tuple | None = None  # the joint names; None for an array topic
    sources: dict | None = None  # channel stem (q, qd, tau, r) -> variable prefix, by name


def _sources(columns) -> dict:
    """Which filled fields give ``q, qd, tau`` (and ``r``) of the joints, by name.

    JointState: position, velocity, effort. JointTrajectoryControllerState: the measured point
    (``feedback``, else ``actual``) for q, q̇ and τ, and the commanded one (``reference``, else
    ``desired``) positions for the references r that IDIM-IV needs.
    """
    if "position" in columns or "velocity" in columns or "effort" in columns:
        return {stem: field for field, stem in _FIELDS if field in columns}
    out = {}
    for stem, array, points in (
        ("q", "positions", ("feedback", "actual")),
        ("qd", "velocities", ("feedback", "actual")),
        ("tau", "effort", ("feedback", "actual")),
        ("r", "positions", ("reference", "desired")),
    ):
        filled = [f"{pt}.{array}" for pt in points if f"{pt}.{array}" in columns]
        if filled:
            out[stem] = filled[0]
    return out


def _fields_of(msg) -> tuple[tuple, dict]:
    """(joint names, field -> values) of a JointState or JointTrajectoryControllerState."""
    if hasattr(msg, "name"):
        return tuple(msg.name), {f: getattr(msg, f) for f, _ in _FIELDS}
    fields = {}
    for point in _POINTS:
        value = getattr(msg, point, None)
        if value is not None:
            fields.update({f"{point}.{a}": getattr(value, a) for a in _ARRAYS})
    return tuple(msg.joint_names), fields


def _label(topic: str) -> str:
    """``/effort_controller/commands`` -> ``effort_controller.commands``."""
    return topic.strip("/").replace("/", ".") or "topic"


def _join_topics(path, parts):
    """Several topics of one run on one uniform grid (`physid.signals.join_recordings`).

    Each topic becomes a `Recording` timed exactly as `load_recording` times a file of integer
    nanosecond stamps (``(stamp − first) · 1e-9`` with the first stamp as ``time_origin``), so
    the joined bag equals the same topics exported to files and read with ``--join``.
    """
    from ..join import join_recordings
    from ..recording import Recording

    recs, labels = [], []
    seen: dict[str, int] = {}
    for part in parts:
        order = np.argsort(part.stamps, kind="stable")
        stamps = part.stamps[order]
        names = list(part.values)
        for n in names:
            seen[n] = seen.get(n, 0) + 1
        recs.append(
            Recording(
                (stamps - stamps[0]).astype(float) * 1e-9,
                np.column_stack([part.values[n][order] for n in names]),
                names,
                metadata={
                    "time_origin": {"first_stamp": int(stamps[0]), "unit": "ns"},
                    "source": f"{path}:{part.topic}",
                },
            )
        )
        labels.append(_label(part.topic))
    twice = sorted(n for n, c in seen.items() if c > 1)
    if twice:
        raise DataFileError(
            f"{path}: the topics {', '.join(p.topic for p in parts)} all carry {twice}; read "
            "one of them, or read them one at a time."
        )
    run = join_recordings(recs, labels)
    if len(run.segments) > 1:
        raise DataFileError(
            f"{path}: the topics of the run have gaps: {' '.join(run.notes[1:])}. Export the "
            "topics to files and join them (each segment then a separate experiment), or read "
            "one topic."
        )
    seg = run.segments[0]
    notes = [n.replace("files", "topics").replace("a file's", "a topic's") for n in run.notes]
    return seg.t, {n: seg[n] for n in seg.names}, notes


def _messages(path, reader, connections):
    """``(connection, logtime, raw)`` of the connections' messages, lazily, in the bag's order;
    a damaged bag's failure midway is a `DataFileError` (the whole read and the blocks alike)."""
    items = reader.messages(connections=connections)
    while True:
        try:
            item = next(items)
        except StopIteration:
            return
        except Exception as exc:  # rosbags raises its own classes for damaged chunks
            raise DataFileError(
                f"{path}: the bag is damaged: reading its messages failed ({type(exc).__name__}: "
                f"{exc}); repair it (rosbag reindex, ros2 bag reindex) or export the topics."
            ) from None
        yield item


def _check_count(path, topic, count: int) -> None:
    if count < 2:
        raise DataFileError(
            f"{path}: topic {topic!r} holds {count} message(s); physid needs at least 2."
        )


def _deserialize(path, reader, connection, raw, topic, k: int):
    try:
        return reader.deserialize(raw, connection.msgtype)
    except Exception as exc:  # a truncated or foreign message
        raise DataFileError(
            f"{path}: message {k} of topic {topic!r} cannot be decoded as "
            f"{connection.msgtype} ({type(exc).__name__}: {exc}); the bag is damaged."
        ) from None


@dataclass
class _Decoder:
    """Decodes a topic's messages batch by batch, the first message fixing the joints (named
    messages) or the width (arrays); ``seen`` counts the messages decoded so far."""

    path: Any
    topic: str
    named: bool
    first: tuple | None = None  # the joint names of the first message (named messages)
    width: int | None = None  # values per message (arrays)
    seen: int = 0

    def decode(self, reader, items) -> tuple[dict, np.ndarray]:
        """``(columns, stamps [ns] int64)`` of the messages ``items``; ``columns``: field ->
        (m, n_joints) float array (None for a field some of them leave empty) or, for arrays,
        ``{"data": (m, width)}``."""
        if not self.named:
            return self._arrays(reader, items)
        rows: dict[str, list] = {}
        stamps = []
        for connection, logtime, raw in items:
            msg = _deserialize(self.path, reader, connection, raw, self.topic, self.seen)
            names, fields = _fields_of(msg)
            if self.first is None:
                self.first = names
            if names == self.first:
                index = None
            elif sorted(names) == sorted(self.first):
                index = np.array([names.index(n) for n in self.first])
            else:
                raise DataFileError(
                    f"{self.path}: topic {self.topic!r} changes its joints from "
                    f"{list(self.first)} to {list(names)} at message {self.seen}; physid reads "
                    "one set of joints."
                )
            stamps.append(_stamp(msg, logtime))
            for field, raw_values in fields.items():
                values = np.asarray(raw_values, dtype=float)
                full = values.size == len(self.first)
                row = (values if index is None else values[index]) if full else None
                rows.setdefault(field, []).append(row)
            self.seen += 1
        columns = {
            field: np.vstack(values) if all(v is not None for v in values) else None
            for field, values in rows.items()
        }  # fmt: skip
        return columns, np.asarray(stamps, dtype=np.int64)

    def _arrays(self, reader, items) -> tuple[dict, np.ndarray]:
        rows, stamps = [], []
        for connection, logtime, raw in items:
            msg = _deserialize(self.path, reader, connection, raw, self.topic, self.seen)
            values = np.asarray(msg.data, dtype=float)
            if self.width is None:
                self.width = values.size
            if values.size != self.width or self.width == 0:
                raise DataFileError(
                    f"{self.path}: topic {self.topic!r} has {self.width} values in its first "
                    f"message and {values.size} in message {self.seen + 1}; physid reads "
                    "arrays of one length (one value per joint)."
                )
            rows.append(values)
            stamps.append(int(logtime))  # no header: the bag's receive time
            self.seen += 1
        data = np.vstack(rows) if rows else np.zeros((0, self.width or 0))
        return {"data": data}, np.asarray(stamps, dtype=np.int64)

    def topic_of(self, columns, stamps) -> _Topic:
        """The `_Topic` of decoded columns (fields every message fills; arrays by index)."""
        if not self.named:
            label = _label(self.topic)
            data = columns["data"]
            values = {f"{label}.data{k + 1}": data[:, k] for k in range(data.shape[1])}
            return _Topic(self.topic, stamps, values)
        filled = {f: v for f, v in columns.items() if v is not None}
        values = {
            f"{field}.{name}": v[:, j]
            for field, v in filled.items()
            for j, name in enumerate(self.first)
        }  # fmt: skip
        return _Topic(self.topic, stamps, values, tuple(self.first), _sources(filled))


def read_bytes(count: int, width: int) -> int:
    """Bytes the whole read of ``count`` messages of ``width`` values takes: about three
    float64 copies of each value and of the stamp (the rows, the stacked arrays, the record)."""
    return 8 * int(count) * (int(width) + 1) * 3


def _head_width(path, reader, topic, connections) -> tuple:
    """Values per message of a topic from its first message: ``(width, what, decoder, head,
    items)``, ``items`` the messages after ``head`` (a JointState's joints times its filled
    fields; an array's length)."""
    decoder = _Decoder(path, topic, connections[0].msgtype in _NAMED)
    items = _messages(path, reader, connections)
    head = list(islice(items, 1))
    columns, _ = decoder.decode(reader, head)
    if decoder.named and decoder.first is None:  # an index counting messages the bag lacks
        return 0, "0 joints", decoder, head, items
    if decoder.named:
        width = len(decoder.first) * sum(v is not None for v in columns.values())
        return width, f"{len(decoder.first)} joints", decoder, head, items
    return decoder.width or 0, f"{decoder.width or 0} values", decoder, head, items


def bag_extent(path, topic=None, *, width: bool = True) -> tuple[int, int]:
    """``(messages, values per message)`` of the topic(s) a bag is read from, from its index
    (rosbags' connections' ``msgcount``: a ROS 1 bag's index, a ROS 2 bag's metadata.yaml) and
    its first message, without reading the rest (``width=False``: the index alone, no message
    decoded, the values given as 0).

    Several topics (joined on their stamps): the most messages of one topic, the values of all.

    Raises
    ------
    DataFileError
        As `read_rosbag` (no such topic, several JointState topics and none chosen, ...).
    """
    path = Path(path)
    reader = _open(path)
    try:
        count, values = 0, 0
        for name, connections in _connections(path, reader, _topic_list(topic)):
            n = sum(int(c.msgcount) for c in connections)
            _check_count(path, name, n)  # before the first message's width: there may be none
            count = max(count, n)
            values += _head_width(path, reader, name, connections)[0] if width else 0
        return count, values
    finally:
        reader.close()


def _read_topic(path, reader, topic, connections) -> _Topic:
    """The messages of one topic as a `_Topic` (JointState by joint, arrays by index)."""
    count = sum(int(c.msgcount) for c in connections)
    _check_count(path, topic, count)
    width, what, decoder, head, items = _head_width(path, reader, topic, connections)
    check_memory(
        read_bytes(count, width),
        what=f"reading topic {topic!r} of {path} ({count} messages of {what})",
        fix="split the bag (ros2 bag convert / rosbag filter) into shorter runs",
    )
    decoder.seen = 0
    columns, stamps = decoder.decode(reader, chain(head, items))
    return decoder.topic_of(columns, stamps)


def _joint_map(path, topics, parts, joint_names, mapped) -> dict:
    """``q<j>/qd<j>/tau<j>`` (``r<j>``) → ``position.<name>`` ... for the model's joints, by
    name, from the topics that name their joints (the first that fills a field gives it)."""
    if not joint_names or not parts:
        return {}
    out: dict[str, str] = {}
    missing = []
    for j, name in enumerate(joint_names, start=1):
        having = [p for p in parts if name in p.joints]
        if not having:
            if f"q{j}" not in mapped:
                missing.append(name)
            continue
        for stem in ("q", "qd", "tau", "r"):
            for p in having:
                if stem in p.sources and f"{stem}{j}" not in out:
                    out[f"{stem}{j}"] = f"{p.sources[stem]}.{name}"
    if missing:
        names = list(dict.fromkeys(n for p in parts for n in p.joints))
        where = f"topic {topics[0]!r}" if len(topics) == 1 else f"topics {', '.join(topics)}"
        raise DataFileError(
            f"{path}: the model's joint(s) {missing} are not in {where}, whose joints are "
            f"{names}; rename them in the model, or map them, e.g. "
            f"channels={{'q1': 'position.{names[0]}'}}."
        )
    return out
