"""ROS bags read block by block (`open_blocks`): one topic's messages, decoded a block at a time.

`rosbags`' ``AnyReader`` hands the messages over one at a time, lazily, in the bag's order; a
pass keeps the raw messages of one block, decodes them with the whole-bag reader's decoder
(`rosbag_reader._Decoder`: JointState and JointTrajectoryControllerState by joint name,
Float64/Float32MultiArray by index) and gives their variables as `read_rosbag` would (``t`` the
``header.stamp`` in integer nanoseconds, exact; ``position.<joint>`` …), so that `_assemble`
and `FileBlocks` make of them what `load_recording` makes of the bag, with the same checks of
time (a stamp not increasing, a gap) at the record's own sample.

Opening the bag scans the topic once without decoding it (the messages counted, the first two
and the last two kept), which gives the record's length, its first and last stamps, the joints
and the channel map by name. Memory of one block of ``size`` messages: the raw messages
(``size × message bytes``; a 7-joint JointState is about 240 bytes), each decoded into a few
small arrays, and the block's channels, whatever the bag's length: measured (tracemalloc), about
2 kB per message of a 7-joint JointState, a 10 MB peak for blocks of 5000 of a bag of 20 000 or
80 000 messages alike (130 MB for the command line's 65 536-sample blocks). `FileBlocks.blocks`
checks the block against the memory available (`_Layout.row_bytes`).

Several topics joined on their stamps (``topic="/joint_states,/effort_controller/commands"``)
are interpolated onto one grid of the whole run (`physid.signals.join_recordings`): that is not
read in blocks, and is refused with the fix.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections import deque
from collections.abc import Iterator
from itertools import islice
from pathlib import Path

from ..._resources import format_bytes
from ...errors import DataFileError
from .rosbag_reader import (
    _NAMED,
    _check_count,
    _connections,
    _Decoder,
    _joint_map,
    _messages,
    _open,
    _topic_list,
    _topic_source,
    read_bytes,
)
from .variables import _Source

__all__: list[str] = []


class _Layout:
    """Bytes one message takes while a block is read (for `FileBlocks`' memory check)."""

    def __init__(self, raw_bytes: int, n_values: int):
        self.raw_bytes, self.n_values = raw_bytes, n_values

    def row_bytes(self) -> int:
        # the raw message, the Python objects of its decoding (about 1 kB: its small arrays,
        # measured), and about three float64 copies of each value and of the stamp (the rows,
        # the stacked arrays, the block's channels)
        return int(self.raw_bytes + 1024 + 3 * 8 * (self.n_values + 1))


class _BagBlocks:
    """One topic of a ROS bag, a block of messages at a time (the bag reopened for each pass).

    Parameters
    ----------
    path : Path
    topic : str or None
        As `read_rosbag` (several topics are refused here, with the fix).
    joint_names : sequence of str or None
        The model's joints: matched by name to the messages' (``joint_map``).
    mapped : collection of str
        Channels the caller maps itself.
    """

    how = "message by message (rosbags AnyReader), decoded a block at a time; one topic"

    @property
    def time_hint(self) -> str:
        """Added to a time error of jitter (a step off by under half a period, or a drift),
        not to a lost message's gap: the whole read's fix, and the memory it takes."""
        need = format_bytes(read_bytes(self.n, self.layout.n_values))
        return (
            f"load_recording(..., resample=True) reads it whole and resamples it onto its mean "
            f"period, in memory (about {need} for its {self.n} messages, and the fit's arrays); "
            "where the memory is short of that, split the bag into shorter runs (rosbag filter, "
            "ros2 bag convert)."
        )

    def __init__(self, path: Path, topic, joint_names, mapped):
        self.path = path
        topics = _topic_list(topic)
        reader = _open(path)
        try:
            chosen = _connections(path, reader, topics)
            if len(chosen) > 1:
                names = ", ".join(t for t, _ in chosen)
                raise DataFileError(
                    f"{path}: the topics {names} are joined on their stamps by interpolation "
                    "onto one grid of the whole run, which is not read in blocks; fit the bag in "
                    "memory (load_recording with topic=...), or read one "
                    "topic in blocks (topic='/joint_states' with the torques in its effort)."
                )
            self.topic, self.connections = chosen[0]
            self._scan(reader)
        finally:
            reader.close()
        part = self._decoder.topic_of(*self._head)
        self.joint_map = _joint_map(
            path, [self.topic], [part] if part.joints is not None else [], joint_names, mapped
        )
        self.metadata = {
            "topic": self.topic,
            "bag_joint_names": list(part.joints or ()),
        }
        self.layout = _Layout(self._raw_bytes, len(part.values))

    def _scan(self, reader) -> None:
        """Count the messages (not decoded), decode the first two and the last two."""
        named = self.connections[0].msgtype in _NAMED
        self._decoder = _Decoder(self.path, self.topic, named)
        head, tail = [], deque(maxlen=2)
        n, biggest = 0, 0
        for item in _messages(self.path, reader, self.connections):
            if n < 2:
                head.append(item)
            tail.append(item)
            biggest = max(biggest, len(item[2]))
            n += 1
        _check_count(self.path, self.topic, n)
        self.n, self._raw_bytes = n, biggest
        self._head = self._decoder.decode(reader, head)
        self._fields = {f for f, v in self._head[0].items() if v is not None}
        ends = dataclasses.replace(self._decoder, seen=n - 2)  # its joints and width
        try:
            self._tail = ends.decode(reader, list(tail))
        except DataFileError:
            self._first_bad(reader)  # the whole read's error, at its message
            raise

    def _first_bad(self, reader) -> None:
        """Decode the topic forward, a batch at a time, to the message whose joints (or array
        length) differ from the first's: raises the whole read's error, which names it."""
        decoder = _Decoder(self.path, self.topic, self._decoder.named)
        items = _messages(self.path, reader, self.connections)
        while batch := list(islice(items, 4096)):
            decoder.decode(reader, batch)

    def _source(self, columns, stamps, a: int) -> _Source:
        """The `_Source` of decoded messages ``a ..``: the fields the first messages fill (a
        field they leave empty is dropped, as the whole read drops it, even where later
        messages fill it)."""
        filled = {f for f, v in columns.items() if v is not None}
        if self._decoder.named:
            lost = sorted(self._fields - filled)
            if lost:
                torque = (
                    " (and with effort the torques: take them from another topic, "
                    "topic='/joint_states,/TORQUES')"
                    if "effort" in lost
                    else ""
                )
                raise DataFileError(
                    f"{self.path}: topic {self.topic!r} fills {lost} in its first messages but "
                    f"leaves it empty in some message of samples {a}..{a + stamps.size - 1}; "
                    "read in blocks, a field the first messages fill must be filled in every "
                    f"message: fill {' and '.join(lost)} in every message. Or read the bag whole "
                    f"(load_recording), which drops such a field{torque}."
                )
            columns = {f: v for f, v in columns.items() if f in self._fields}
        return _topic_source(self._decoder.topic_of(columns, stamps), self.metadata)

    def probe(self, a: int, b: int) -> _Source:
        """The first rows or the last ones (up to 2), decoded by the scan."""
        columns, stamps = self._head if a == 0 else self._tail
        keep = slice(0, b - a) if a == 0 else slice(stamps.size - (b - a), None)
        cut = {f: (v[keep] if v is not None else None) for f, v in columns.items()}
        return self._source(cut, stamps[keep], a)

    @contextlib.contextmanager
    def reading(self) -> Iterator:
        """One pass, forward: ``read(a, b)`` gives the `_Source` of messages ``a:b``."""
        reader = _open(self.path)
        try:
            # the connections of this reader (those of the scan's reader select nothing here)
            connections = [c for c in reader.connections if c.topic == self.topic]
            items = _messages(self.path, reader, connections)
            decoder = dataclasses.replace(self._decoder, seen=0)  # the scan's joints and width
            state = {"pos": 0}

            def read(a, b):
                if a < state["pos"]:
                    raise DataFileError(
                        f"{self.path}: messages {a}..{b} asked after {state['pos']}."
                    )
                for _ in islice(items, a - state["pos"]):  # skipped, not decoded
                    decoder.seen += 1
                batch = list(islice(items, b - a))
                state["pos"] = b
                if len(batch) != b - a:
                    raise _changed(self.path, f"it has fewer than the {self.n} messages counted")
                return self._source(*decoder.decode(reader, batch), a)

            yield read
            if state["pos"] == self.n and next(items, None) is not None:
                raise _changed(self.path, f"it has more than the {self.n} messages counted")
        finally:
            reader.close()


def _changed(path, what: str) -> DataFileError:
    return DataFileError(
        f"{path}: the bag changed while it was read in blocks ({what}); a bag that is still "
        "being recorded cannot be read in blocks. Open it again once it is complete."
    )
