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

from ._common import (
    add_recording_options,
    check_output_folder,
    print_json,
    progress,
    read_recording,
)

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
            "band (MATLAB resid). Relative errors are fractions."
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
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    parser.add_argument(
        "--plot", default=None, metavar="DIR", help="write PNG figures and DIR/index.html"
    )
    parser.set_defaults(func=run)


def run(args) -> int:
    from ..analysis.validation import load_result, validate

    check_output_folder(args.plot, "--plot")  # before any work
    loaded = load_result(args.result, model=args.model)
    # the held-out file is read like the fit's (--map, units, --detrend; checked against the
    # model), with the [recording] table of the model file the result names when --model is not
    # given (it used to be read only from --model)
    import argparse

    reading = argparse.Namespace(**{**vars(args), "model": args.model or loaded.data.get("model")})
    rec = read_recording(reading, args.file, model=getattr(loaded, "model", None))
    progress(f"validate: {loaded.method} result on {args.file} ({rec.n_samples} samples)")
    report = validate(loaded, rec)
    if args.plot:
        from ..report.validation import write_validation_plots

        written = write_validation_plots(report, args.plot)
        progress(f"validate: figures in {written['index']}")
    if args.json:
        print_json(report.to_dict())
    else:
        print(report.summary())
    return 1 if report.failures else 0
