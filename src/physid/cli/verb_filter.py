"""``physid filter F --kind lowpass|first|second --half-width M --cutoff W --out G``.

Applies the paper's Harris-windowed FIR low-pass or differentiating filter to channels of a
recording and writes the aligned result (time of each output = time of its centre sample).
"""

from __future__ import annotations

import argparse
import math
import re

from ..errors import InputError, PhysidError
from ._common import progress
from ._recordings import add_recording_options, read_recording

ORDER = 60

_SUFFIX = {0: "", 1: "_dot", 2: "_ddot"}


def register(subparsers) -> None:
    """Add the ``filter`` verb and its options to the CLI's ``subparsers``."""
    parser = subparsers.add_parser(
        "filter",
        help="low-pass or differentiate channels with the paper's FIR filters",
        description=(
            "Filter channels of a recording (CSV, NPZ, MAT, HDF5) with the Harris-windowed FIR "
            "filters of Cedro & Janecki (section 3): 'lowpass' keeps the names, 'first' and "
            "'second' write NAME_dot [unit/s] and NAME_ddot [unit/s^2]. The output holds the "
            "samples M..n-M-1 of the input (the filter's valid range), each at its own time. "
            "Progress goes to stderr; the output path is printed on stdout."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument("file", metavar="F", help="input recording (.csv, .npz, .mat, .h5)")
    parser.add_argument(
        "--kind",
        choices=["lowpass", "first", "second"],
        default="lowpass",
        help="low-pass, first derivative or second derivative",
    )
    parser.add_argument(
        "--half-width",
        type=int,
        default=100,
        metavar="M",
        help="half-width M in samples (2M+1 taps, delay M samples)",
    )
    parser.add_argument(
        "--cutoff",
        type=_cutoff,
        default=0.2,
        metavar="W|auto",
        help="cut-off Ω_g in rad/sample, 0 < W <= π (f_c = W / (2π dt) Hz); 'auto': the lowest "
        "cut-off whose flat band holds the motion of the filtered channels, above their noise "
        "(physid.filters.choose_filter, for the given --half-width)",
    )
    parser.add_argument(
        "--channels",
        default=None,
        metavar="LIST",
        help="comma-separated channel names (default: all channels)",
    )
    parser.add_argument(
        "--paper",
        action="store_true",
        help="drop one more sample at the end, like the paper's loop i = M+1..NN-M-1",
    )
    add_recording_options(parser)
    parser.add_argument("--out", metavar="G", required=True, help="output file (.csv or .npz)")
    parser.set_defaults(func=run)


def _cutoff(text: str):
    """``--cutoff``: a number, or ``auto`` (chosen from the data)."""
    if str(text).strip().lower() == "auto":
        return "auto"
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expects a cut-off in rad/sample such as 0.2, or auto; got {text!r}"
        ) from None


def run(args) -> int:
    """Filter the recording ``args.file`` and write ``args.out``; return the exit status 0.

    Bad input raises a `PhysidError` (the CLI prints ``physid: error: ...`` and exits 2); errors
    from applying the filter (e.g. a record shorter than 2M + 1 samples) name the input file.
    """
    from ..filters import design_filter
    from ..signals import Recording, save_recording

    rec = read_recording(args, args.file)
    if args.channels:
        names = [n.strip() for n in args.channels.split(",") if n.strip()]
        if not names:
            raise InputError(f"--channels expects names such as q1,q2; got {args.channels!r}.")
    else:
        names = list(rec.names)
    data = rec.select(names)
    _check_output_length(rec.n_samples, args.half_width, args.paper, args.file)
    cutoff = args.cutoff
    if cutoff == "auto":
        cutoff = _auto_cutoff(data, rec.dt, args.half_width, names)
    filt = design_filter(args.kind, args.half_width, cutoff, rec.dt)
    try:
        out = filt.apply(data, paper=args.paper)
    except PhysidError as exc:  # e.g. a record shorter than 2M+1 samples: name the file
        raise type(exc)(f"{args.file}: {exc}") from None
    t_out = filt.output_time(rec.t, paper=args.paper)
    suffix = _SUFFIX[filt.order]
    out_names = tuple(f"{n}{suffix}" for n in names)
    out_units = tuple(derivative_unit(rec.unit(n), filt.order) for n in names)
    metadata = {
        **dict(rec.metadata),
        "filter": {
            "kind": filt.kind,
            "half_width": filt.half_width,
            "cutoff_rad_per_sample": filt.cutoff,
            "dt_s": filt.dt,
            "delay_samples": filt.delay,
            "paper": bool(args.paper),
            "cutoff_auto": args.cutoff == "auto",
            "input": str(args.file),
        },
    }
    result = Recording(t_out, out, out_names, out_units, metadata)
    path = save_recording(result, args.out)
    progress(
        f"physid filter: {filt.kind} M={filt.half_width} Ω_g={filt.cutoff:g} rad/sample "
        f"(f_c = {filt.cutoff / (2 * math.pi * filt.dt):.4g} Hz) on {len(names)} "
        f"channel(s): {rec.n_samples} -> {result.n_samples} samples "
        f"(t = {t_out[0]:.6g}..{t_out[-1]:.6g} s)"
    )
    print(path)
    return 0


def _auto_cutoff(data, dt: float, half_width, names) -> float:
    """Ω_g chosen by `physid.filters.choose_filter` for M = ``half_width``; says why on stderr."""
    from ..filters import choose_filter

    if not isinstance(half_width, int) or half_width < 1:
        return 0.2  # design_filter words the bad --half-width
    choice = choose_filter(data, dt, half_width=half_width)
    progress(f"physid filter: --cutoff auto, from {', '.join(names)}: {choice.reason}")
    return float(choice.cutoff)


def _check_output_length(n: int, half_width, paper: bool, file) -> None:
    """Refuse a filter that would leave fewer than 2 samples (a file physid cannot read back).

    The output holds samples M..n−M−1 of the input (one fewer with ``--paper``): n − 2M rows.
    """
    if not isinstance(half_width, int) or half_width < 1:
        return  # design_filter words the bad value
    n_out = n - 2 * half_width - (1 if paper else 0)
    if 0 <= n_out < 2:  # (n_out < 0: shorter than the filter itself, which says so)
        largest = (n - 2 - (1 if paper else 0)) // 2
        fix = (
            f"lower --half-width to at most {largest}" if largest >= 1 else "use a longer recording"
        )
        raise InputError(
            f"{file}: --half-width {half_width} leaves {max(n_out, 0)} output sample(s) of the "
            f"{n} in the file (the filter's valid range is samples M..n-M-1), and a recording "
            f"needs at least 2; {fix}, or use a longer recording."
            if largest >= 1
            else f"{file}: the file holds {n} samples, too few to filter (a filter of half-width "
            f"M keeps n - 2M samples, and a recording needs at least 2); {fix}."
        )


_PER_SECOND = re.compile(r"^(?P<base>.*?)/s(?:\^(?P<power>\d+)|(?P<sup>[²³]))?$")


def derivative_unit(unit: str, order: int) -> str:
    """Unit of the ``order``-th time derivative: ``rad`` -> ``rad/s``, ``m/s`` -> ``m/s^2``."""
    if order == 0:
        return unit
    if not unit:
        return "1/s" if order == 1 else f"1/s^{order}"
    match = _PER_SECOND.match(unit)
    if match:
        power = int(match["power"] or {"²": 2, "³": 3}.get(match["sup"] or "", 1))
        return f"{match['base']}/s^{power + order}"
    if "/" in unit or " " in unit:
        unit = f"({unit})"
    return f"{unit}/s" if order == 1 else f"{unit}/s^{order}"
