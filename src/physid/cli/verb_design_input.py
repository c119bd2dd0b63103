"""``physid design-input msd``: the variance factor K(Z, λ) of the recursive estimator and the best
sinusoidal input frequency ratio Z = ω1/ω0 (Oueslati et al. 2011, section 3.B–3.D)."""

from __future__ import annotations

import math

from ..errors import InputError
from ._common import check_figure_path, float_list, print_json, progress

ORDER = 70

__all__ = ["ORDER", "register", "run"]


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "design-input",
        help="variance of the recursive (RLS) estimator vs input frequency; the optimal ratio Z",
        description=(
            "Evaluate K(Z, λ, ω0, T_s, m, k), the variance factor of the recursive estimator of "
            "θ2 = ω0² for a sinusoidal input u = A1 sin(Z ω0 t) (Var θ̂2 = σ²/A1² K), over a range "
            "of ratios Z and forgetting factors λ, and find the Z that minimises it."
        ),
    )
    p.add_argument("model", help="the model: 'msd' (the analysis is for the mass-spring-damper)")
    p.add_argument(
        "--samples",
        type=int,
        default=100,
        metavar="K",
        help="estimation horizon k in samples (default 100, the paper's)",
    )
    p.add_argument(
        "--init-samples",
        type=int,
        default=3,
        metavar="M",
        help="samples m before the first row (default 3, the paper's)",
    )
    p.add_argument(
        "--forgetting",
        default="0.95,0.98,0.99,1",
        metavar="LIST",
        help="comma-separated forgetting factors in (0, 1] (default 0.95,0.98,0.99,1)",
    )
    p.add_argument(
        "--ratio-range",
        type=float,
        nargs=2,
        default=(0.01, 2.0),
        metavar=("LO", "HI"),
        help="range of Z = ω1/ω0 searched and plotted (default 0.01 2)",
    )
    p.add_argument(
        "--sample-period",
        type=float,
        default=1e-3,
        metavar="S",
        help="sample period T_s [s] (default 0.001)",
    )
    p.add_argument(
        "--natural-frequency",
        type=float,
        default=None,
        metavar="W",
        help="ω0 [rad/s] (default: the model's nominal √θ2, √(400/3) for 'msd')",
    )
    p.add_argument(
        "--horizons",
        default=None,
        metavar="LIST",
        help="comma-separated horizons k for the λ = 1 study (default K×1,3,10,30)",
    )
    p.add_argument(
        "--points",
        type=int,
        default=200,
        metavar="N",
        help="points of the printed curve (default 200)",
    )
    p.add_argument("--plot", default=None, metavar="FILE.png", help="also save the figure")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(func=run)


def _summary(res, keys: list[str]) -> dict:
    """The result as one JSON object for ``--json`` (K as log10)."""
    return {
        "model": "msd",
        "parameters": res.parameters,
        "optimal_ratio": res.optimal_ratio_by_forgetting(),
        "optimal_log10_variance_factor": {
            k: math.log10(v) for k, v in zip(keys, res.optimal_variance_factor, strict=True)
        },
        "at_boundary": dict(zip(keys, res.at_boundary, strict=True)),
        "forgetting": list(res.forgetting),
        "curve": {
            "ratio": res.ratio,
            "log10_variance_factor": {
                k: [math.log10(v) for v in row]
                for k, row in zip(keys, res.variance_factor, strict=True)
            },
        },
        "horizons": {
            "samples": list(res.horizons),
            "optimal_ratio": list(res.horizon_optimal_ratio),
        },
        "natural_frequency": res.natural_frequency,
        "sample_period": res.sample_period,
        "init_samples": res.init_samples,
        "samples": res.samples,
        "success": res.success,
        "message": res.message,
    }


def _print_table(res, keys: list[str]) -> None:
    """The optimal ratio per forgetting factor and the horizon study, as text on stdout."""
    print(
        f"Variance factor K of the RLS estimator of θ2 (k = {res.samples}, "
        f"m = {res.init_samples}, "
        f"ω0 = {res.natural_frequency:.6g} rad/s, T_s = {res.sample_period:g} s), "
        f"Z in [{res.ratio[0]:g}, {res.ratio[-1]:g}]"
    )
    print(f"{'lambda':>8}  {'optimal Z':>10}  {'log10 K':>9}  note")
    for k, z, kv, edge in zip(
        keys, res.optimal_ratio, res.optimal_variance_factor, res.at_boundary, strict=True
    ):
        print(f"{k:>8}  {z:10.6f}  {math.log10(kv):9.4f}  {'end of range' if edge else ''}")
    print(
        "horizon study (λ = 1): "
        + ", ".join(
            f"k={h}: Z*={z:.4f}"
            for h, z in zip(res.horizons, res.horizon_optimal_ratio, strict=True)
        )
    )
    if res.message:
        print(res.message)


def run(args) -> int:
    from ..analysis.input_design import design_input
    from ..models.linear_ode import MSD_NATURAL_FREQUENCY

    if args.model.lower() != "msd":
        raise InputError(
            f"design-input analyses the mass-spring-damper; got model {args.model!r}. Use 'msd' "
            "(set its ω0 with --natural-frequency)."
        )
    if args.plot:
        check_figure_path(args.plot, "--plot")
    lams = float_list(args.forgetting, "--forgetting")
    if not lams:
        raise InputError("--forgetting needs at least one value, e.g. --forgetting 0.99,1.")
    horizons = None
    if args.horizons:
        horizons = [int(round(v)) for v in float_list(args.horizons, "--horizons")]
    # the model's own ω0 unless --natural-frequency is given
    w0 = MSD_NATURAL_FREQUENCY if args.natural_frequency is None else args.natural_frequency
    progress(
        f"design-input: K(Z) for λ = {lams}, k = {args.samples}, m = {args.init_samples}, "
        f"ω0 = {w0:.6g} rad/s, T_s = {args.sample_period:g} s"
    )
    res = design_input(
        forgetting=lams,
        ratio_range=tuple(args.ratio_range),
        n_ratios=args.points,
        natural_frequency=w0,
        sample_period=args.sample_period,
        init_samples=args.init_samples,
        samples=args.samples,
        horizons=horizons,
    )
    if args.plot:
        from ..report.style import save_figure

        save_figure(res.plot(), args.plot)
        progress(f"design-input: figure written to {args.plot}")
    keys = [f"{lam:g}" for lam in res.forgetting]
    if args.json:
        print_json(_summary(res, keys))
        return 0
    _print_table(res, keys)
    return 0
