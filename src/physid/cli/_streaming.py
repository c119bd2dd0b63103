"""``identify --stream``: whether a record is fitted in blocks, and the block sources it reads.

An IDIM fit in memory holds the full-rate regressor of the whole record (about
``n_samples × n_joints × n_base × 8`` bytes, three times over while the parallel filter runs);
a streamed fit (`physid.estimators.idim.stream.fit_streamed`) holds a few blocks and the
accumulated normal equations, whatever the length, and gives the same estimate. ``--stream
auto`` (the default) streams when the in-memory fit would need more than 2 GiB or a quarter
of the available memory (`physid.estimators.idim.stream.streams_better`; a ROS bag's samples
are its index's message count, as for ``estimate`` and fleets), and the fit is one that
streams (IDIM-OLS or -WLS, files that can be read in blocks); ``on`` streams whenever it can
(and says why when it cannot); ``off`` never streams.
"""

from __future__ import annotations

from ._common import progress

__all__ = ["add_stream_options", "wants_stream", "open_sources"]


def add_stream_options(group, fits: str) -> None:
    """``--stream`` and ``--block-samples`` in a verb's option group.

    Parameters
    ----------
    group : argparse group or parser
    fits : str
        The fits that stream, for the help (e.g. ``"idim-ols and idim-wls"``).
    """
    group.add_argument(
        "--stream",
        choices=("auto", "on", "off"),
        default="auto",
        help=f"fit a long record block by block in bounded memory, with the same estimate as "
        f"in memory ({fits}): auto = when the in-memory fit would need more than 2 GiB or a "
        "quarter of the free memory (default: auto)",
    )
    group.add_argument(
        "--block-samples",
        type=int,
        default=65536,
        metavar="N",
        help="samples read at a time by a streamed fit (default: 65536)",
    )


def _why_not(args, paths, method: str) -> str | None:
    """Why these settings cannot stream (`stream_obstacle`, shown in the command line's
    words), or None."""
    from ..errors import InputError
    from ..estimators.idim.stream import stream_obstacle

    why = stream_obstacle(
        method,
        paths,
        stderr=getattr(args, "stderr", "filtered"),
        consistent=getattr(args, "consistent", False),
        resample=getattr(args, "resample", False),
        join=getattr(args, "join", False),
        detrend=getattr(args, "detrend", None),
        joints=getattr(args, "joints", None),
        torque=getattr(args, "torque", "measured"),
        topic=getattr(args, "topic", None),
    )
    return None if why is None else InputError(why).render(getattr(args, "argument_flags", None))


def wants_stream(args, paths, model, method: str) -> bool:
    """Whether ``identify`` fits these files block by block (``--stream``); says so on stderr.

    Raises
    ------
    InputError
        ``--stream on`` with settings that cannot stream (the reason and the fix).
    """
    from .._resources import format_bytes
    from ..errors import DataFileError, InputError
    from ..estimators.idim.stream import streams_better

    choice = getattr(args, "stream", "auto")
    block = getattr(args, "block_samples", 65536)
    if block is None or block < 2:
        raise InputError(f"--block-samples must be an integer of at least 2; got {block!r}.")
    if choice == "off":
        return False
    why = _why_not(args, paths, method)
    if choice == "on":
        if why is not None:
            raise InputError(
                f"--stream on cannot stream this fit: {why}. Leave --stream out (or --stream "
                "off) to fit in memory."
            )
        return True
    if why is not None:
        return False
    try:  # a bag by its index's message count: the rule of estimate and fleets
        stream, peak, limit = streams_better(paths, model, topic=getattr(args, "topic", None))
    except DataFileError:
        return False  # the in-memory read says what is wrong with the file
    if not stream:
        return False
    progress(
        f"physid: note: fitting block by block (--stream auto): in memory the fit would need "
        f"about {format_bytes(peak)}, above {format_bytes(limit)}; the estimate is the same "
        "(--stream off to fit in memory)"
    )
    return True


def open_sources(args, paths, model) -> list:
    """The block sources of ``paths`` with the verb's reading options and the model's checks.

    The channel map (``--map`` over the model file's ``[recording]`` table), ``--rate``,
    ``--decimal``, ``--delimiter`` apply as when the file is read whole; motor-side channels are
    converted through the model's transmission block by block; the units are checked against
    the model on the first block.
    """
    from ..errors import PhysidError
    from ..signals.io import open_blocks, parse_channel_map
    from ..signals.joint_side import joint_side_blocks
    from ._recordings import (
        _model_channel_map,
        _reworded,
        _table_name,
        _warn_implausible_data,
        check_recording_units,
    )

    sources = []
    try:
        table = _model_channel_map(args, model)
        channels = parse_channel_map(getattr(args, "channel_map", None)) or None
        for p in paths:
            src = open_blocks(
                p,
                channels,
                rate=getattr(args, "rate", None),
                channel_defaults=table or None,
                channel_defaults_source=_table_name(args),
                decimal=getattr(args, "decimal", ".") or ".",
                delimiter=getattr(args, "delimiter", None),
                uniform_rtol=1e-3,  # as a whole file is read by the command line
                topic=getattr(args, "topic", None),  # a ROS bag's, matched to the model's joints
                joint_names=getattr(model, "joint_names", None),
            )
            src = joint_side_blocks(model, src)  # motor-side channels, block by block
            first = next(iter(src.blocks(min(src.n_samples, 4096))))
            check_recording_units(model, first)
            _warn_implausible_data(model, first)
            sources.append(src)
    except PhysidError as exc:
        for s in sources:
            getattr(s, "close", lambda: None)()
        raise _reworded(exc) from None
    return sources
