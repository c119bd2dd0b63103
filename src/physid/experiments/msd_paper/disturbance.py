"""Figs. 13–15 of the paper: the high-frequency disturbance A2 = 0.1 m, ω2 = 500 ω0, and what
1 kHz sampling does to it (aliasing)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...signals.noise import alias_frequency
from ...simulate import PAPER_MSD, msd_paper_scenario
from ..data import FigureData, SectionData, Table
from ._common import (
    KEYS,
    SEED,
    TITLES,
    TS,
    W0,
    WINDOW,
    algebraic,
    convergence,
    num,
    rls,
    say,
    steady_errors,
    trace,
)

#: The paper's convergence claims with the disturbance [sample periods].
PAPER_ALGEBRAIC_TS, PAPER_RLS_TS = 5, 50
#: How much faster the unaliased comparison samples.
FAST_FACTOR = 10
#: Per-window errors are measured after this time [s].
WINDOW_ERRORS_AFTER = 0.2


def _case_rows(fits: dict, cases: dict, duration: float) -> list[tuple]:
    """Each fit's convergence (into ``cases``) and its row; then the same record sampled 10x faster.

    The same disturbance sampled 10x faster is not aliased: the last row compares.
    """
    rows = []
    for label, res in fits.items():
        conv = convergence(res)
        if label.startswith("algebraic"):
            conv["window_errors"] = steady_errors(res, WINDOW_ERRORS_AFTER)
        cases[label] = conv
        rows.append(
            (
                label,
                num(conv["first_hit"]),
                num(conv["first_hit"] / TS),
                num(conv["settle"]),
                num(conv["final_relative_error"]),
            )
        )
    fast_dt = TS / FAST_FACTOR
    rec_fast = msd_paper_scenario(
        ratio=10.0,
        snr_db=80.0,
        disturbance="paper",
        duration=min(duration, 2.0),
        dt=fast_dt,
        seed=SEED + 13,
    )
    fast = convergence(algebraic(rec_fast))
    cases["algebraic T=0.05 s, Z=10, T_s=0.1 ms"] = fast
    rows.append(
        (
            "algebraic T=0.05 s, Z=10, sampled at 10 kHz",
            num(fast["first_hit"]),
            num(fast["first_hit"] / TS),
            num(fast["settle"]),
            num(fast["final_relative_error"]),
        )
    )
    return rows


def _panels(fits: dict) -> dict[str, tuple]:
    """The ω0 traces of Figs. 14–15 (RLS without a validity mask)."""
    panels = {}
    for label in ("algebraic T=0.05 s, Z=10", "algebraic T=0.2 s, Z=10"):
        panels[label] = trace(fits[label])
    for label in ("RLS λ=1, Z=1", "RLS λ=1, Z=10"):
        t, w, _ = trace(fits[label])
        panels[label] = (t, w, None)
    return panels


def _quoted(a2: float, signal_amp: float, alg: dict, kb: dict, alg0: dict, kb0: dict):
    """The numbers the section's text quotes (times in sample periods)."""
    return {
        "nyquist_hz": 1 / (2 * TS),
        "a2_over_peak": a2 / signal_amp,
        "paper_algebraic_ts": PAPER_ALGEBRAIC_TS,
        "paper_rls_ts": PAPER_RLS_TS,
        "algebraic_first_hit_ts": alg["first_hit"] / TS,
        "window_ts": WINDOW / TS,
        "rls_first_hit_ts": kb["first_hit"] / TS,
        "undisturbed_algebraic_ts": alg0["first_hit"] / TS,
        "undisturbed_rls_ts": kb0["first_hit"] / TS,
        "fast_factor": FAST_FACTOR,
        "fast_khz": 1e-3 * FAST_FACTOR / TS,
        "window_errors_after_s": WINDOW_ERRORS_AFTER,
        "windows_s": [WINDOW, 0.2],
    }


def compute(quick: bool, progress, traces: Mapping[str, Any]) -> tuple[SectionData, dict]:
    """Disturbed records: time to 2 %, final errors, the aliased frequency.

    Returns
    -------
    (SectionData, dict)
    """
    say(progress, "high-frequency disturbance")
    duration = 2.0 if quick else 5.0
    a2 = PAPER_MSD["disturbance_amplitude"]
    w2 = PAPER_MSD["disturbance_ratio"] * W0
    w_alias = alias_frequency(w2, TS)
    cases = {}
    rec_alg = msd_paper_scenario(
        ratio=10.0, snr_db=80.0, disturbance="paper", duration=duration, seed=SEED + 13
    )
    rec_kb = msd_paper_scenario(
        ratio=1.0, snr_db=80.0, disturbance="paper", duration=duration, seed=SEED + 13
    )
    fits = {
        "algebraic T=0.05 s, Z=10": algebraic(rec_alg),
        "algebraic T=0.2 s, Z=10": algebraic(rec_alg, window=0.2),
        "RLS λ=1, Z=1": rls(rec_kb),
        "RLS λ=1, Z=10": rls(rec_alg),
    }
    rows = _case_rows(fits, cases, duration)
    x_true = rec_alg["x_true"]
    signal_amp = float(np.max(np.abs(x_true)))
    alg = cases["algebraic T=0.05 s, Z=10"]
    kb = cases["RLS λ=1, Z=1"]
    by = {(c["snr_db"], c["method"], c["ratio"], c["setting"]): c for c in traces["cases"]}
    alg0 = by[(80.0, "algebraic", 10.0, WINDOW)]
    kb0 = by[(80.0, "rls", 1.0, 1.0)]
    faster = alg["first_hit"] < alg0["first_hit"] and kb["first_hit"] < kb0["first_hit"]
    results = {
        "A2_m": a2,
        "omega2_rad_s": w2,
        "omega2_hz": w2 / (2 * math.pi),
        "alias_rad_s": w_alias,
        "alias_hz": w_alias / (2 * math.pi),
        "alias_over_omega0": w_alias / W0,
        "nyquist_rad_s": math.pi / TS,
        "true_x_peak_m": signal_amp,
        "cases": cases,
        "undisturbed_80dB_first_hit_s": {"algebraic": alg0["first_hit"], "rls": kb0["first_hit"]},
        "faster_than_undisturbed": faster,
    }
    table = Table(
        "Disturbed records (A2 = 0.1 m, ω2 = 500 ω0, 80 dB): time to 2 % and final error",
        (
            "estimator, input",
            "first hit [s]",
            "first hit [× 1 ms]",
            "settle [s]",
            "final rel. error",
        ),
        rows,
    )
    results["quoted"] = _quoted(a2, signal_amp, alg, kb, alg0, kb0)
    panels = _panels(fits)
    section = SectionData(
        KEYS["disturbance"],
        TITLES["disturbance"],
        tables=(table,),
        figures=(
            FigureData(
                "msd_fig13_disturbed_position",
                {"t": rec_alg.t, "x": rec_alg["x"], "x_true": x_true, "a2": a2, "t_max": 0.3},
            ),
            FigureData("msd_fig14_15_disturbance_estimates", {"panels": panels, "truth": W0}),
        ),
        results=results,
    )
    return section, results
