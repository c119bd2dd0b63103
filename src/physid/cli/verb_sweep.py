"""``physid sweep msd``: the Monte-Carlo convergence study of the MSD over SNR × Z × estimators."""

from __future__ import annotations

import argparse
import math

from ..errors import InputError
from ._common import float_list, print_json, progress

ORDER = 50


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "sweep",
        help="Monte-Carlo sweep of the MSD estimators over SNR x frequency ratio (local or Dask)",
        description=(
            "Simulate the paper's mass-spring-damper (Oueslati et al. 2011) at every SNR and "
            "frequency ratio Z = w1/w0, TRIALS noise realisations each, estimate w0 with every "
            "estimator configuration on the same records, and measure the time to 2 % error. "
            "Writes DIR/trials.csv (one row per trial; trials.parquet too when pyarrow is "
            "installed), DIR/summary.json (per-cell statistics) and the convergence maps "
            "DIR/convergence_first_hit.png and DIR/convergence_settle.png. The same --seed gives "
            "the same table bit for bit on every backend. Progress goes to stderr."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument("system", choices=["msd"], help="the system to study")
    parser.add_argument("--snr", default="25,50,80", metavar="LIST", help="SNR values [dB]")
    parser.add_argument("--ratio", default="0.5,1,2,5,10", metavar="LIST", help="Z = w1/w0 values")
    parser.add_argument(
        "--trials", type=int, default=10, metavar="N", help="noise realisations per cell"
    )
    parser.add_argument(
        "--method",
        default="algebraic,rls",
        metavar="LIST",
        help="estimators: algebraic, rls (comma-separated)",
    )
    parser.add_argument(
        "--window",
        default="0.05",
        metavar="S",
        help="algebraic window length(s) [s] (comma-separated list allowed)",
    )
    parser.add_argument(
        "--forgetting",
        default="1",
        metavar="L",
        help="RLS forgetting factor(s) in (0, 1] (comma-separated list allowed)",
    )
    parser.add_argument(
        "--duration", type=float, default=5.0, metavar="S", help="record length [s]"
    )
    parser.add_argument("--dt", type=float, default=1e-3, metavar="S", help="sample period [s]")
    parser.add_argument("--seed", type=int, default=0, metavar="N", help="root seed")
    parser.add_argument(
        "--scheduler",
        default="local",
        metavar="ADDRESS",
        help="local (process pool), serial, local:N (Dask LocalCluster with N "
        "workers) or tcp://HOST:PORT (a running Dask scheduler)",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="processes of the local pool (default: every CPU)",
    )
    parser.add_argument("--out", required=True, metavar="DIR", help="output folder")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    parser.add_argument(
        "--json",
        action="store_true",
        help="print the summary (per-cell statistics) as JSON on stdout",
    )
    parser.set_defaults(func=run)


def _methods(text: str) -> list[str]:
    methods = [m.strip().lower() for m in text.split(",") if m.strip()]
    bad = [m for m in methods if m not in ("algebraic", "rls")]
    if bad or not methods:
        raise InputError(
            f"--method expects a comma-separated list of algebraic, rls; got {text!r}."
        )
    return methods


def _fmt_time(cell, column: str) -> str:
    stats = cell.get(column)
    if not isinstance(stats, dict):
        return "-"
    value = stats.get("median_censored")
    return "never" if value is None or not math.isfinite(value) else f"{value:.3g}"


def _fmt_pct(value) -> str:
    """A relative bias or spread as a percentage; "-" where undefined (e.g. one trial)."""
    if value is None or not math.isfinite(value):
        return "-"
    return f"{100 * value:.2g} %"


def run(args) -> int:
    from ..analysis.montecarlo import MSD_TIME_COLUMNS, msd_sweep, write_sweep
    from ..report.msd import plot_convergence_maps, variant_label

    if args.trials < 1:
        raise InputError(f"--trials must be >= 1; got {args.trials}.")
    result = msd_sweep(
        snr_db=float_list(args.snr, "--snr"),
        ratio=float_list(args.ratio, "--ratio"),
        trials=args.trials,
        methods=_methods(args.method),
        windows=float_list(args.window, "--window"),
        forgettings=float_list(args.forgetting, "--forgetting"),
        duration=args.duration,
        dt=args.dt,
        seed=args.seed,
        scheduler=args.scheduler,
        workers=args.workers,
        progress=not args.no_progress,
    )
    cells = result.summarize()  # once: the maps, the table and --json all read it
    figures = {
        f"convergence_{c.removeprefix('t_')}": plot_convergence_maps(cells, metric=c)
        for c in MSD_TIME_COLUMNS
    }
    paths = write_sweep(result, args.out, figures=figures)
    progress(f"sweep: {result.message}")
    if args.json:
        print_json(
            {
                "summary": str(paths["summary"]),
                "csv": str(paths["csv"]),
                "success": result.success,
                "message": result.message,
                "cells": cells,
            }
        )
        return 0
    print(
        f"{'estimator':<22} {'SNR':>6} {'Z':>6} {'ok':>7} {'first hit [s]':>14} {'settle [s]':>11}"
        f" {'ω0 bias':>9} {'ω0 spread':>10}"
    )
    for cell in cells:
        snr = "clean" if cell["snr_db"] is None else f"{cell['snr_db']:g}"
        acc = cell.get("accuracy", {}).get("omega0", {})
        print(
            f"{variant_label(cell):<22} {snr:>6} {cell['ratio']:>6g} "
            f"{cell['n_ok']:>3}/{cell['n']:<3} {_fmt_time(cell, 't_first_hit'):>14} "
            f"{_fmt_time(cell, 't_settle'):>11} {_fmt_pct(acc.get('relative_bias')):>9} "
            f"{_fmt_pct(acc.get('relative_spread')):>10}"
        )
    for key, path in paths.items():
        print(f"{key}: {path}")
    return 0
