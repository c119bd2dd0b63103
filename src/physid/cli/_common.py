"""Helpers shared by the verb modules: list parsing, JSON output, progress on stderr."""

from __future__ import annotations

import json
import math
import os
import re
import sys
from typing import Any

from ..errors import InputError, OutputError, PhysidWarning

__all__ = [
    "float_list",
    "assignments",
    "print_json",
    "progress",
    "add_resample_option",
    "OUTPUT_OPTIONS",
    "check_outputs",
    "FIGURE_SUFFIXES",
    "RECORDING_SUFFIXES",
    "check_recording_path",
    "check_figure_path",
    "report_warnings",
    "cli_words",
    "torque_fit_line",
]

#: File types a figure is written as (`physid.report.style.save_figure` writes PNG).
FIGURE_SUFFIXES = (".png",)

#: argparse destinations that name files or folders a verb writes (``--out``, ``--plot``, ...).
#: `check_outputs` refuses any of them that resolves to a file the same command reads.
OUTPUT_OPTIONS = ("out", "plot", "plots", "html", "report", "json_out", "save")


def float_list(text: str, option: str) -> list[float]:
    """Parse ``"1,2.5,3"`` into finite floats, naming ``option`` in the error.

    Spaces around items are ignored; an empty string gives ``[]`` (the caller decides whether
    that is allowed). An empty item (``"25,,80"``, a trailing comma) and a non-finite value
    (``nan``, ``inf``) are refused: a typo must not silently drop or poison a value.
    """
    if not text.strip():
        return []
    items = text.split(",")
    out = []
    for k, item in enumerate(items):
        if not item.strip():
            raise InputError(
                f"{option} expects comma-separated numbers such as 1,2.5,3; item {k + 1} of "
                f"{text!r} is empty. Remove the extra comma."
            )
        try:
            value = float(item)
        except ValueError:
            raise InputError(
                f"{option} expects comma-separated numbers such as 1,2.5,3; got {item.strip()!r} "
                f"in {text!r}."
            ) from None
        if not math.isfinite(value):
            raise InputError(f"{option} expects finite numbers; got {item.strip()!r} in {text!r}.")
        out.append(value)
    return out


def assignments(text: str | None, option: str) -> dict[str, float]:
    """Parse ``"m1=50.1,l1=0.4"`` into a dict, naming ``option`` in the error."""
    out: dict[str, float] = {}
    if not text:
        return out
    for item in text.split(","):
        if not item.strip():
            continue
        name, sep, value = item.partition("=")
        if not sep:
            raise InputError(
                f"{option} expects NAME=VALUE pairs separated by commas; got {item!r}."
            )
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise InputError(
                f"{option}: the value of {name.strip()!r} must be a number; got {value!r}."
            ) from None
    return out


def print_json(obj: Any) -> None:
    """Print one JSON object on stdout."""
    from ..estimators.results import jsonable  # lazy: `physid --help` imports no numpy

    json.dump(jsonable(obj), sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")


def progress(message: str) -> None:
    """Progress goes to stderr so stdout stays machine-readable (nothing with ``--quiet``)."""
    from .._progress import _STATE

    if _STATE.get("quiet"):
        return
    print(message, file=sys.stderr, flush=True)


def add_resample_option(parser) -> None:
    """``--resample``: accept a non-uniformly sampled recording by interpolating it."""
    parser.add_argument(
        "--resample",
        action="store_true",
        help="interpolate a non-uniformly sampled recording linearly onto a uniform grid "
        "with its mean period (default: refuse it with an error)",
    )


def _same_file(a: str, b: str) -> bool:
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return os.path.realpath(a) == os.path.realpath(b)


def check_outputs(args) -> None:
    """Refuse an output option that resolves to one of the command's input files.

    Every verb's arguments pass through this once, before the verb runs (`physid.cli.main`
    calls it). The inputs are every other argument that names an existing file (positional
    recordings, ``--model``, ...); an output is any destination in `OUTPUT_OPTIONS`. Paths are
    compared as files (`os.path.samefile`: relative paths, symbolic and hard links included),
    so ``physid filter same.csv --out ./same.csv`` is refused before anything is read.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of one verb.

    Raises
    ------
    OutputError
        An output names an input file; the message names both options and the fix.
    """
    values = vars(args)
    outputs = {k: v for k, v in values.items() if k in OUTPUT_OPTIONS and isinstance(v, str)}
    if not outputs:
        return
    inputs = []
    for key, value in values.items():
        if key in OUTPUT_OPTIONS or key == "func":
            continue
        for item in value if isinstance(value, (list, tuple)) else [value]:
            if isinstance(item, (str, os.PathLike)) and str(item) and os.path.isfile(item):
                inputs.append((key, str(item)))
    for out_key, out in outputs.items():
        for in_key, path in inputs:
            if os.path.exists(out) and _same_file(out, path):
                flag = "--" + out_key.replace("_", "-")
                what = (
                    "the input file"
                    if in_key in ("file", "files", "path")
                    else (f"the input of {'--' + in_key.replace('_', '-')}")
                )
                raise OutputError(
                    f"{flag} {out!r} is {what} {path!r}; writing it would destroy the input. "
                    f"Choose another output, e.g. {flag} {_suggest(out)!r}."
                )


def check_output_folder(path, option: str) -> None:
    """Refuse a folder output (``--plot DIR``, ``sweep --out DIR``) that cannot be one.

    Called before the verb's work, so a wrong path costs nothing: an existing file (not a
    folder), or a parent that is a file or is not writable.

    Parameters
    ----------
    path : str or None
        The folder the verb will create or fill (None: the option was not given).
    option : str
        The flag, for the message (``"--plot"``).

    Raises
    ------
    OutputError
        The path exists and is not a folder, or its parent is not a writable folder.
    """
    if path is None:
        return
    path = os.fspath(path)
    if os.path.exists(path) and not os.path.isdir(path):
        raise OutputError(
            f"{option} {path!r} is an existing file, not a folder; give a folder (new or "
            f"existing), e.g. {option} {_suggest(path).rsplit('.', 1)[0]!r}."
        )
    parent = os.path.dirname(os.path.abspath(path))
    while parent and not os.path.exists(parent):
        parent = os.path.dirname(parent)
    if parent and (not os.path.isdir(parent) or not os.access(parent, os.W_OK | os.X_OK)):
        raise OutputError(
            f"{option} {path!r}: cannot create a folder inside {parent!r} (not a writable "
            f"folder); choose another {option} or fix its permissions (chmod u+w)."
        )


def _suggest(path: str) -> str:
    root, ext = os.path.splitext(path)
    return f"{root}-out{ext}"


def check_figure_path(path: str, option: str) -> str:
    """Refuse a figure path whose suffix is not ``.png``, before any work is done.

    Parameters
    ----------
    path : str
        The path the user gave.
    option : str
        The option's flag (``"--plot"``), named in the message.

    Returns
    -------
    str
        The image format (suffix without the dot, lower case).

    Raises
    ------
    InputError
        ``x.csv``, a missing suffix, ...
    """
    suffix = os.path.splitext(str(path))[1].lower()
    if suffix not in FIGURE_SUFFIXES:
        root = os.path.splitext(str(path))[0] or "figure"
        raise InputError(
            f"{option} {str(path)!r} is not a PNG file name: figures are written as PNG, so the "
            f"suffix must be {', '.join(FIGURE_SUFFIXES)}; got {suffix or 'none'!r}. For "
            f"example {option} {root + '.png'!r}."
        )
    return suffix[1:]


#: Suffixes `physid.signals.save_recording` writes (checked by `check_recording_path`).
RECORDING_SUFFIXES = (".csv", ".npz")


def check_recording_path(path: str, option: str) -> None:
    """Refuse a recording output (``--out F``) that cannot be written, before any work is done.

    ``save_recording`` would refuse the same path, but only after the simulation or design
    that produced the data (seconds to minutes), losing it.

    Parameters
    ----------
    path : str
        The path the user gave.
    option : str
        The option's flag (``"--out"``), named in the message.

    Raises
    ------
    OutputError
        A suffix other than ``.csv``/``.npz``, an existing folder, or a folder that does not
        exist or is not writable.
    """
    text = os.fspath(path)
    root, suffix = os.path.splitext(text)
    if suffix.lower() not in RECORDING_SUFFIXES:
        raise OutputError(
            f"{option} {text!r}: recordings are written as {' or '.join(RECORDING_SUFFIXES)}; "
            f"got suffix {suffix or 'none'!r}. For example {option} {(root or 'out') + '.csv'!r}."
        )
    if os.path.isdir(text):
        raise OutputError(
            f"{option} {text!r}: it is a folder; give a file name, e.g. "
            f"{option} {os.path.join(text, 'out' + suffix.lower())!r}."
        )
    parent = os.path.dirname(os.path.abspath(text))
    if not os.path.isdir(parent):
        raise OutputError(
            f"{option} {text!r}: the folder {parent!r} does not exist; create it first "
            "(mkdir -p) or choose another path."
        )
    if not os.access(parent, os.W_OK | os.X_OK) or (
        os.path.exists(text) and not os.access(text, os.W_OK)
    ):
        raise OutputError(
            f"{option} {text!r}: cannot write there (permissions); choose another path or fix "
            "them (chmod u+w)."
        )


def report_warnings(caught, flags=None) -> None:
    """Print recorded warnings as ``physid: warning: ...`` lines on stderr, once per message.

    numpy's floating-point RuntimeWarnings ("overflow encountered in multiply") name no input
    and no fix; they are summarised as one line per message with a count and a hint. physid's
    own warnings are printed with their message only (no file and line); a `PhysidWarning` names
    the verb's flags instead of Python arguments (``--cutoff auto``, not ``cutoff='auto'``), as
    errors do.

    Parameters
    ----------
    caught : list of warnings.WarningMessage
        From ``warnings.catch_warnings(record=True)``.
    flags : mapping of str to str or None, or argparse.Namespace, optional
        Python keyword → flag (`physid.cli.argument_flags`), or the verb's parsed arguments,
        which carry that mapping as ``argument_flags`` (set by `physid.cli.main`); None keeps
        the Python spelling.
    """
    if flags is not None and not isinstance(flags, dict):
        flags = getattr(flags, "argument_flags", None)
    counts: dict = {}
    for w in caught or ():
        message = w.message
        text = message.render(flags) if isinstance(message, PhysidWarning) else str(message)
        text = cli_words(text)
        key = (w.category.__name__, text)
        counts[key] = counts.get(key, 0) + 1
    for (category, message), n in counts.items():
        times = f" ({n} times)" if n > 1 else ""
        if category == "RuntimeWarning" and "encountered" in message:
            print(
                f"physid: warning: numpy: {message}{times}; some intermediate values were "
                "infinite or undefined (check the scale of the inputs and the results' "
                "finiteness).",
                file=sys.stderr,
            )
        else:
            print(f"physid: warning: {message}{times}", file=sys.stderr)


def _map_entries(match: re.Match) -> str:
    """``channels={'u': 'Force', 'x': 'pos [mm]'}`` → ``--map 'u=Force,x=pos [mm]'``."""
    pairs = re.findall(r"'([^']*)': '([^']*)'", match.group(1))
    text = ",".join(f"{k}={v}" for k, v in pairs)
    return f"--map '{text}'"


#: Fixes the library's time errors offer that the command line has no flag for (also dropped
#: by ``--joint --scheduler``'s own wording, `physid.cli._fleet`).
KEEP_TIMES = re.compile(r",? or pass uniform_rtol=None to keep the times as they are")
JOIN_SPLITS = re.compile(r" \(physid\.signals\.join_recordings splits files at gaps\)")

# library messages name Python keywords; the command line shows its own flags instead (a
# message worded with physid.errors.arg marks is rendered by the verb's flags first; these
# patterns reword the rest, and any text a result carries, such as its stderr_reason)
_CLI_WORDS = (
    (re.compile(r" ?\(or uniform_rtol=None to keep the time vector as it is\)"), ""),
    (KEEP_TIMES, ""),  # blocks
    (re.compile(r" Or pass uniform_rtol=None to keep the times as they are\."), ""),
    (re.compile(r"read the bag whole \(load_recording\)"), "read the bag whole (--stream off)"),
    # --join refuses one file, --joint --join joins logs as channels: a gap's fix is the split
    (JOIN_SPLITS, ""),
    (
        re.compile(r"load_recording\(\.\.\., resample=True\) reads"),
        "--resample without --stream on reads",
    ),
    (re.compile(r",? or uniform_rtol=None to keep the time vector as it is"), ""),
    # a verb without --noise-std (simulate msd): only the input can be changed
    (re.compile(r", or give the noise as a standard deviation instead \(noise_std=\.\.\.\)"), ""),
    (re.compile(r"resample=True"), "--resample"),
    (re.compile(r"channels=\{((?:'[^']*': '[^']*'(?:, )?)+)\}"), _map_entries),
    (re.compile(r"channels\['([^']*)'\] = '([^']*)'"), r"--map \1=\2"),
    (re.compile(r"channels\['([^']*)'\]"), r"--map \1"),
    (re.compile(r"channels=\{NAME: COLUMN\}"), "--map NAME=COLUMN"),
    (re.compile(r"channels=\{\.\.\.\}"), "--map"),
    (re.compile(r"channels= ?"), "--map "),
    (re.compile(r"decimal=','"), "--decimal ,"),
    (re.compile(r"load_model\('([^']*)'\)"), r"--model \1"),
    (re.compile(r"delimiter='([^']*)'"), r"--delimiter '\1'"),
    (re.compile(r"bias_compensation=True"), "--bias-compensation"),  # RLS's withholding reason
    (re.compile(r"\bstick_threshold=([\w.]+)"), r"--stick-threshold \1"),  # the stiction notes
    (re.compile(r"\(Recording\.resample\)"), "(--resample)"),
    (re.compile(r"\brate=(\d+)"), r"--rate \1"),
    (re.compile(r"\brate="), "--rate"),
    (re.compile(r"\btopic='([^']*)'"), r"--topic \1"),
    (re.compile(r"\btopic="), "--topic"),
    (re.compile(r"\bfinal='([\w-]+)'"), r"--final \1"),  # the algebraic estimator's reasons
)


def cli_words(message: str) -> str:
    """Reword a library message for the command line (``resample=True`` → ``--resample``).

    Parameters
    ----------
    message : str
        A library message or a result's text (already rendered with the verb's flags).

    Returns
    -------
    str
        The message with the Python keywords the command line spells as flags replaced:
        ``channels={'u': 'Force'}`` → ``--map u=Force``, ``final='median'`` → ``--final
        median``; a clause about a keyword the command line has no flag for
        (``uniform_rtol=None``) is dropped.
    """
    for pattern, repl in _CLI_WORDS:
        message = pattern.sub(repl, message)
    return message


def torque_fit_line(result) -> str:
    """``"torque fit: tau1 98.7 %, tau2 97.9 %"`` of an arm's fit, 100 (1 − rms error / rms τ).

    Parameters
    ----------
    result : InputErrorResult or IDIMResult
        With ``relative_residual`` (array per joint) or ``relative_error`` (dict per joint).

    Returns
    -------
    str
        The line ``identify`` prints after the summary ("" when the result has neither).
    """
    rel = getattr(result, "relative_error", None)
    if isinstance(rel, dict):
        pairs = [(k, v) for k, v in rel.items() if k != "overall"]
    else:
        values = getattr(result, "relative_residual", None)
        if values is None:
            return ""
        pairs = [(f"tau{j + 1}", float(v)) for j, v in enumerate(values)]
    shown = ", ".join(f"{k} {100.0 * (1.0 - v):.2f} %" for k, v in pairs if math.isfinite(v))
    if not shown:
        return ""
    return f"  torque fit (100 (1 − rms error / rms τ), filtered): {shown}"
