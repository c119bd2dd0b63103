"""Fig. 16 of the paper: a jumping ω0, tracked by the algebraic window and by RLS with λ < 1."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...analysis import metrics
from ...simulate import msd_paper_scenario
from ..data import FigureData, SectionData, Table
from ._common import KEYS, SEED, TITLES, TS, WINDOW, algebraic, num, rls, say, trace


def truth_trace(rec) -> tuple[np.ndarray, list[float]]:
    segments = rec.metadata["segments"]
    t = rec.t
    truth = np.empty(t.size)
    starts = [float(s["from"]) for s in segments]
    for k, seg in enumerate(segments):
        end = starts[k + 1] if k + 1 < len(segments) else math.inf
        truth[(t >= starts[k]) & (t < end)] = math.sqrt(seg["a"][0])
    return truth, starts[1:]


def _recoveries(fits: dict, truth, jump_times: list[float], recovery: dict):
    """Each estimator's recovery times after each jump (into ``recovery``).

    Returns the table rows, the curves of the figure and the summary per estimator.
    """
    rows = []
    curves = []
    summary: dict[str, dict[str, Any]] = {}
    for label, res in fits.items():
        t, w, v = trace(res)
        curves.append((label, t, w, v))
        rec_times = metrics.recovery_times(t, w, truth, jump_times, valid=v)
        recovery[label] = {k: np.asarray(val).tolist() for k, val in rec_times.items()}
        shown = np.isfinite(w) if v is None else np.isfinite(w) & np.asarray(v, dtype=bool)
        first_estimate = float(t[np.flatnonzero(shown)[0]]) if shown.any() else math.inf
        # a jump before the estimator's first estimate is not a recovery: its start-up
        startup = [
            first_estimate >= float(rec_times["segment_start"][j])
            for j in range(1, rec_times["segment_start"].size)
        ]
        first_hits = [num(x) for x in rec_times["first_hit"][1:]]
        settles = [num(x) for x in rec_times["settle"][1:]]
        summary[label] = {
            "first_estimate_s": first_estimate,
            "startup": startup,
            "first_hit": first_hits,
            "settle": settles,
        }
        for j, (hit, settle, is_startup) in enumerate(
            zip(first_hits, settles, startup, strict=True), start=1
        ):
            rows.append(
                (
                    label,
                    float(rec_times["segment_start"][j]),
                    float(rec_times["truth"][j]),
                    hit,
                    settle,
                    f"start-up: first estimate at {first_estimate:.3g} s, after this jump"
                    if is_startup
                    else "",
                )
            )
    return rows, curves, summary


def _recovered(summary: dict, label: str) -> tuple[int, int]:
    """How many real jumps (not start-ups) the estimator recovered from, and how many there were."""
    info = summary[label]
    real = [k for k, up in enumerate(info["startup"]) if not up]
    return sum(info["first_hit"][k] is not None for k in real), len(real)


def _quoted(summary: dict, jump_times: list[float]) -> dict[str, Any]:
    """The numbers the section's text quotes."""
    alg = summary[f"algebraic T={WINDOW:g} s"]
    alg_real = [k for k, up in enumerate(alg["startup"]) if not up]
    alg_hits = [alg["first_hit"][k] for k in alg_real]
    alg_settles = [alg["settle"][k] for k in alg_real]
    within_window = all(h is not None and h <= WINDOW + 1e-9 for h in alg_hits)
    n_settled = sum(x is not None for x in alg_settles)
    memory = {lam: TS / (1 - lam) for lam in (0.99, 0.999)}
    rls_startups = {
        label: info["first_estimate_s"]
        for label, info in summary.items()
        if label.startswith("RLS") and any(info["startup"])
    }
    lam1_ok, lam1_n = _recovered(summary, "RLS λ=1")
    n_rls = sum(label.startswith("RLS") for label in summary)
    who = "RLS (every λ)" if len(rls_startups) == n_rls else ", ".join(rls_startups)
    return {
        "window_s": WINDOW,
        "snr_db": 80.0,
        "forgettings": [0.99, 0.999],
        "first_jump_s": jump_times[0],
        "algebraic_hits_s": alg_hits,
        "algebraic_settles_s": alg_settles,
        "algebraic_within_window": within_window,
        "algebraic_settled": n_settled,
        "algebraic_jumps": len(alg_settles),
        "memory_s": {f"{lam:g}": v for lam, v in memory.items()},
        "rls_startups_s": rls_startups,
        "rls_startup_who": who if rls_startups else "",
        "rls_lambda1_recovered": lam1_ok,
        "rls_lambda1_jumps": lam1_n,
    }


def compute(quick: bool, progress) -> tuple[SectionData, dict]:
    """Recovery times after each stiffness jump for the algebraic windows and RLS.

    Returns
    -------
    (SectionData, dict)
    """
    say(progress, "jumping ω0")
    duration = 3.0 if quick else 5.0
    jumps = (
        [(0.1, 600.0), (1.2, 300.0), (2.2, 500.0)]
        if quick
        else [(0.1, 600.0), (1.5, 300.0), (3.0, 500.0)]
    )
    rec = msd_paper_scenario(
        ratio=10.0, snr_db=80.0, duration=duration, jumps=jumps, seed=SEED + 16
    )
    truth, jump_times = truth_trace(rec)
    fits = {
        f"algebraic T={WINDOW:g} s": algebraic(rec),
        "algebraic T=0.2 s": algebraic(rec, window=0.2),
        "RLS λ=0.99": rls(rec, forgetting=0.99),
        "RLS λ=0.999": rls(rec, forgetting=0.999),
        "RLS λ=1": rls(rec, forgetting=1.0),
    }
    results: dict[str, Any] = {
        "jumps": [{"time_s": tj, "stiffness_N_per_m": k} for tj, k in jumps],
        "recovery": {},
    }
    rows, curves, summary = _recoveries(fits, truth, jump_times, results["recovery"])
    results["summary"] = summary
    results["quoted"] = _quoted(summary, jump_times)
    table = Table(
        "Recovery after each jump (time from the jump)",
        ("estimator", "jump at [s]", "new ω0 [rad/s]", "first hit [s]", "settle [s]", "note"),
        rows,
    )
    return SectionData(
        KEYS["jumps"],
        TITLES["jumps"],
        tables=(table,),
        figures=(
            FigureData(
                "msd_fig16_jumping_omega0",
                {"t": rec.t, "truth": truth, "curves": curves, "jump_times": jump_times},
            ),
        ),
        results=results,
    ), results
