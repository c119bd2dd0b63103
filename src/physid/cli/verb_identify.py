"""``physid identify``: identify a chain model's parameters from one or several recordings.

Methods: ``input-error`` (nonlinear least squares on filtered signals; the default for models
whose parameters enter nonlinearly, like the paper's masses and lengths) and ``idim-ols`` /
``idim-wls`` / ``idim-iv`` (inverse dynamic model least squares on the base parameters; the
default for models linear in their parameters, like URDF rigid bodies). Each method has its own
``_run_*`` function below; the options shared by all are registered once.
"""

from __future__ import annotations

import argparse
import warnings

from ._common import (
    assignments,
    cli_words,
    float_list,
    print_json,
    progress,
    report_warnings,
    torque_fit_line,
)
from ._recordings import add_recording_options, read_recordings, warn_implausible_estimates
from ._streaming import add_stream_options, wants_stream

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
    """Add the ``identify`` verb.

    Long by design: a flat argparse declaration, one ``add_argument`` per option.
    """
    p = subparsers.add_parser(
        "identify",
        help="identify the parameters of a manipulator (input-error or IDIM methods)",
        description=(
            "Identify the parameters of a chain model from one or several recordings. "
            "input-error minimises the residual of the equations of motion evaluated on "
            "filtered signals (Cedro & Janecki, section 5): estimates, standard errors, the "
            "paper's quality factor J and the combinations the data cannot separate. idim-ols, "
            "idim-wls and idim-iv estimate the base parameters by least squares on the filtered "
            "and decimated inverse dynamic model (Gautier; Janot-Gautier for IV): base "
            "parameters with expressions and standard errors, condition number, relative "
            "torque error per joint."
        ),
    )
    p.add_argument(
        "recordings",
        nargs="+",
        metavar="recording",
        help="recording file(s) (CSV/NPZ/MAT/HDF5) with t, q1..qn and tau1..taun (or r1..rn); "
        "several files are stacked by the idim-* methods, each filtered on its own",
    )
    p.add_argument(
        "--join",
        action="store_true",
        help="the files are the columns of one run (positions in one, currents in another), "
        "joined on their time stamps (or sample by sample with --rate); a name in several "
        "files becomes STEM.NAME (pos.Joint_1); a gap splits the run into segments",
    )
    p.add_argument("--model", required=True, help="'manipulator', a TOML or a URDF model file")
    p.add_argument(
        "--method",
        default=None,
        choices=("input-error", "idim-ols", "idim-wls", "idim-iv"),
        help="identification method (default: idim-ols for models linear in their parameters, "
        "input-error otherwise)",
    )
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
        help="filter half-width M (2M+1 taps; default: chosen with --cutoff auto; with a number "
        "for --cutoff: 100 for input-error, ceil(8π/cutoff) for idim-*)",
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
        help="PD proportional gains [N·m/rad], for --torque pd or --method idim-iv "
        "(default: file metadata)",
    )
    p.add_argument(
        "--kd",
        default=None,
        metavar="LIST",
        help="PD derivative gains [N·m·s/rad], for --torque pd or --method idim-iv "
        "(default: file metadata)",
    )
    p.add_argument(
        "--feedforward",
        choices=("none", "gravity", "gravity+friction"),
        default=None,
        help="--method idim-iv: the feed-forward the controller added to PD (default: metadata)",
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
        choices=("auto", "ignore", "compensate"),
        default="auto",
        help="compensate the errors-in-variables bias of the noise on q (the noise level is "
        "estimated from the spectrum; standard errors from re-noised replicates), ignore it, "
        "or auto: compensate when the spectrum shows noise (default: auto)",
    )
    add_recording_options(p)
    p.add_argument(
        "--max-nfev", type=int, default=200, help="budget of residual evaluations (default: 200)"
    )
    _register_idim_options(p)
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument(
        "--save",
        default=None,
        metavar="RESULT.json",
        help="write the result file (parameters, units, filter settings, model) that "
        "'physid validate' reads",
    )
    p.add_argument(
        "--joints",
        default=None,
        metavar="NAME,...",
        help="identify only these joints of a rigid-body model (a connected sub-tree, e.g. one "
        "arm of a robot that branches); the others must hold still in the log and are held at "
        "its positions",
    )
    _register_fleet_options(p)
    p.set_defaults(func=run)


def _register_fleet_options(p) -> None:
    """Options of a fleet: one fit per file (``--each``), on a Dask scheduler (docs/fleets.md)."""
    g = p.add_argument_group("fleets: one fit per file (docs/fleets.md)")
    g.add_argument(
        "--each",
        action="store_true",
        help="fit each file on its own (a fleet: one robot or run per file), written to --out as "
        "fleet.csv/.parquet, results/<file>.json and fleet.html; failed files are rows with the "
        "reason",
    )
    g.add_argument(
        "--joint",
        action="store_true",
        help="one fit over all the files, each an experiment of the same robot (the default for "
        "several files; the opposite of --each)",
    )
    g.add_argument(
        "--scheduler",
        default=None,
        metavar="local|local:N|tcp://HOST:PORT",
        help="with --each: where the fits run; with --joint: where one fit over all the files "
        "runs as a map-reduce of their normal equations (idim-ols, idim-wls): local (default: "
        "in-process for 1-2 files, else a Dask cluster with a worker per CPU), local:N (N worker "
        "processes) or the address of a running Dask scheduler",
    )
    g.add_argument(
        "--scheduler-timeout",
        type=float,
        default=None,
        metavar="S",
        help="with --each or --joint: seconds to wait for a tcp:// scheduler to answer "
        "(default 30)",
    )
    g.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help="with --each (required): the fleet's folder; written whole at the end, replacing "
        "only the fleet's own files",
    )
    g.add_argument(
        "--against",
        default=None,
        metavar="REFERENCE.json",
        help="with --each: a reference fit (identify --save) of the same model; flags each "
        "parameter that moved beyond |Δβ| > 1.96·sqrt(se² + se_ref²) (wear, payload change)",
    )


def _register_idim_options(p) -> None:
    """Options of the idim-* methods."""
    g = p.add_argument_group("IDIM options (idim-ols, idim-wls, idim-iv)")
    g.add_argument(
        "--decimate",
        default=None,
        metavar="ND|auto",
        help=(
            "parallel filtering and decimation: keep one sample in ND (default: auto, chosen "
            "by a cross-validated torque error among bands from the cut-off down to 1/32 of it)"
        ),
    )
    g.add_argument(
        "--differentiation",
        choices=("physid", "butterworth"),
        default="physid",
        help="state filter: physid's FIR differentiators, or zero-phase Butterworth + central "
        "differences (default: physid)",
    )
    g.add_argument(
        "--stderr",
        choices=("filtered", "hac", "iid"),
        default="filtered",
        help="standard errors: 'filtered', the sandwich with the correlation the parallel "
        "filter gives white torque noise (covers 94 %% of 400 trials on a 2-link arm where hac "
        "gives 85 %%); 'hac', Newey-West with an estimated correlation; 'iid', classical with "
        "a noise variance per joint (default: filtered)",
    )
    g.add_argument(
        "--consistent",
        action="store_true",
        help="also compute a physically consistent estimate (positive definite pseudo-inertia "
        "per link, friction >= 0) and print its standard parameters",
    )
    g.add_argument(
        "--max-iter", type=int, default=10, help="IDIM-IV iterations at most (default: 10)"
    )
    g.add_argument(
        "--stick-threshold",
        default="auto",
        metavar="F",
        help="which equations of a joint with dry friction to drop (stiction: the holding "
        "friction is unknown there): auto = where the measured position stays within its noise "
        "for a sustained interval, and next to speed reversals or below 0.2x the rms speed "
        "where a first fit's residual shows friction the model lacks; a number F in (0, 1) = "
        "where the filtered speed is below F times its rms; 0 keeps every equation (default: "
        "auto)",
    )
    add_stream_options(g, "idim-ols and idim-wls")


def run(args) -> int:
    """Load, fit, print; returns the exit status (0 on a successful fit, 1 otherwise)."""
    import physid

    from ._fleet import check_fleet_flags, run_each

    check_fleet_flags(args)  # before any file is read
    options = {}
    if args.kinetic is not None:
        options["kinetic"] = args.kinetic
    model = physid.load_model(args.model, **options)
    method = args.method or _default_method(model)
    _check_method_options(args, method)
    if args.each:
        return run_each(args, model, method, _idim_options(args, method))
    if args.joint and args.scheduler:
        from ._fleet import run_joint_on_cluster

        result = run_joint_on_cluster(args, model, method, _idim_options(args, method))
        return _print_idim(args, result, method)
    if wants_stream(args, args.recordings, model, method):
        return _run_streamed(args, model, method)
    recordings = read_recordings(args, args.recordings, model=model)
    if getattr(args, "joints", None):  # a connected sub-tree, the other joints held still
        model, recordings = _subtree(args, model, recordings)
    if method == "input-error":
        return _run_input_error(args, model, recordings)
    return _run_idim(args, model, recordings, method)


def _subtree(args, model, recordings):
    """``--joints``: the sub-tree model and the recordings renumbered for it."""
    from ..errors import InputError
    from ..models.subtree import subtree_model, subtree_recording

    if not hasattr(model, "chain"):
        raise InputError("--joints chooses joints of a rigid-body model (a URDF or sidecar).")
    if args.save:
        raise InputError(
            "--joints with --save: physid validate cannot rebuild the sub-tree model from a "
            "result file yet; validate the sub-tree by identifying on the held-out file too."
        )
    joints = [j.strip() for j in args.joints.split(",") if j.strip()]
    held, recordings = subtree_recording(model, joints, recordings)
    sub = subtree_model(model, joints, held)
    where = ", ".join(f"{k} = {v:.6g}" for k, v in held.items()) or "none"
    progress(f"identify: joints {', '.join(sub.joint_names)}; held still at the log's {where}")
    return sub, recordings


# Options that only one family of methods reads, with the value that means "not given". A flag
# the chosen method would ignore is refused: a silently dropped --fix is a wrong answer.
_INPUT_ERROR_ONLY = {
    "fix": ("--fix", None),
    "initial": ("--initial", None),
    "torque": ("--torque", "measured"),
    "noise": ("--noise", "auto"),
    "start": ("--start", "initial"),
    "derivatives": ("--derivatives", "consistent"),
    "max_nfev": ("--max-nfev", 200),
}
_IDIM_ONLY = {
    "decimate": ("--decimate", None),
    "differentiation": ("--differentiation", "physid"),
    "stderr": ("--stderr", "filtered"),
    "consistent": ("--consistent", False),
    "stick_threshold": ("--stick-threshold", "auto"),
    "stream": ("--stream", "auto"),
    "block_samples": ("--block-samples", 65536),
}


def _check_method_options(args, method: str) -> None:
    """Refuse options that ``method`` would ignore (before any file is read)."""
    from ..errors import InputError

    if method == "input-error":
        unused = dict(_IDIM_ONLY, max_iter=("--max-iter", 10), feedforward=("--feedforward", None))
        family = "the idim-* methods"  # --kp/--kd without --torque pd: the estimator refuses
    else:
        unused = dict(_INPUT_ERROR_ONLY)
        family = "--method input-error"
        if method != "idim-iv":
            unused.update(kp=("--kp", None), kd=("--kd", None), max_iter=("--max-iter", 10))
            unused.update(feedforward=("--feedforward", None))
    given = [flag for name, (flag, default) in unused.items() if getattr(args, name) != default]
    if not given:
        return
    verb = "apply" if len(given) > 1 else "applies"
    if method in ("idim-ols", "idim-wls") and set(given) <= {
        "--kp",
        "--kd",
        "--max-iter",
        "--feedforward",
    }:
        raise InputError(
            f"{', '.join(given)} {verb} to --method idim-iv (its simulated closed loop); "
            f"--method {method} does not use {'them' if len(given) > 1 else 'it'}. Use --method idim-iv, or leave them out."
        )
    raise InputError(
        f"{', '.join(given)} {verb} to {family}, not to --method {method}, which would ignore "
        f"{'them' if len(given) > 1 else 'it'}. Leave {'them' if len(given) > 1 else 'it'} out"
        + (
            " (IDIM estimates the base parameters, all of them, from the measured torques), "
            "or use --method input-error."
            if method != "input-error"
            else ", or use --method idim-ols|idim-wls|idim-iv."
        )
    )


def _save(args, result) -> None:
    """Write ``--save RESULT.json`` (the file ``physid validate`` reads)."""
    if not args.save:
        return
    from ..estimators.results import save_result

    # how the model was loaded and the gains given on the command line, so that validate
    # rebuilds the same model and the same PD torque (not the defaults, not the held-out
    # record's metadata)
    options = {"kinetic": args.kinetic} if args.kinetic is not None else {}
    gains = {k: float_list(getattr(args, k), "--" + k) for k in ("kp", "kd") if getattr(args, k)}
    save_result(
        result,
        args.save,
        model=args.model,
        recording=args.recordings[0],
        model_options=options,
        gains=gains or None,
        feedforward=getattr(args, "feedforward", None),
    )
    progress(f"identify: result written to {args.save}")


def _default_method(model) -> str:
    """idim-ols for models linear in their parameters (β(θ) = θ up to order), else input-error."""
    import numpy as np

    try:
        jac = np.asarray(model.beta_jacobian(), dtype=float)
        theta = np.asarray(model.parameter_vector(None), dtype=float)
        jac2 = np.asarray(model.beta_jacobian(2.0 * theta + 1.0), dtype=float)
    except Exception:  # no linear form at all
        return "input-error"
    return "idim-ols" if np.allclose(jac, jac2) else "input-error"


def _run_input_error(args, model, recordings) -> int:
    from ..errors import InputError
    from ..estimators.input_error import InputErrorEstimator

    if len(recordings) > 1:
        raise InputError(
            f"--method input-error fits one recording; got {len(recordings)} files. Give one "
            "file, or use --method idim-ols|idim-wls|idim-iv to stack several."
        )
    recording = recordings[0]
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
    report_warnings(caught, args)  # now, before the result: "physid: warning:" with flags
    result = estimator.result_
    warn_implausible_estimates(model, result, recordings)
    _save(args, result)
    if result.filter_choice:
        progress(f"identify: {result.filter_choice}")
    if args.json:
        schema = result.to_dict()  # the result schema every --json shares (format, names, ...)
        print_json(
            {
                **{k: schema[k] for k in ("format", "format_version", "method", "names")},
                "parameters": result.parameters,
                "derived": result.derived,
                "stderr": result.stderr,
                "stderr_reason": result.stderr_reason,
                "units": result.units,
                "parameter_set": result.parameter_set,
                # base parameters (mcx1R): the kept column of each and what it combines
                "columns": list(result.columns),
                "base_expressions": result.base_expressions,
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
        print(cli_words(result.summary()))
        print(torque_fit_line(result))
    return 0 if result.success else 1


def _idim_options(args, method: str) -> dict:
    """The `IDIMEstimator` keywords (after the method) given by the command line."""
    from ..errors import InputError

    decimate = "auto"
    if args.decimate not in (None, "auto"):
        try:
            decimate = int(args.decimate)
        except ValueError:
            raise InputError(
                f"--decimate expects a positive integer or auto; got {args.decimate!r}."
            ) from None
    return dict(
        differentiation=args.differentiation,
        cutoff="auto" if args.cutoff in (None, "auto") else args.cutoff,
        half_width=args.half_width,
        decimate=decimate,
        stderr=args.stderr,
        kp=float_list(args.kp, "--kp") if args.kp else None,
        kd=float_list(args.kd, "--kd") if args.kd else None,
        feedforward=args.feedforward,
        max_iter=args.max_iter,
        consistent=args.consistent,
        stick_threshold=args.stick_threshold,
    )


def _run_idim(args, model, recordings, method: str) -> int:
    from ..estimators.idim import IDIMEstimator

    options = _idim_options(args, method)
    estimator = IDIMEstimator(model, method.removeprefix("idim-"), **options)
    progress(f"identify ({method}): " + ", ".join(repr(r) for r in recordings))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        estimator.fit(recordings)
    report_warnings(caught, args)  # now, before the result: "physid: warning:" with flags
    result = estimator.result_
    warn_implausible_estimates(model, result, recordings)
    return _print_idim(args, result, method)


def _run_streamed(args, model, method: str) -> int:
    """``--stream``: the files read block by block, the fit in bounded memory."""
    from .._progress import is_enabled
    from ..estimators.idim.stream import STREAMED_SETTINGS, fit_streamed
    from ._streaming import open_sources

    options = _idim_options(args, method)
    sources = open_sources(args, args.recordings, model)
    progress(
        f"identify ({method}, streamed in blocks of {args.block_samples} samples): "
        + ", ".join(
            f"{s.n_samples} samples of {p}" for s, p in zip(sources, args.recordings, strict=True)
        )
    )
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = fit_streamed(
                model,
                sources,
                method=method.removeprefix("idim-"),
                block_samples=args.block_samples,
                progress=is_enabled(),
                **{k: options[k] for k in STREAMED_SETTINGS if k in options},
            )
    finally:
        for src in sources:
            getattr(src, "close", lambda: None)()
    report_warnings(caught, args)
    return _print_idim(args, result, method)


def _print_idim(args, result, method: str) -> int:
    """Save (``--save``) and print an IDIM result; the exit status."""
    _save(args, result)
    if args.json:
        out = result.to_dict()
        out.update(
            {
                "method": method,
                "base_parameters": [
                    {
                        "name": n,
                        "expression": result.base_expressions[n],
                        "value": result.parameters[n],
                        "stderr": None if result.stderr is None else result.stderr[n],
                        "unit": result.units.get(n, ""),
                    }
                    for n in result.names
                ],
                "iterations": result.iterations,
            }
        )
        if result.consistent is not None:
            out["standard_parameters"] = result.consistent.standard
        print_json(out)
    else:
        print(cli_words(result.summary()))
        print(torque_fit_line(result))
    return 0 if result.success else 1
