"""``physid identify FILES --each``: a fleet, one fit per file (`physid.analysis.fleet`).

The verb's options are checked here (flags that do not apply to a fleet are refused before any
file is read), the fleet runs in `physid.analysis.fleet.run_fleet`, and the outputs go into
``--out`` (`physid.analysis.fleet_result.write_fleet`).
"""

from __future__ import annotations

import re

from ._common import JOIN_SPLITS, KEEP_TIMES, check_output_folder, cli_words, print_json, progress

# the fixes of a time or field error that --each and --joint --scheduler refuse
_WHOLE_READ = re.compile(r" Or read the bag whole \(load_recording\)[^.]*\.")

# Options of a single fit that a fleet cannot honour: flag -> (attribute, value meaning "not
# given", why). A silently ignored flag is a wrong answer.
_NOT_WITH_EACH = {
    "--join": ("join", False, "joins the files into one run; --each fits each file on its own"),
    "--joint": ("joint", False, "fits all the files together; --each fits each on its own"),
    "--save": (
        "save",
        None,
        "writes one result file; --each writes one per file into --out DIR/results/",
    ),
    "--joints": ("joints", None, "(a sub-tree) is not available for fleets yet"),
    "--detrend": ("detrend", None, "is not available for fleets"),
    "--topic": ("topic", None, "(ROS bags) is not available for fleets yet; convert the bags"),
    "--stream": (
        "stream",
        "auto",
        "is chosen per log: a log too long for memory is fitted block by block",
    ),
    "--block-samples": ("block_samples", 65536, "is chosen per log (65536 when it streams)"),
}
_ONLY_WITH_EACH = ("scheduler", "scheduler_timeout", "out", "against")


def check_fleet_flags(args) -> None:
    """Refuse flags that do not apply: fleet flags without ``--each``, single-fit flags with it.

    Parameters
    ----------
    args : argparse.Namespace

    Raises
    ------
    InputError
        The message names the flags and what to do.
    """
    from ..errors import InputError

    if not args.each:
        given = ["--" + k.replace("_", "-") for k in _ONLY_WITH_EACH if getattr(args, k, None)]
        if getattr(args, "joint", False):  # one fit spread over a cluster: --scheduler applies
            given = [g for g in given if g not in ("--scheduler", "--scheduler-timeout")]
        if given:
            raise InputError(
                f"{', '.join(given)} appl{'y' if len(given) > 1 else 'ies'} to a fleet, one fit "
                "per file: add --each (e.g. physid identify logs/*.h5 --model robot.urdf --each "
                "--out fleet/; --scheduler also spreads one --joint fit), or leave "
                f"{'them' if len(given) > 1 else 'it'} out."
            )
        return
    for flag, (attr, default, why) in _NOT_WITH_EACH.items():
        if getattr(args, attr, default) != default:
            raise InputError(f"{flag} with --each: {flag} {why}. Leave one of them out.")
    if args.method == "input-error":
        raise InputError(
            "--each fits the files with an idim-* method (one linear fit per log); "
            "--method input-error is not available for fleets. Use --method idim-ols|idim-wls|"
            "idim-iv, or fit the files one by one."
        )
    if not args.out:
        raise InputError(
            "--each needs --out DIR, the fleet's folder (fleet.csv, results/<file>.json per "
            "log, fleet.html): e.g. --out fleet/."
        )
    if args.scheduler_timeout is not None and not args.scheduler_timeout > 0:
        raise InputError(
            f"--scheduler-timeout must be a positive number of seconds; got "
            f"{args.scheduler_timeout!r}."
        )
    check_output_folder(args.out, "--out")


def _load_options(args, model) -> dict:
    """`physid.load_recording` keywords from the reading options and the model's table."""
    from ..signals.io import parse_channel_map
    from ._recordings import _model_channel_map, _table_name

    table = _model_channel_map(args, model)
    # without --resample, no "resample" key: a ROS bag read whole is resampled (run_fleet)
    chosen = {"resample": True} if getattr(args, "resample", False) else {}
    return {
        **chosen,
        "channels": parse_channel_map(getattr(args, "channel_map", None)) or None,
        "uniform_rtol": 1e-3,
        "decimal": getattr(args, "decimal", ".") or ".",
        "delimiter": getattr(args, "delimiter", None),
        "channel_defaults": table or None,
        "channel_defaults_source": _table_name(args),
        "rate": getattr(args, "rate", None),
        "joint_names": getattr(model, "joint_names", None),  # a ROS bag's joints, by name
    }


def run_each(args, model, method: str, fit_options: dict) -> int:
    """Run the fleet and print its table; 0 when every file fitted with success, else 1.

    Parameters
    ----------
    args : argparse.Namespace
    model : model
        The loaded model (for the method's default and the channel table; the workers load
        their own from ``--model``).
    method : str
    fit_options : dict
        `IDIMEstimator` keywords from the command line.

    Returns
    -------
    int
    """
    from .._progress import is_enabled
    from ..analysis.fleet import run_fleet
    from ..analysis.sweep_backends import SCHEDULER_TIMEOUT
    from ..errors import InputError

    if method not in ("idim-ols", "idim-wls", "idim-iv"):
        raise InputError(
            f"--each fits with an idim-* method; the model {args.model!r} is not linear in its "
            "parameters (its default is --method input-error). Give --method idim-ols for a "
            "linear model."
        )
    options = {"kinetic": args.kinetic} if args.kinetic is not None else {}
    flags = dict(getattr(args, "argument_flags", {}) or {})
    flags.update(against="--against", scheduler="--scheduler", paths="recording")
    n = len(args.recordings)
    progress(f"identify --each ({method}): {n} file{'s' if n > 1 else ''}")
    result = run_fleet(
        args.model,
        args.recordings,
        method=method,
        fit_options=fit_options,
        load_options=_load_options(args, model),
        scheduler=args.scheduler or "local",
        against=args.against,
        progress=is_enabled(),
        model_options=options,
        flags=flags,
        scheduler_timeout=args.scheduler_timeout or SCHEDULER_TIMEOUT,
    )
    for row in result.rows:  # the reasons in the command line's words
        row["reason"] = in_blocks_words(row["reason"])
    from ..report.fleet import write_fleet_report

    paths = write_fleet_report(result, args.out)
    progress(f"identify --each: wrote {paths['csv']}, {paths['html']} and {paths['results']}/")
    if "parquet_note" in paths:
        progress(f"physid: note: {paths['parquet_note']}")
    if args.json:
        print_json(
            {
                "format": "physid-fleet",
                "success": result.success,
                "columns": list(result.columns),
                "rows": [dict(r) for r in result.rows],
                "moved": result.moved() if result.reference is not None else None,
                "notes": list(result.notes),
                "outputs": {k: str(v) for k, v in paths.items()},
            }
        )
    else:
        print(result.summary())
    return 0 if result.success else 1


def run_joint_on_cluster(args, model, method: str, fit_options: dict):
    """``--joint --scheduler``: one fit over all the files as a map-reduce on Dask.

    Parameters
    ----------
    args : argparse.Namespace
    model : model
        The loaded model (the workers load their own from ``args.model``).
    method : str
    fit_options : dict
        `IDIMEstimator` keywords from the command line.

    Returns
    -------
    IDIMResult

    Raises
    ------
    InputError
        Settings a joint fit over a cluster does not take, named by their flags.
    """
    from ..analysis.fleet_joint import JOINT_SETTINGS, run_joint
    from ..analysis.sweep_backends import SCHEDULER_TIMEOUT
    from ..errors import DataFileError, InputError

    if method not in ("idim-ols", "idim-wls"):
        raise InputError(
            f"--joint --scheduler spreads one fit's normal equations over a cluster: --method "
            f"idim-ols or idim-wls (got --method {method}); leave --scheduler out to fit in "
            "this process."
        )
    if getattr(args, "stream", "auto") == "off":
        raise InputError(
            "--stream off with --joint --scheduler: the fit over a cluster reads every log block "
            "by block; leave --stream off out, or leave --scheduler out to fit in this process."
        )
    flags = {"stderr": ("--stderr hac", "hac"), "consistent": ("--consistent", True)}
    for key, (flag, bad) in flags.items():
        if fit_options.get(key) == bad:
            raise InputError(
                f"--joint --scheduler cannot take {flag} (it needs every row in one place); "
                "leave one of them out."
            )
    for flag, attr in (("--join", "join"), ("--joints", "joints"), ("--detrend", "detrend"),
                       ("--topic", "topic"), ("--resample", "resample")):  # fmt: skip
        if getattr(args, attr, None):
            raise InputError(
                f"{flag} with --joint --scheduler: each worker reads its log as it is; leave "
                f"{flag} out, or leave --scheduler out to fit in this process."
            )
    options = {k: v for k, v in fit_options.items() if k in JOINT_SETTINGS}
    model_options = {"kinetic": args.kinetic} if args.kinetic is not None else {}
    progress(f"identify --joint ({method}) over {len(args.recordings)} logs on {args.scheduler}")
    try:
        return run_joint(
            args.model,
            args.recordings,
            method=method,
            fit_options=options,
            load_options=_load_options(args, model),
            scheduler=args.scheduler,
            model_options=model_options,
            scheduler_timeout=args.scheduler_timeout or SCHEDULER_TIMEOUT,
            block_samples=getattr(args, "block_samples", 65536),
        )
    except DataFileError as exc:
        raise _scheduler_fix(exc) from None


def _scheduler_fix(exc):
    """A log's error under ``--joint --scheduler``, less the fixes that mode refuses (reading
    the bag whole, resample, join, keeping the times): a gap keeps its split; jitter gets the
    one fix it has, leave --scheduler out."""
    from ..errors import DataFileError

    text = str(exc)
    if _WHOLE_READ.search(text):  # a field emptied partway: filling it is the fix left
        return DataFileError(_WHOLE_READ.sub("", text))
    if "not uniformly sampled" not in text:
        return exc
    for dropped in (KEEP_TIMES, JOIN_SPLITS):
        text = dropped.sub("", text)
    refused = ("resample=True", "uniform_rtol=None", "split the bag")
    kept = [s for s in re.split(r"(?<=\.) (?=[A-Za-z])", text) if not any(r in s for r in refused)]
    text = " ".join(kept).rstrip(";,. ") + "."
    if "resample=True" not in str(exc):
        return DataFileError(text)
    return DataFileError(
        text + " With --joint --scheduler each worker reads its log in blocks as it is: leave "
        "--scheduler out to fit in this process, where --resample reads a jittered log whole "
        "and resamples it."
    )


def in_blocks_words(reason: str) -> str:
    """A fleet's reason for a log read in blocks, in the command line's words, less the fix
    a fleet refuses (reading the bag whole: fleets take no --stream nor joined --topic)."""
    return cli_words(_WHOLE_READ.sub("", reason))
