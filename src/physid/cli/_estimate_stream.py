"""``estimate --stream``: whether a linear-ODE fit reads its record in blocks, and the source.

The in-memory fits hold the recording and several per-sample arrays: measured peaks (tracemalloc,
the MSD, 2e5 and 8e5 samples) of about 350 bytes per sample for ``--method rls`` and 540 for
``--method algebraic``; their block fits (`physid.estimators.recursive.fit_blocks`,
`physid.estimators.algebraic.fit_blocks`) hold a block and a few sums whatever the length, with
the same estimate, standard errors and verdict. ``--stream auto`` (the default) streams when the
in-memory fit would need more than `physid._resources.stream_limit` (2 GiB, or a quarter of
the available memory: about 6 million samples, 1.7 hours at 1 kHz, for rls) and the settings
stream: below that the in-memory fit is faster (one pass instead of three) and keeps the full
histories. A ROS bag's samples are its index's message count (`physid.signals.io.
in_memory_samples`, the rule of ``identify`` and fleets): a bag below the limit is read whole
once, not scanned first. ``on`` streams whenever it can (and says why not otherwise); ``off``
never streams.
"""

from __future__ import annotations

from ..errors import InputError, PhysidError
from ._common import progress

__all__ = ["block_source", "BYTES_PER_SAMPLE"]

#: Measured peak of the in-memory fit per sample [bytes] (with a margin), by method.
BYTES_PER_SAMPLE = {"rls": 400, "algebraic": 600}


def _why_not(args, method: str) -> str | None:
    """Why these settings cannot stream (in the command line's words), or None."""
    if method not in BYTES_PER_SAMPLE:
        return f"--method {method} fits the record in memory only"
    if method == "algebraic" and (args.final or "lstsq") != "bias-compensated":
        return (
            f"--final {args.final or 'lstsq'} needs every window's estimate at once (a median); "
            "--final bias-compensated streams"
        )
    if getattr(args, "resample", False):
        return "--resample interpolates the whole record; a streamed fit reads a uniform file"
    if getattr(args, "detrend", None):
        return "--detrend subtracts the whole record's mean before the fit"
    from ..signals.io.block_readers import blocks_obstacle
    from ._common import cli_words

    why = blocks_obstacle(args.file, getattr(args, "topic", None))  # identify's rule for files
    return None if why is None else cli_words(InputError(why).render({"topic": "--topic"}))


def block_source(args, model, method: str):
    """The block source of ``args.file`` when the fit streams (``--stream``), else None.

    Raises
    ------
    InputError
        ``--stream on`` with settings or a file that cannot stream (the reason named).
    """
    mode = args.stream
    if mode == "off":
        return None
    why = _why_not(args, method)
    if why is not None and mode == "on":
        raise InputError(f"--stream on: {why}. Drop --stream on to fit in memory.")
    per_sample = BYTES_PER_SAMPLE.get(method, max(BYTES_PER_SAMPLE.values()))
    try:
        if mode == "auto":
            known = _known_need(args, per_sample)
            if known is not None and (known <= _limit() or why is not None):
                _note_cannot(known, why)
                return None  # a bag by its index's count: not scanned, then read whole
            if known is None and _surely_small(args.file, per_sample):
                return None
        src = _open(args, model)
    except ImportError:
        if mode == "on":
            raise InputError(
                "--stream on: this installation has no block readers (physid.signals.io."
                "open_blocks); fit in memory (--stream off)."
            ) from None
        return None
    except PhysidError:
        if mode == "on":
            raise
        return None  # the in-memory read says what is wrong with the file, or reads it whole
    if mode == "auto":
        from .._resources import format_bytes

        need = per_sample * src.n_samples
        limit = _limit()
        if need <= limit or why is not None:
            _close(src)
            _note_cannot(need, why)
            return None
        progress(
            f"estimate: the in-memory fit would need about {format_bytes(need)} (more than "
            f"{format_bytes(limit)}): streaming {args.file} in blocks (--stream off to refuse)"
        )
    return src


def _limit() -> int:
    """The in-memory fit's peak [bytes] above which ``--stream auto`` streams."""
    from .._resources import stream_limit

    return stream_limit()


def _known_need(args, per_sample: int) -> int | None:
    """The in-memory fit's peak [bytes] from the file's index (a ROS bag's message count, the
    rule of ``identify`` and fleets), or None where the file has no index."""
    from ..signals.io import in_memory_samples

    n = in_memory_samples(args.file, getattr(args, "topic", None))
    return None if n is None else per_sample * n


def _note_cannot(need: int, why: str | None) -> None:
    """Says on stderr that a fit above the limit cannot stream (``why``)."""
    from .._resources import format_bytes

    limit = _limit()
    if why is not None and need > limit:
        progress(
            f"estimate: note: the in-memory fit would need about {format_bytes(need)} "
            f"(more than {format_bytes(limit)}) but cannot stream: {why}"
        )


def _surely_small(path, per_sample: int) -> bool:
    """Whether the record is small enough for memory whatever its channels, from the file's
    estimated in-memory size alone (no pass over the file): at least 16 bytes per sample are
    two channels, so ``bytes / 16`` bounds the samples."""
    from ..signals.io import in_memory_bytes

    return in_memory_bytes(path) // 16 * per_sample <= _limit()


def _open(args, model):
    """`open_blocks` with the verb's reading options (the model file's table as defaults)."""
    from ..signals.io import open_blocks, parse_channel_map
    from ._recordings import _model_channel_map, _reworded, _table_name, _with_table_line

    try:
        return open_blocks(
            args.file,
            parse_channel_map(getattr(args, "channel_map", None)) or None,
            rate=getattr(args, "rate", None),
            channel_defaults=_model_channel_map(args, model) or None,
            channel_defaults_source=_table_name(args),
            uniform_rtol=1e-3,
            decimal=getattr(args, "decimal", ".") or ".",
            delimiter=getattr(args, "delimiter", None),
            topic=getattr(args, "topic", None),  # a ROS bag's
        )
    except PhysidError as exc:
        raise _reworded(_with_table_line(args, exc)) from None


def _close(src) -> None:
    close = getattr(src, "close", None)
    if callable(close):
        close()


def fit_streamed(est, method: str, src, block_samples: int):
    """The block fit of ``est`` on ``src`` (closed afterwards), with a note on stderr."""
    from ..estimators.algebraic import fit_blocks as algebraic_blocks
    from ..estimators.recursive import fit_blocks as recursive_blocks

    fit_blocks = recursive_blocks if method == "rls" else algebraic_blocks
    try:
        result = fit_blocks(est, src, block_samples=block_samples)
    finally:
        _close(src)
    notes = (result.metadata if method == "rls" else result.settings).get("notes", [])
    progress(f"estimate: {'; '.join(notes)}")
    return result
