"""Constants and helpers shared by the sections of the MSD reproduction."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ...analysis import metrics
from ...analysis.msd_study import MSD_NATURAL_FREQUENCY
from ...estimators.registry import make
from ...simulate import PAPER_MSD

#: Root seed of every record of this study.
SEED = 3
PAPER = "Oueslati et al. 2011"
W0 = MSD_NATURAL_FREQUENCY  # √(400/3) rad/s
TS = PAPER_MSD["dt"]
WINDOW = 0.05  # algebraic window [s]: our default (the paper does not state its T)
SNRS = (25.0, 50.0, 80.0)
#: Section titles: each is the section's key in results.json (keep them stable).
TITLES = {
    "claims": "MSD: the paper's claims checked",
    "variance": "MSD: variance function and optimal input (Figs. 2–3)",
    "traces": "MSD: ω0 against time at 25, 50 and 80 dB (Figs. 7–12)",
    "maps": "MSD: convergence-time maps over SNR × Z (Figs. 5–6)",
    "disturbance": "MSD: high-frequency sinusoidal disturbance (Figs. 13–15)",
    "jumps": "MSD: jumping natural frequency (Fig. 16)",
    "errata": "MSD: errata of the paper",
}
#: Which renderer of physid.report writes each section.
KEYS = {name: f"msd.{name}" for name in TITLES}


# ============================================================================ helpers
def say(progress: Callable[[str], None] | None, message: str) -> None:
    if progress is not None:
        progress(f"msd_paper: {message}")


def algebraic(rec, window: float = WINDOW, **options):
    return make("algebraic", "msd", window=window, **options).fit(rec).result_


def rls(rec, forgetting: float = 1.0, **options):
    options.setdefault("covariance", "diagonal")
    return make("rls", "msd", forgetting=forgetting, **options).fit(rec).result_


def trace(result):
    return metrics.estimate_trace(result, "natural_frequency")


def convergence(result, truth=W0) -> dict[str, float]:
    t, omega, valid = trace(result)
    out = metrics.convergence_times(t, omega, truth, valid=valid)
    final = float(result.derived.get("natural_frequency", math.nan))
    out["final_estimate"] = final
    out["final_relative_error"] = abs(final - truth) / truth if math.isfinite(final) else math.nan
    return out


def steady_errors(result, start: float) -> dict[str, float]:
    """Largest and 99th-percentile relative ω0 error over the valid estimates after ``start``."""
    t, omega, valid = trace(result)
    keep = (t >= start) & np.isfinite(omega)
    if valid is not None:
        keep &= valid
    if not keep.any():
        return {"max": math.nan, "p99": math.nan, "median": math.nan}
    err = np.abs(omega[keep] - W0) / W0
    return {
        "max": float(err.max()),
        "p99": float(np.percentile(err, 99)),
        "median": float(np.median(err)),
    }


def fmt_s(value: float) -> str:
    return "never" if value is None or not math.isfinite(value) else f"{value:.3g} s"


def pct(value: float) -> str:
    """A relative error as a percentage with two significant digits (``0.0012`` → ``0.12 %``)."""
    if value is None or not math.isfinite(value):
        return "n/a"
    return f"{100 * value:.0f} %" if abs(value) >= 0.1 else f"{100 * value:.2g} %"


def see(key: str) -> str:
    if key == "claims":  # computed for the errata table itself
        return f"Numbers in results.json under “{TITLES[key]}” → errata_evidence."
    return f"Evidence in the section “{TITLES[key]}”."


def num(value: float) -> float | None:
    return None if value is None or not math.isfinite(value) else float(value)


def verdict(holds: bool | None) -> str:
    return {True: "holds", False: "does not hold", None: "partly"}[holds]
