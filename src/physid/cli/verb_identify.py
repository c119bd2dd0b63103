"""``physid identify``: input-error identification of a manipulator's parameters."""

from __future__ import annotations

import argparse
import warnings

from ._common import (
    add_recording_options,
    assignments,
    float_list,
    print_json,
    progress,
    read_recording,
)

ORDER = 30


ARGUMENT_FLAGS = {"fixed": "--fix"}  # InputErrorEstimator(fixed=...) is --fix here


def _cutoff(text: str):
    """``--cutoff``: a number [rad/sample] or ``auto``."""
    if text.strip().lower() == "auto":
        return "auto"
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be 'auto' or a number in (0, π] [rad/sample]; got {text!r}"
        ) from None


def register(subparsers) -> None:
    """Add the ``identify`` verb."""
    p = subparsers.add_parser(
        "identify",
        help="identify masses and lengths of a manipulator (input-error method)",
        description=(
            "Identify the physical parameters of a chain model from a recording by minimising "
            "the residual of the equations of motion evaluated on filtered signals (Cedro & "
            "Janecki, section 5). Prints the estimates, their standard errors, the paper's "
            "quality factor J and the combinations the data cannot separate."
        ),
    )
    p.add_argument(
        "recording",
        help="recording file (CSV/NPZ/MAT/HDF5) with t, q1..qn and tau1..taun or r1..rn",
    )
    p.add_argument("--model", required=True, help="'manipulator' or a TOML model file")
    p.add_argument(
        "--kinetic",
        choices=("exact", "paper"),
        default=None,
        help="kinetic energy of the built-in manipulator: exact, or the paper's (no cross terms) "
        "(default: the model's own, exact for 'manipulator')",
    )
    p.add_argument(
        "--half-width",
        type=int,
        default=None,
        metavar="M",
        help="filter half-width M (2M+1 taps; default: chosen with --cutoff auto, else 100)",
    )
    p.add_argument(
        "--cutoff",
        type=_cutoff,
        default="auto",
        metavar="W|auto",
        help="filter cut-off Ω_g [rad/sample], or 'auto' (default): M and Ω_g chosen from the "
        "spectrum of q, the choice printed on stderr (the paper: --half-width 100 --cutoff 0.2)",
    )
    p.add_argument(
        "--initial",
        default=None,
        metavar="NAME=VALUE,...",
        help="starting values, e.g. m1=50.1,m2=25.1 (others: the model's nominal values)",
    )
    p.add_argument(
        "--fix", default=None, metavar="NAME=VALUE,...", help="parameters held fixed, e.g. l1=0.4"
    )
    p.add_argument(
        "--torque",
        choices=("measured", "pd"),
        default="measured",
        help="measured tau1..taun, or rebuilt from the PD law with r1..rn and the gains "
        "(default: measured)",
    )
    p.add_argument(
        "--kp",
        default=None,
        metavar="LIST",
        help="PD proportional gains [N·m/rad], only with --torque pd (default: file metadata)",
    )
    p.add_argument(
        "--kd",
        default=None,
        metavar="LIST",
        help="PD derivative gains [N·m·s/rad], only with --torque pd (default: file metadata)",
    )
    p.add_argument(
        "--start",
        choices=("initial", "linear"),
        default="initial",
        help="start from the initial values, or from the linear base-parameter solution "
        "(default: initial)",
    )
    p.add_argument(
        "--derivatives",
        choices=("consistent", "paper"),
        default="consistent",
        help="derivative filters built from the low-pass (default; no filter bias), or the "
        "paper's Filtr1/Filtr2 (to reproduce its numbers, m1*l1**2 biased by ~3 %%)",
    )
    p.add_argument(
        "--noise",
        choices=("ignore", "compensate"),
        default="ignore",
        help="ignore the noise on q, or compensate its errors-in-variables bias (the noise level "
        "is estimated from the spectrum; standard errors from re-noised replicates) "
        "(default: ignore)",
    )
    add_recording_options(p)
    p.add_argument(
        "--max-nfev", type=int, default=200, help="budget of residual evaluations (default: 200)"
    )
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    """Load, fit, print; returns the exit status (0 on a successful fit, 1 otherwise)."""
    import physid

    from ..estimators.input_error import InputErrorEstimator

    options = {}
    if args.kinetic is not None:
        options["kinetic"] = args.kinetic
    model = physid.load_model(args.model, **options)
    recording = read_recording(args, args.recording, model=model)
    estimator = InputErrorEstimator(
        model,
        half_width=args.half_width,
        cutoff=args.cutoff,
        torque=args.torque,
        kp=float_list(args.kp, "--kp") if args.kp else None,
        kd=float_list(args.kd, "--kd") if args.kd else None,
        fixed=assignments(args.fix, "--fix") or None,
        start=args.start,
        derivatives=args.derivatives,
        max_nfev=args.max_nfev,
        noise=args.noise,
    )
    progress(f"identify: {recording!r}")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        estimator.fit(recording, initial=assignments(args.initial, "--initial"))
    for w in caught:
        progress(f"warning: {w.message}")
    result = estimator.result_
    if result.filter_choice:
        progress(f"identify: {result.filter_choice}")
    if args.json:
        print_json(
            {
                "parameters": result.parameters,
                "stderr": result.stderr,
                "cost": result.cost,
                "nfev": result.nfev,
                "njev": result.njev,
                "iterations": result.njev,
                "success": result.success,
                "message": result.message,
                "unidentifiable": list(result.unidentifiable),
                "unidentifiable_text": list(result.unidentifiable_text),
                "combinations": result.combinations,
                "fixed": result.fixed,
                "half_width": result.half_width,
                "derivatives": args.derivatives,
                "cutoff": result.cutoff,
                "filter_choice": result.filter_choice,
                "noise_std": list(result.noise_std),
                "torque": result.torque,
                "at_bound": list(result.at_bound),
            }
        )
    else:
        print(result.summary())
    return 0 if result.success else 1
