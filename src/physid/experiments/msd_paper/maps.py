"""Figs. 5–6 of the paper: convergence-time maps over SNR × Z from a Monte-Carlo sweep, and the
shortest usable algebraic window."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...analysis import metrics
from ...analysis.msd_study import msd_sweep
from ...estimators.registry import make
from ...simulate import msd_paper_scenario
from ..data import FigureData, SectionData, Table
from ._common import KEYS, SEED, TITLES, W0, WINDOW, algebraic, convergence, num, say


def variant_label(cell) -> str:
    """A short name for an estimator configuration: ``"algebraic T=0.05 s"``, ``"RLS λ=0.99"``.

    The same labels as `physid.report.msd.variant_label` (the sweep's figures).
    """
    method = cell.get("method")
    if method == "algebraic":
        window = cell.get("window")
        return "algebraic" + (f" T={window:g} s" if window is not None else "")
    if method == "rls":
        lam = cell.get("forgetting")
        return "RLS" + (f" λ={lam:g}" if lam is not None else "")
    return str(method)


def _median(values) -> float | None:
    finite = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.median(finite)) if finite else None


def _largest(values) -> float | None:
    finite = [abs(v) for v in values if v is not None and math.isfinite(v)]
    return max(finite) if finite else None


def _cell_rows(cells) -> tuple[list[tuple], dict[tuple, list[tuple[float, float]]]]:
    """One table row per cell, and each (estimator, SNR, rule)'s (Z, median time) pairs."""
    times: dict[tuple, list[tuple[float, float]]] = {}
    rows = []
    for c in cells:
        label = variant_label(c)
        hit = c["t_first_hit"]["median_censored"]
        settle = c["t_settle"]["median_censored"]
        acc = c.get("accuracy", {}).get("omega0", {})
        rows.append(
            (
                label,
                c["snr_db"],
                c["ratio"],
                c["n_ok"],
                num(hit),
                num(settle),
                num(c["final_error"]["median"]),
                num(acc.get("relative_bias", math.nan)),
                num(acc.get("relative_spread", math.nan)),
                num(acc.get("relative_rmse", math.nan)),
            )
        )
        for metric, value in (("first_hit", hit), ("settle", settle)):
            times.setdefault((label, c["snr_db"], metric), []).append((c["ratio"], value))
    return rows, times


def _fastest_of(times, label, snr, metric) -> tuple[list[float], float]:
    """Every Z that ties for the shortest finite median time, and that time (NaN: none)."""
    finite = [(z, v) for z, v in times.get((label, snr, metric), []) if math.isfinite(v)]
    if not finite:
        return [], math.nan
    best = min(v for _, v in finite)
    return [z for z, v in finite if v <= best * (1 + 1e-9)], best  # every Z that ties


def _fastest_rows(cells, snrs, times) -> list[tuple]:
    """The fastest Z (all ties) per estimator and SNR, by each rule."""
    fastest = []
    for label in dict.fromkeys(variant_label(c) for c in cells):
        for snr in snrs:
            z_hit, t_hit = _fastest_of(times, label, snr, "first_hit")
            z_set, t_set = _fastest_of(times, label, snr, "settle")
            fastest.append(
                (
                    label,
                    snr,
                    ", ".join(f"{z:g}" for z in z_hit) or "none",
                    num(t_hit),
                    ", ".join(f"{z:g}" for z in z_set) or "none",
                    num(t_set),
                )
            )
    return fastest


def _finite(c, col) -> bool:
    value = c[col]["median_censored"]
    return value is not None and math.isfinite(value)


def _worst(cells_of, stat):
    values = [
        (abs(c["accuracy"]["omega0"][stat]), c)
        for c in cells_of
        if math.isfinite(c.get("accuracy", {}).get("omega0", {}).get(stat, math.nan))
    ]
    return max(values, key=lambda v: v[0]) if values else (math.nan, None)


def _accuracy_summary(alg, rls) -> dict[str, dict[str, Any]]:
    """The largest |bias| and spread of the final ω0 per estimator, and the cell of each."""
    accuracy_summary = {}
    for name, group in (("algebraic", alg), ("rls", rls)):
        bias, bias_cell = _worst(group, "relative_bias")
        spread, spread_cell = _worst(group, "relative_spread")
        accuracy_summary[name] = {
            "largest_abs_relative_bias": bias,
            "at": None if bias_cell is None else [bias_cell["snr_db"], bias_cell["ratio"]],
            "largest_relative_spread": spread,
            "spread_at": None
            if spread_cell is None
            else [spread_cell["snr_db"], spread_cell["ratio"]],
        }
    return accuracy_summary


def _tables(cells, rows, fastest) -> tuple[Table, ...]:
    """The fastest-Z table and the table of every cell with its summary row."""
    summary = (
        "summary: all cells (medians; largest |bias|, spread, RMSE)",
        None,
        None,
        sum(c["n_ok"] for c in cells),
        _median(r[4] for r in rows),
        _median(r[5] for r in rows),
        _median(r[6] for r in rows),
        _largest(r[7] for r in rows),
        _largest(r[8] for r in rows),
        _largest(r[9] for r in rows),
    )
    return (
        Table(
            "Fastest input ratio Z per estimator and SNR (median time to 2 %; ties listed)",
            ("estimator", "SNR [dB]", "Z (first hit)", "first hit [s]", "Z (settle)", "settle [s]"),
            fastest,
        ),
        Table(
            "Every cell of the maps: median times and final error over the trials; bias, spread "
            "and RMSE of the final ω0 over the trials (relative to the true ω0)",
            (
                "estimator",
                "SNR [dB]",
                "Z",
                "trials ok",
                "first hit [s]",
                "settle [s]",
                "final rel. error",
                "ω0 rel. bias",
                "ω0 rel. spread (std)",
                "ω0 rel. RMSE",
            ),
            rows,
            summary=summary,
        ),
    )


def _cell_counts(alg: list, rls: list) -> dict[str, int]:
    """How many cells each estimator has, how many are fast (≤ 2 T) and how many settle."""
    return {
        "alg": len(alg),
        "rls": len(rls),
        "alg_fast": sum(
            _finite(c, "t_first_hit") and c["t_first_hit"]["median_censored"] <= 2 * WINDOW
            for c in alg
        ),
        "alg_settled": sum(_finite(c, "t_settle") for c in alg),
        "rls_settled": sum(_finite(c, "t_settle") for c in rls),
    }


def _fastest_lists(cells, snrs, times) -> list[dict[str, Any]]:
    """The fastest Z (all ties, as lists) per estimator and SNR, by each rule."""
    return [
        {
            "estimator": label,
            "snr_db": snr,
            "z_first_hit": _fastest_of(times, label, snr, "first_hit")[0],
            "z_settle": _fastest_of(times, label, snr, "settle")[0],
        }
        for label in dict.fromkeys(variant_label(c) for c in cells)
        for snr in snrs
    ]


def compute(quick: bool, progress) -> tuple[SectionData, dict]:
    """The sweep, its cells and the fastest input ratio per estimator and SNR.

    Returns
    -------
    (SectionData, dict)
    """
    if quick:
        snrs, ratios, trials, duration = [25.0, 50.0, 80.0], [0.5, 1.0, 10.0], 2, 2.0
    else:  # about 1200 trials of 5 s records: ~20 s on two idle cores
        snrs, ratios, trials, duration = (
            [20.0, 25.0, 35.0, 50.0, 65.0, 80.0],
            [0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0],
            14,
            5.0,
        )
    say(progress, f"convergence sweep: {len(snrs)} SNR × {len(ratios)} Z × {trials} trials")
    sweep = msd_sweep(
        snrs,
        ratios,
        trials=trials,
        methods=("algebraic", "rls"),
        windows=(WINDOW,),
        forgettings=(1.0,),
        duration=duration,
        seed=SEED,
        scheduler="local",
        progress=False,
    )
    cells = sweep.summarize()
    rows, times = _cell_rows(cells)
    fastest = _fastest_rows(cells, snrs, times)
    alg = [c for c in cells if c["method"] == "algebraic"]
    rls = [c for c in cells if c["method"] == "rls"]
    counts = _cell_counts(alg, rls)
    cell_80_10 = next((c for c in alg if c["snr_db"] == 80.0 and c["ratio"] == 10.0), None)
    results = {
        "grid": {"snr_db": snrs, "ratio": ratios, "trials": trials, "duration_s": duration},
        "sweep": {
            "n_trials": len(sweep.rows),
            "status_counts": sweep.status_counts(),
            "backend": sweep.backend,
            "elapsed_s": round(sweep.elapsed_s, 2),
        },
        "cells": [{k: v for k, v in c.items()} for c in cells],
        "cell_counts": counts,
        "omega0_accuracy": _accuracy_summary(alg, rls),
        "fastest_ratio": [
            dict(
                zip(
                    ("estimator", "snr_db", "z_first_hit", "t_first_hit", "z_settle", "t_settle"),
                    r,
                    strict=False,
                )
            )
            for r in fastest
        ],
        "fastest_ratio_lists": _fastest_lists(cells, snrs, times),
    }
    if cell_80_10 is not None:
        results["algebraic_80dB_Z10_first_hit_s"] = cell_80_10["t_first_hit"]["median_censored"]
    results["quoted"] = {
        "n_snr": len(snrs),
        "n_ratio": len(ratios),
        "n_estimators": 2,
        "seed": SEED,
        "two_windows_s": 2 * WINDOW,
    }
    figures = (
        FigureData("msd_fig5_6_convergence_first_hit", {"cells": cells, "metric": "t_first_hit"}),
        FigureData("msd_fig5_6_convergence_settle", {"cells": cells, "metric": "t_settle"}),
    )
    return SectionData(
        KEYS["maps"],
        TITLES["maps"],
        tables=_tables(cells, rows, fastest),
        figures=figures,
        results=results,
    ), results


def window_search(quick: bool) -> dict[str, Any]:
    """Shortest algebraic window at Z = 10 for the '0.005 s at 80 dB' claim, clean and at 80 dB."""
    duration = 1.0 if quick else 2.0
    windows = [0.005, 0.007, 0.01, 0.02, 0.05, 0.1, 0.2, 0.4]
    out: dict[str, Any] = {"windows_s": windows}
    for name, snr in (("clean", None), ("80dB", 80.0)):
        seed = None if snr is None else SEED  # a seed only where there is noise to seed
        rec = msd_paper_scenario(ratio=10.0, snr_db=snr, duration=duration, seed=seed)
        search = metrics.shortest_window(
            lambda T: make("algebraic", "msd", window=T), rec, windows, W0
        )
        expanding = convergence(algebraic(rec, expanding=True))
        out[name] = {
            "shortest_window_s": search.shortest,
            "fraction_within": search.fraction_within.tolist(),
            "errors": list(search.errors),
            "expanding_first_hit_s": expanding["first_hit"],
            "expanding_settle_s": expanding["settle"],
        }
    return out
