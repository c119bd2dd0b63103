"""Reading recordings on the command line: the options every verb that reads one shares, the
channel map of the model file's ``[recording]`` table, several files of one run (``--join``),
motor-side channels, unit checks against the model and warnings about doubtful units."""

from __future__ import annotations

import re
import sys

from ..errors import PhysidWarning
from ._common import add_resample_option, cli_words, progress

#: Seconds [s] a recording read may take before its progress line appears on stderr.
READ_DELAY = 2.0

__all__ = [
    "add_recording_options",
    "read_recording",
    "read_recordings",
    "warn_implausible_estimates",
    "check_recording_units",
]


def add_recording_options(parser, *, what="the recording", detrend=True) -> None:
    """The options of every verb that reads a recording (use with `read_recording`).

    ``--map``, ``--decimal``, ``--delimiter``, ``--resample`` and (unless ``detrend=False``)
    ``--detrend``; see docs/your-data.md. ``what`` names the file in the group's title
    (``"the --reference file"``).
    """
    group = parser.add_argument_group(f"reading {what} (docs/your-data.md)")
    group.add_argument(
        "--map",
        dest="channel_map",
        default=None,
        metavar="NAME=SOURCE,...",
        help="channel map: which column/variable (or arithmetic over them and over scalars of "
        "the file) each channel physid needs comes from, e.g. t=time,q1=qm,tau1=gtau*vir; a "
        "MATLAB struct field is data.pos; a unit may follow in brackets: tau1=35.15*vir [N]",
    )
    group.add_argument(
        "--decimal",
        choices=[".", ","],
        default=".",
        help="decimal mark of a CSV file (default '.'); with ',' the separator is ';' or a tab",
    )
    group.add_argument(
        "--delimiter",
        default=None,
        metavar="SEP",
        help="CSV separator: ',', ';' or tab (default: recognised from the header)",
    )
    add_resample_option(group)
    group.add_argument(
        "--rate",
        type=float,
        default=None,
        metavar="HZ",
        help="sample rate of a file without a time column: t = k/HZ (also 'rate' in the model "
        "file's [recording] table)",
    )
    group.add_argument(
        "--topic",
        default=None,
        metavar="TOPIC",
        help="ROS bags: the sensor_msgs/JointState topic to read, e.g. /joint_states (default: "
        "the bag's only one); joints are matched to the model's by name. Also "
        "control_msgs/JointTrajectoryControllerState (by name, with r1..rn) and "
        "std_msgs/Float64MultiArray topics (values LABEL.data1..n, for --map); several "
        "topics separated by commas are joined on their stamps",
    )
    if not detrend:
        return
    group.add_argument(
        "--detrend",
        nargs="?",
        const="*",
        default=None,
        metavar="CHANNELS",
        help="subtract the mean of every channel (or of the comma-separated CHANNELS) before "
        "fitting: removes a constant sensor offset and the input's mean together (MATLAB's "
        "detrend(data, 0)); the alternative to estimating an offset in the model",
    )


def read_recording(args, path=None, *, model=None, table_channels=None, raw=False, period=None):
    """Read the verb's recording with the options of `add_recording_options`.

    Parameters
    ----------
    args : argparse.Namespace
        With ``channel_map``, ``decimal``, ``delimiter``, ``resample`` and ``detrend`` (missing
        attributes take their defaults, so verbs with only ``--resample`` work too).
    path : str, optional
        The file (default ``args.file``).
    model : model, optional
        When given, the recording's units are checked against it (`check_recording_units`):
        a force where the model wants u = F/m is an error, never a silent wrong answer. Its
        model file's ``[recording]`` table is the channel map, which ``--map`` entries
        override.
    table_channels : callable, optional
        ``table_channels(name) -> bool``: which entries of the ``[recording]`` table apply (a
        ``--reference`` file takes ``t`` and ``r1..rn`` only, not the log's ``q1``/``tau1``);
        default all.
    raw : bool
        Read the file as it is (time, units, ``--rate``; no channel map, any sampling, no
        checks): one of the files ``--join`` joins.
    period : float, optional
        With ``--resample``: resample onto this period [s] (validate: the fit's), whatever the
        file's sampling.

    Returns
    -------
    Recording

    Raises
    ------
    PhysidError
        Whatever `physid.signals.load_recording` raises, with the message in CLI words
        (``--resample``, ``--map``).
    """
    from ..errors import PhysidError

    path = getattr(args, "file", None) if path is None else path
    try:
        table = _model_channel_map(args, model)
        if table_channels is not None:
            table = {k: v for k, v in table.items() if table_channels(k)}
        rec = _load(args, path, model, table, raw=raw, period=period)
        if raw:
            return rec
        rec = _checked(args, rec, model)
    except PhysidError as exc:
        raise _reworded(_with_table_line(args, exc)) from None
    return rec


def _with_table_line(args, exc):
    """An error about an entry of the model file's ``[recording]`` table, with its line."""
    import re

    name = getattr(args, "model", None)
    where = _table_name(args)
    found = re.search(re.escape(where) + r" entry (\w+)", str(exc))
    if not found or not isinstance(name, str):
        return exc
    from pathlib import Path

    from ..models._locate import _line_of

    try:
        line = _line_of(Path(name).read_text(encoding="utf-8"), found[1], table="recording")
    except (OSError, UnicodeDecodeError):
        return exc
    if not line:
        return exc
    text = str(exc).replace(found[0], f"{where} (line {line}) entry {found[1]}", 1)
    try:
        new = type(exc)(text)
    except TypeError:  # an error class with required keywords: keep it as it is
        return exc
    for key, value in vars(exc).items():
        if key not in ("template", "arguments"):
            setattr(new, key, value)
    return new


def _table_name(args) -> str:
    name = getattr(args, "model", None)
    if isinstance(name, str) and name.lower().endswith(".toml"):
        return f"the [recording] table of {name}"
    return "the model file's [recording] table"


def _load(args, path, model, table, *, raw=False, period=None):
    """`load_recording` with the verb's options; notes and warnings of the load on stderr.

    ``raw``: no channel map, any sampling (the files of a --join); ``period``: resample onto
    this period [s] (validate's --resample onto the fit's).
    """
    import warnings
    from pathlib import Path

    from .._progress import working
    from ..signals import load_recording
    from ..signals.io import parse_channel_map
    from ..signals.io.rosbag_reader import is_rosbag

    where = _table_name(args)
    resample = bool(getattr(args, "resample", False))
    bag = is_rosbag(path)
    # --map entries are strict and override the table's; a table entry whose sources the
    # file lacks is skipped where the file has the channel (physid's own recordings)
    channels = parse_channel_map(getattr(args, "channel_map", None)) or None
    if raw:
        channels, table = None, {k: v for k, v in table.items() if k == "rate"}
    # a long file (a large CSV, a ROS bag) shows the time spent on stderr after READ_DELAY s
    with working(f"physid: reading {Path(path).name}", delay=READ_DELAY):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            rec = load_recording(
                path,
                channels,
                resample=(resample or bag) and not raw and period is None,
                uniform_rtol=None if raw or (period is not None and resample) else 1e-3,
                decimal=getattr(args, "decimal", ".") or ".",
                delimiter=getattr(args, "delimiter", None),
                channel_defaults=table or None,
                channel_defaults_source=where,
                rate=getattr(args, "rate", None),
                topic=getattr(args, "topic", None),
                joint_names=getattr(model, "joint_names", None) if bag else None,
            )
    for w in caught:
        render = getattr(w.message, "render", None)
        text = render(_RECORDING_FLAGS) if callable(render) else str(w.message)
        print(f"physid: warning: {cli_words(text)}", file=sys.stderr)
    _load_notes(path, rec, where, bag)
    if period is not None and resample and not _on_period(rec, period):
        before = rec.dt if _uniform(rec) else None
        rec = rec.resample(period)
        was = f"{before:.6g} s" if before is not None else "non-uniform sampling"
        progress(
            f"physid: note: {path} resampled from {was} onto the fit's period {period:.6g} s "
            f"({rec.n_samples} samples, linear interpolation)"
        )
    return rec


def _on_period(rec, period) -> bool:
    """The recording is uniformly sampled at ``period`` [s] (relative 1e-6)."""
    return _uniform(rec) and abs(rec.dt - period) <= 1e-6 * period


def _uniform(rec) -> bool:
    from ..errors import SamplingError

    try:
        return rec.dt > 0
    except SamplingError:
        return False


def _load_notes(path, rec, where, bag) -> None:
    meta = rec.metadata
    unused = meta.get("channel_defaults_unused") or {}
    if unused:
        entries = ", ".join(f"{k} = {v!r}" for k, v in unused.items())
        progress(
            f"physid: note: {where} maps {entries}, but {path} has no such source and "
            f"already has the channel{'s' if len(unused) > 1 else ''} "
            f"{', '.join(unused)}: reading {'them' if len(unused) > 1 else 'it'} as "
            "the file has them (pass --map to choose otherwise)."
        )
    if bag:
        joints = meta.get("bag_joint_names") or []
        progress(f"physid: note: {path}: topic {meta.get('topic')}, joints {', '.join(joints)}")
        for note in meta.get("bag_join") or ():
            progress(f"physid: note: {path}: {note}")
    resampled = meta.get("resampled_from")
    if resampled and "max_sampling_deviation" in meta:
        progress(
            f"physid: note: {path}: sample intervals deviate by up to "
            f"{100 * meta['max_sampling_deviation']:.3g} % of the mean period; resampled onto a "
            f"uniform grid of {1e3 * resampled['dt']:.6g} ms by linear interpolation"
        )


def _checked(args, rec, model):
    """Motor-side channels, units against the model, plausibility of unit-less channels,
    --detrend."""
    from ..signals.joint_side import joint_side

    rec = joint_side(model, rec)  # motor-side qm/taum/im through the model's transmission
    if model is not None:
        if callable(getattr(model, "recording_channels", None)):  # the --map that fixes it
            model.recording_channels(rec.names, dict(zip(rec.names, rec.units, strict=True)))
        check_recording_units(model, rec)
        _warn_implausible_data(model, rec)
    detrend = getattr(args, "detrend", None)
    if detrend:
        names = None if detrend == "*" else [n.strip() for n in detrend.split(",") if n.strip()]
        _check_detrend_for_chain(model, rec, names)
        rec = rec.detrend(names)
    return rec


def _warn_implausible_data(model, rec) -> None:
    from ..signals.io.plausibility import implausible_units

    types = getattr(model, "joint_types", None)
    limits = getattr(model, "limits", None)
    if not types or not isinstance(limits, dict):
        return
    for text in implausible_units(rec, types, limits, source=rec.metadata.get("source")):
        shown = PhysidWarning(text).render(_RECORDING_FLAGS)  # the --map spelling of the fix
        print(f"physid: warning: {shown}", file=sys.stderr)


def warn_implausible_estimates(model, result, recordings) -> bool:
    """Warn (stderr) about estimated masses 100× away from the model's nominal ones.

    The estimators' verdict already fails such a fit (`physid.estimators.plausibility.
    implausible_scale` in their gate); the warning repeats it on stderr, where a ``--json``
    reader sees it too.

    Parameters
    ----------
    model : model
        With ``parameters`` (nominal values) and ``units``.
    result : fit result
        With ``parameters`` and ``units``.
    recordings : list of Recording
        The fitted recordings: their position channels without a unit are named as suspects.

    Returns
    -------
    bool
        True when something was warned about.
    """
    from ..estimators.plausibility import implausible_scale

    messages = implausible_scale(
        result.parameters, model, recordings, getattr(result, "units", None)
    )
    for text in messages:
        print(f"physid: warning: {text}", file=sys.stderr)
    return bool(messages)


def read_recordings(args, paths, *, model=None) -> list:
    """The verb's recordings: one per file, or with ``--join`` the files as one run.

    Parameters
    ----------
    args : argparse.Namespace
        As for `read_recording`, and ``join`` (bool).
    paths : list of str
    model : model, optional

    Returns
    -------
    list of Recording
        One per file; with ``--join``, one per segment of the joined run (a gap splits it).

    Raises
    ------
    PhysidError
        Whatever reading or joining raises, in CLI words.
    """
    from pathlib import Path

    from ..errors import InputError, PhysidError
    from ..signals.io import map_recording
    from ..signals.join import join_recordings

    if not getattr(args, "join", False):
        return [read_recording(args, p, model=model) for p in paths]
    if len(paths) < 2:
        raise InputError(
            "--join joins the files of one run (positions in one, currents in another); give "
            "at least 2 files, or leave --join out."
        )
    try:
        raw = [read_recording(args, p, model=model, raw=True) for p in paths]
        labels = [Path(p).stem for p in paths]
        if len(set(labels)) < len(labels):
            labels = [f"{Path(p).stem}{k + 1}" for k, p in enumerate(paths)]
        run = join_recordings(raw, labels)
        for note in run.notes:
            progress(f"physid: note: {note}")
        table = _model_channel_map(args, model)
        channels = getattr(args, "channel_map", None)
        out = []
        for seg in run.segments:
            mapped = map_recording(
                seg, channels, channel_defaults=table or None,
                channel_defaults_source=_table_name(args),
            )  # fmt: skip
            out.append(_checked(args, mapped, model))
    except PhysidError as exc:
        raise _reworded(exc) from None
    return out


def _check_detrend_for_chain(model, rec, names) -> None:
    """Refuse ``--detrend`` of joint channels for an arm: their means are physics, not offsets.

    q enters an arm's dynamics through sin/cos and the mean of τ is mostly the gravity load, so
    subtracting either changes the system (a fit that explains half the torque, reported as a
    fit). A torque-sensor offset is a model term (``torque_offset``; ``OF*`` in URDF models).
    """
    from ..errors import InputError

    if getattr(model, "n_joints", None) is None:
        return
    targets = rec.names if names is None else names
    joint = [n for n in targets if re.fullmatch(r"(q|qd|qdd|tau|r)\d+", n)]
    if joint:
        raise InputError(
            f"--detrend would subtract the mean of {', '.join(joint)}, which for an arm is "
            "physics (gravity load, joint angles inside sin/cos), not a sensor offset. Leave "
            "--detrend out; a constant torque-sensor offset is a model term (torque_offset in the "
            "model file or the URDF's sidecar TOML: parameters OF1..OFn), estimated with the rest."
        )


def _model_channel_map(args, model) -> dict:
    """The ``[recording]`` table of the model file named by ``--model`` (empty if none)."""
    mapping = getattr(model, "recording_map", None)
    if mapping:
        return dict(mapping)
    name = getattr(args, "model", None)
    if isinstance(name, str) and name.lower().endswith(".toml"):
        from pathlib import Path

        from ..models.spec import read_recording_map

        if Path(name).is_file():
            return read_recording_map(name)
    return {}


_RECORDING_FLAGS = {
    "resample": "--resample",
    "decimal": "--decimal",
    "delimiter": "--delimiter",
    "channels": "--map",
}


def _reworded(exc):
    """The error with its message in CLI words (argument marks rendered, keywords → flags)."""
    render = getattr(exc, "render", None)
    shown = render(_RECORDING_FLAGS) if callable(render) else str(exc)
    text = cli_words(shown)
    if text == str(exc):
        return exc
    try:
        new = type(exc)(text)
    except TypeError:  # an error class with required keywords: keep it as it is
        return exc
    for key, value in vars(exc).items():
        if key not in ("template", "arguments"):  # the new text is final: no marks to render
            setattr(new, key, value)
    return new


def check_recording_units(model, rec) -> None:
    """Refuse channel units that contradict the model (see `LinearODEModel.check_units`).

    Chain models: a prismatic joint's ``q``/``tau`` must be a length [m] / force [N], a
    revolute joint's an angle [rad] / torque [N·m]. Channels without a unit are not checked.
    The message names the recording's file (``metadata["source"]``) and the unit its header
    gave (``q1 [deg]``, read as rad).
    """
    from ..errors import InputError

    source = (getattr(rec, "metadata", None) or {}).get("source")
    prefix = f"{source}: " if source else ""
    check = getattr(model, "check_units", None)
    if callable(check):
        try:
            check(rec)
        except InputError as exc:
            if not prefix or str(exc).startswith(prefix):
                raise
            raise type(exc)(prefix + str(exc)) from None
        return
    joint_types = getattr(model, "joint_types", None)
    if not joint_types:
        return
    from ..units import parse_unit

    original = dict((getattr(rec, "metadata", None) or {}).get("original_units") or {})
    for j, kind in enumerate(joint_types, start=1):
        prismatic = str(kind).lower().startswith("p")
        for stem, want in (("q", ("m", "rad")), ("tau", ("N", "N·m"))):
            name = f"{stem}{j}"
            if name not in rec.names or not rec.unit(name):
                continue
            expected = want[0] if prismatic else want[1]
            if parse_unit(rec.unit(name)).dimension != parse_unit(expected).dimension:
                joint = "prismatic" if prismatic else "revolute"
                given = original.get(name)
                unit = f"{given} (read as {rec.unit(name)})" if given else rec.unit(name)
                raise InputError(
                    f"{prefix}channel {name!r} is in {unit}, but joint {j} of the model is "
                    f"{joint}, so {name} must be in {expected}; check the joint type in the "
                    "model or the channel's unit (map it: --map "
                    f"'{name}=GAIN*SOURCE [{expected}]')."
                )
