"""``physid estimate F --model msd|MODEL.toml --method algebraic|rls``: linear ODE coefficients.

The algebraic method is the sliding-window estimator of `physid.estimators.algebraic`; rls is the
recursive least squares of `physid.estimators.recursive`. ``--json`` prints ``parameters`` (the
fitted coefficients), ``derived`` (for the MSD: natural_frequency, damping_ratio; the physical
parameters of a model in physical terms: mass, damping, stiffness for msd-force, m, c, k for
``a = ["k/m", "c/m"]``, ``b = ["1/m"]``), ``stderr`` (None with ``stderr_reason`` where not
defined), ``derived_stderr`` (delta method; None whenever ``stderr`` is), ``units``, ``success``,
``message`` (which says which physical parameters are not identifiable, and which combinations
are), ``valid_fraction``, ``fit_percent`` and ``physical`` (identifiable, unidentifiable,
combinations, message; null for models without expressions) and ``streamed``; ``--save
RESULT.json`` writes the result file that ``physid validate`` reads. ``--stream``: a long record
is fitted block by block in constant memory (`_estimate_stream`).
"""

from __future__ import annotations

import sys

from ..errors import InputError
from ._common import assignments, cli_words, print_json, progress
from ._estimate_stream import block_source, fit_streamed
from ._recordings import add_recording_options, read_recording
from ._streaming import add_stream_options

ORDER = 40

_ALGEBRAIC_ONLY = ("window", "mu", "integration", "block", "expanding", "final")
_RLS_ONLY = ("forgetting", "prefilter_cutoff", "init_samples", "bias_compensation")


def register(subparsers) -> None:
    """Add the ``estimate`` verb.

    Long by design: a flat argparse declaration, one ``add_argument`` per option.
    """
    parser = subparsers.add_parser(
        "estimate",
        help="estimate a linear ODE model's coefficients (algebraic or recursive least squares)",
        description=(
            "Estimate the coefficients of a linear ODE model (the built-in mass-spring-damper "
            "'msd' or a TOML model file) from a recording with the model's input and output "
            "channels (the MSD: u and x, or y). --method algebraic: the Fliess / Sira-Ramirez "
            "sliding-window estimator (Oueslati et al. 2011, section 4, corrected; "
            "docs/algebraic.md); "
            "--method rls: recursive least squares with forgetting (section 3). Progress goes to "
            "stderr; the result (a summary, or one JSON object with --json) to stdout."
        ),
    )
    parser.add_argument(
        "file",
        metavar="F",
        help="recording (.csv, .npz, .mat, .h5) with the model's input and output channels",
    )
    parser.add_argument(
        "--model",
        default="msd",
        metavar="MODEL",
        help="'msd' (default) or a path to a TOML linear ODE model file",
    )
    parser.add_argument(
        "--method",
        choices=["algebraic", "rls", "equation-error", "output-error"],
        default=None,
        help="estimator (default algebraic; structure models: equation-error or output-error, "
        "docs/structures.md)",
    )
    parser.add_argument(
        "--modal",
        action="store_true",
        help="structure models: print natural frequencies, damping ratios and mode shapes",
    )
    alg = parser.add_argument_group("algebraic method")
    alg.add_argument(
        "--window", type=float, default=None, metavar="S", help="window length T [s] (default 0.05)"
    )
    alg.add_argument(
        "--mu",
        type=int,
        default=None,
        metavar="N",
        help="smallest power of 1/s (default: model order + 1)",
    )
    alg.add_argument(
        "--integration",
        choices=["exact", "simpson", "trapezoid"],
        default=None,
        help="quadrature of the window integrals (default exact)",
    )
    alg.add_argument(
        "--block",
        type=int,
        default=None,
        metavar="K",
        help="least squares over K consecutive windows (default 1)",
    )
    alg.add_argument(
        "--expanding",
        action="store_true",
        default=None,
        help="estimate on the growing window [0, t0] before the first full window",
    )
    alg.add_argument(
        "--final",
        choices=["lstsq", "median", "bias-compensated"],
        default=None,
        help="final estimate: pooled least squares over the valid windows (lstsq), their "
        "median, or bias-compensated least squares over every full window (unbiased at low SNR) "
        "(default lstsq)",
    )
    rls = parser.add_argument_group("rls method")
    rls.add_argument(
        "--forgetting",
        type=float,
        default=None,
        metavar="L",
        help="forgetting factor in (0, 1] (default 1)",
    )
    rls.add_argument(
        "--prefilter-cutoff",
        type=float,
        default=None,
        metavar="HZ",
        help="cut-off of the derivative pre-filter [Hz] (default: automatic)",
    )
    rls.add_argument(
        "--init-samples",
        type=int,
        default=None,
        metavar="N",
        help="rows of the least-squares start (eq. 4), at least the number of unknowns "
        "(default 10 per unknown)",
    )
    rls.add_argument(
        "--bias-compensation",
        action="store_const",
        const=True,
        default=None,
        help="report the bias-compensated final estimate (errors in the variables removed) with "
        "its standard errors; without it, intervals the noise bias would spoil are withheld",
    )
    parser.add_argument(
        "--unknown",
        default=None,
        metavar="LIST",
        help="coefficients to estimate, comma-separated (default: the model's, less those "
        "given with --known)",
    )
    parser.add_argument(
        "--known",
        default=None,
        metavar="NAME=VALUE,...",
        help="values of known coefficients overriding the model's",
    )
    add_recording_options(parser)
    add_stream_options(
        parser.add_argument_group("long records"), "rls; algebraic with --final bias-compensated"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    parser.add_argument(
        "--save",
        default=None,
        metavar="RESULT.json",
        help="write the result file (parameters, units, settings, model) that 'physid validate' "
        "reads",
    )
    parser.set_defaults(func=run)


def _options(args, names) -> dict:
    return {k: getattr(args, k) for k in names if getattr(args, k) is not None}


def run(args) -> int:
    from ..models import load_model

    model = load_model(args.model)
    if hasattr(model, "nodes"):
        return _run_structure(args, model)
    if args.method in ("equation-error", "output-error") or args.modal:
        raise InputError(
            f"--method {args.method} and --modal apply to structure models (kind = "
            f'"structure"); --model {args.model!r} is not one.'
        )
    args.method = args.method or "algebraic"
    other = _RLS_ONLY if args.method == "algebraic" else _ALGEBRAIC_ONLY
    stray = [k for k in other if getattr(args, k) is not None]
    if stray:
        flags = ", ".join("--" + k.replace("_", "-") for k in stray)
        raise InputError(
            f"{flags} do(es) not apply to --method {args.method}; drop it or choose the other "
            "method."
        )
    if not hasattr(model, "a_names"):
        raise InputError(
            f"--model {args.model!r} is not a linear ODE model (it has no a_names); "
            "physid estimate needs 'msd' or a TOML file of kind 'linear_ode'. Use "
            "'physid identify' for chains."
        )
    common = {}
    if args.unknown is not None:
        common["unknown"] = tuple(n.strip() for n in args.unknown.split(",") if n.strip())
        if not common["unknown"]:
            raise InputError(
                f"--unknown expects names such as theta1,theta2; got {args.unknown!r}."
            )
    known = assignments(args.known, "--known")
    if known:
        common["known"] = known
    from ..estimators.registry import make

    options = _options(args, _ALGEBRAIC_ONLY if args.method == "algebraic" else _RLS_ONLY)
    est = make(args.method, model, **options, **common)
    result, streamed = _fit(args, model, est)
    if args.save:
        from ..estimators.results import save_result

        save_result(result, args.save, model=args.model, recording=args.file, model_options={})
        progress(f"estimate: result written to {args.save}")
    # the result's texts name Python settings; the command line shows its flags
    reason = cli_words(result.stderr_reason) if result.stderr_reason else result.stderr_reason
    if args.json:
        print_json(
            {
                "method": args.method,
                "names": list(result.names),
                "parameters": result.parameters,
                "derived": result.derived,
                "stderr": result.stderr,
                "derived_stderr": result.derived_stderr,
                "stderr_reason": reason,
                "units": result.units,
                "success": result.success,
                "message": result.message,
                "valid_fraction": result.valid_fraction,
                "fit_percent": result.fit_percent,
                "physical": result.physical,
                "streamed": streamed,
            }
        )
    else:
        print(cli_words(result.summary()))
    if not result.success:
        print(f"physid: estimate failed: {cli_words(result.message)}", file=sys.stderr)
    return 0 if result.success else 1


def _fit(args, model, est):
    """``(result, streamed)``: the fit of the file in memory, or block by block (``--stream``)."""
    src = block_source(args, model, args.method)
    what = f"estimate: {args.method} on {args.file}"
    if src is not None:
        progress(f"{what} ({src.n_samples} samples, model {args.model}), streamed")
        return fit_streamed(est, args.method, src, args.block_samples), True
    rec = read_recording(args, args.file, model=model)
    progress(f"{what} ({rec.n_samples} samples, model {args.model})")
    return est.fit(rec).result_, False


def _run_structure(args, model) -> int:
    """``physid estimate`` on a structure model (equation-error or output-error)."""
    method = args.method or "equation-error"
    if method not in ("equation-error", "output-error"):
        raise InputError(
            f"--method {method} does not apply to structure model {model.name!r}; use "
            "--method equation-error or output-error."
        )
    stray = [k for k in (*_ALGEBRAIC_ONLY, *_RLS_ONLY) if getattr(args, k) is not None]
    if stray or args.known:
        flags = ", ".join("--" + k.replace("_", "-") for k in stray) or "--known"
        raise InputError(f"{flags} do(es) not apply to structure models; drop it.")
    if args.stream == "on":
        raise InputError(
            f"--stream on: --method {method} fits structure models in memory only. Drop "
            "--stream on."
        )
    rec = read_recording(args, args.file, model=model)
    settings = {}
    if args.unknown is not None:
        settings["unknown"] = tuple(n.strip() for n in args.unknown.split(",") if n.strip())
    progress(f"estimate: {method} on {args.file} ({rec.n_samples} samples, model {model.name})")
    from ..estimators.registry import make

    result = make(method, model, **settings).fit(rec).result_
    if args.save:
        from ..estimators.results import save_result

        save_result(result, args.save, model=args.model, recording=args.file, model_options={})
        progress(f"estimate: result written to {args.save}")
    modal = result.modal() if args.modal else None
    if args.json:
        out = result.to_dict()
        out["covariance"] = None if result.covariance is None else out["covariance"]
        if modal is not None:
            out["modal"] = modal.to_dict()
        print_json(out)
    else:
        print(cli_words(result.summary()))
        print("  fit [%]: " + ", ".join(f"{k} {v:.2f}" for k, v in result.fit_percent.items()))
        if modal is not None:
            print(modal.summary())
    if not result.success:
        print(f"physid: estimate failed: {result.message}", file=sys.stderr)
    return 0 if result.success else 1
