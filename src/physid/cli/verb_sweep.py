"""``physid sweep msd|MODEL.toml``: Monte-Carlo convergence study over SNR × Z × estimators.

``msd`` is the paper's study (Oueslati et al. 2011: its 3 kg system and scenario); a linear-ODE
model file is swept the same way (`physid.analysis.studies.model_sweep`): its model driven by
u = A sin(Z ω_ref t) with ω_ref = |a_0|^(1/n) (ω0 for an oscillator).
"""

from __future__ import annotations

import argparse
import math
import sys

from ..errors import EstimationError, InputError
from ._common import check_output_folder, float_list, print_json, progress

ORDER = 50


def _count(text: str) -> int:
    """A positive count; ``1e3`` is accepted (an integer written in exponent form)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expects a whole number such as 20; got {text!r}"
        ) from None
    if not math.isfinite(value) or value != int(value) or value < 1:
        raise argparse.ArgumentTypeError(f"expects a whole number >= 1; got {text!r}")
    return int(value)


def register(subparsers) -> None:
    """Add the ``sweep`` verb.

    Long by design: a flat argparse declaration, one ``add_argument`` per option.
    """
    parser = subparsers.add_parser(
        "sweep",
        help="Monte-Carlo sweep of the linear-ODE estimators over SNR x frequency ratio "
        "(local or Dask)",
        description=(
            "Simulate the paper's mass-spring-damper (Oueslati et al. 2011; SYSTEM 'msd') or the "
            "linear-ODE model of a TOML file (driven by u = A sin(Z w_ref t), w_ref = |a_0|^(1/n), "
            "the natural frequency of an oscillator) at every SNR and frequency ratio Z, TRIALS "
            "noise realisations each, estimate the parameters with every estimator configuration "
            "on the same records, and measure the time to 2 % error. "
            "Writes DIR/trials.csv (one row per trial; trials.parquet too when pyarrow is "
            "installed), DIR/summary.json (per-cell statistics) and the convergence maps "
            "DIR/convergence_first_hit.png and DIR/convergence_settle.png. The same --seed gives "
            "the same table bit for bit on every backend. Progress goes to stderr."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument(
        "system",
        metavar="SYSTEM",
        help="'msd' (the paper's study) or a linear-ODE model file (TOML)",
    )
    parser.add_argument("--snr", default="25,50,80", metavar="LIST", help="SNR values [dB]")
    parser.add_argument("--ratio", default="0.5,1,2,5,10", metavar="LIST", help="Z = w1/w0 values")
    parser.add_argument(
        "--trials", type=_count, default=10, metavar="N", help="noise realisations per cell"
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
    parser.add_argument(
        "--amplitude",
        type=float,
        default=1.0,
        metavar="A",
        help="input amplitude A of a model file's sweep (unit of its input; 'msd' uses the "
        "paper's)",
    )
    parser.add_argument("--seed", type=int, default=0, metavar="N", help="root seed")
    parser.add_argument(
        "--scheduler",
        default="local",
        metavar="ADDRESS",
        help="local (process pool), serial, local:N (Dask LocalCluster with N "
        "workers) or tcp://HOST:PORT (a running Dask scheduler)",
    )
    parser.add_argument(
        "--scheduler-timeout",
        type=float,
        default=30.0,
        metavar="S",
        help="seconds to wait for a tcp:// scheduler to answer",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="processes of the local pool (default: every CPU)",
    )
    parser.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="output folder (written whole at the end: an interrupted sweep leaves it as it was)",
    )
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


def _is_msd(system: str) -> bool:
    return system.strip().lower() == "msd"


def run(args) -> int:
    from ..analysis.montecarlo import first_failure, write_sweep
    from ..report.msd import plot_convergence_maps, variant_label

    check_output_folder(args.out, "--out")  # before any trial runs
    common = dict(
        trials=args.trials,
        methods=_methods(args.method),
        windows=float_list(args.window, "--window"),
        forgettings=float_list(args.forgetting, "--forgetting"),
        duration=args.duration,
        dt=args.dt,
        seed=args.seed,
        scheduler=args.scheduler,
        workers=args.workers,
        # a log file gets a line per 10 %, a terminal a bar; none with --quiet or --json to a pipe
        progress=not (args.no_progress or args.quiet or _json_to_pipe(args)),
        scheduler_timeout=args.scheduler_timeout,
    )
    snr, ratio = float_list(args.snr, "--snr"), float_list(args.ratio, "--ratio")
    if _is_msd(args.system):
        from ..analysis.msd_study import MSD_TIME_COLUMNS, msd_sweep

        result = msd_sweep(snr_db=snr, ratio=ratio, **common)
    else:
        from ..analysis.studies import TIME_COLUMNS as MSD_TIME_COLUMNS
        from ..analysis.studies import model_sweep

        result = model_sweep(args.system, snr, ratio, amplitude=args.amplitude, **common)
    if not any(r["status"] == "ok" for r in result.rows):
        paths = write_sweep(result, args.out)  # the table says why, row by row
        raise EstimationError(
            f"every trial failed ({len(result.rows)} of {len(result.rows)}), so there is nothing "
            f"to summarise; {first_failure(result.rows, result.setting_columns)}. The table is in "
            f"{paths['csv']}."
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
    # the quantity whose bias and spread the table shows: ω0 for the MSD, else the first one
    # with a truth (the model file's first estimated parameter)
    keys = [k for c in cells for k in c.get("accuracy", {})]
    shown = "omega0" if "omega0" in keys or not keys else keys[0]
    label = "ω0" if shown == "omega0" else shown
    print(
        f"{'estimator':<22} {'SNR':>6} {'Z':>6} {'ok':>7} {'first hit [s]':>14} {'settle [s]':>11}"
        f" {label + ' bias':>9} {label + ' spread':>10}"
    )
    for cell in cells:
        snr = "clean" if cell["snr_db"] is None else f"{cell['snr_db']:g}"
        acc = cell.get("accuracy", {}).get(shown, {})
        print(
            f"{variant_label(cell):<22} {snr:>6} {cell['ratio']:>6g} "
            f"{cell['n_ok']:>3}/{cell['n']:<3} {_fmt_time(cell, 't_first_hit'):>14} "
            f"{_fmt_time(cell, 't_settle'):>11} {_fmt_pct(acc.get('relative_bias')):>9} "
            f"{_fmt_pct(acc.get('relative_spread')):>10}"
        )
    for key, path in paths.items():
        print(f"{key}: {path}")
    return 0


def _json_to_pipe(args) -> bool:
    """``--json`` with stdout not a terminal: the output is for a program, stderr stays quiet."""
    try:
        return bool(getattr(args, "json", False)) and not sys.stdout.isatty()
    except (AttributeError, ValueError):
        return bool(getattr(args, "json", False))
