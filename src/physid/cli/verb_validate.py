"""``physid validate RESULT.json held-out.csv``: is the identified model any good?

Runs the three tests of `physid.analysis.validation` on a held-out recording: (a) the
inverse-model cross-test (relative force/torque error per channel and overall, on the filtered
signals the fit used), (b) the output-error test (MATLAB ``compare``'s fit [%] per output and the
relative error), (c) residual whiteness and independence from the input (MATLAB ``resid``, ±25
lags, 99 % band). ``--json`` prints ``{"relative_error": {"overall": …, "<channel>": …},
"fit_percent": {…}, "output_relative_error": {…}, "residual": {…}, "notes": […]}`` (relative
errors as fractions); ``--plot DIR`` writes PNGs and ``DIR/index.html``.
"""

from __future__ import annotations

from ..errors import InputError
from ._common import check_output_folder, cli_words, float_list, print_json, progress
from ._recordings import add_recording_options, read_recording

ORDER = 45


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "validate",
        help="validate an identified model on held-out data (cross-test, fit, residuals)",
        description=(
            "Validate a result file (physid estimate ... --save RESULT.json) on a held-out "
            "recording: (a) inverse-model relative error of the forces/torques on the filtered "
            "signals the fit used (the robotics convention), (b) output-error fit "
            "100(1-|y-yhat|/|y-mean(y)|) per output (MATLAB compare), (c) residual "
            "autocorrelation and cross-correlation with the input at +-25 lags against the 99 % "
            "band (MATLAB resid). Relative errors are fractions. A held-out file on another "
            "sampling period is refused unless --resample (onto the fit's period)."
        ),
    )
    parser.add_argument("result", metavar="RESULT.json", help="result file of the fit")
    parser.add_argument("file", metavar="F", help="held-out recording (.csv, .npz, .mat, .h5)")
    parser.add_argument(
        "--model",
        default=None,
        metavar="MODEL",
        help=(
            "the model, where the result file does not name it or names a model file not "
            "found here ('msd', a model file, ...)"
        ),
    )
    add_recording_options(parser)
    parser.add_argument(
        "--kp",
        default=None,
        metavar="LIST",
        help="PD proportional gains [N·m/rad] of the closed-loop re-simulation, one per joint "
        "(default: the result file's, else the held-out file's metadata)",
    )
    parser.add_argument(
        "--kd",
        default=None,
        metavar="LIST",
        help="PD derivative gains [N·m·s/rad], one per joint (default: as --kp)",
    )
    parser.add_argument(
        "--feedforward",
        choices=("none", "gravity", "gravity+friction"),
        default=None,
        help="feed-forward the controller added to PD (default: the held-out file's metadata)",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    parser.add_argument(
        "--plot", default=None, metavar="DIR", help="write PNG figures and DIR/index.html"
    )
    parser.set_defaults(func=run)


def run(args) -> int:
    from ..analysis.validation import load_result, validate

    check_output_folder(args.plot, "--plot")  # before any work
    controller = {
        "kp": float_list(args.kp, "--kp") if args.kp is not None else None,
        "kd": float_list(args.kd, "--kd") if args.kd is not None else None,
        "feedforward": args.feedforward,
    }
    structure = _structure_result(args, controller)
    if structure is not None:
        return structure
    loaded = load_result(args.result, model=args.model)
    # the held-out file is read like the fit's (--map, units, --detrend; checked against the
    # model), with the [recording] table of the model file the result names when --model is not
    # given (it used to be read only from --model)
    import argparse

    reading = argparse.Namespace(**{**vars(args), "model": args.model or loaded.data.get("model")})
    # --resample: onto the fit's sample period (the fit's filters are defined per sample)
    fit_dt = (loaded.data.get("settings") or {}).get("dt", loaded.data.get("dt"))
    period = float(fit_dt) if args.resample and _finite(fit_dt) else None
    rec = read_recording(reading, args.file, model=getattr(loaded, "model", None), period=period)
    progress(f"validate: {loaded.method} result on {args.file} ({rec.n_samples} samples)")
    try:
        report = validate(loaded, rec, **controller)
    except InputError as exc:  # another sample period: name the flag that resamples
        if "(Recording.resample)" not in str(exc):
            raise
        raise InputError(cli_words(str(exc))) from None
    if args.plot:
        from ..report.validation import write_validation_plots

        written = write_validation_plots(report, args.plot, recording=rec)
        progress(f"validate: figures in {written['index']}")
    if args.json:
        print_json(report.to_dict())
    else:
        print(report.summary())
    return 1 if report.failures else 0


def _finite(value) -> bool:
    import math

    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _structure_result(args, controller):
    """Validate an equation-error / output-error result of a structure: fit [%] per output of
    the model simulated on the held-out forces. None when the file is another kind."""
    from pathlib import Path

    from ..analysis.validation.result_file import read_result_json

    data = read_result_json(Path(args.result))  # size, nesting and values checked
    if data.get("method") not in ("equation-error", "output-error"):
        return None
    named = [f"--{k}" for k, v in controller.items() if v is not None]
    if named:
        raise InputError(
            f"{', '.join(named)}: a {data['method']} result is simulated from rest on the "
            "held-out forces, with no controller; leave them out."
        )
    from ..estimators.equation_error import StructureResult
    from ..models import load_model

    model = load_model(args.model or data.get("model"))
    rec = read_recording(args, args.file, model=model)
    known = {k: v for k, v in (data.get("known") or {}).items() if k in model.parameters}
    result = StructureResult(
        method=data["method"],
        names=tuple(data["names"]),
        parameters=data["parameters"],
        stderr=data.get("stderr"),
        stderr_reason=data.get("stderr_reason"),
        units={},
        success=bool(data.get("success")),
        message="",
        known=known,
        model=model,
        covariance=_covariance(data.get("covariance"), len(data["names"])),
    )
    from ..analysis.validation.structure import summary_lines, validate_structure

    progress(f"validate: {data['method']} result on {args.file} ({rec.n_samples} samples)")
    report = validate_structure(result, rec)
    if args.json:
        print_json(report)
    else:
        print("\n".join(summary_lines(report)))
    return 0 if report["consistent"] else 1


def _covariance(value, p: int):
    """The result file's covariance as a (p, p) finite array, or None (absent or malformed: the
    parameter-uncertainty explanation of the residual tests is then not tried)."""
    import numpy as np

    try:
        cov = np.array(value, dtype=float)
    except (TypeError, ValueError):
        return None
    return cov if cov.shape == (p, p) and np.all(np.isfinite(cov)) else None
