"""The filter choice: bias against Ω_g and M, for the paper's and for consistent filters."""

from __future__ import annotations

from ...estimators.input_error import ENERGY_FRACTION_WARN, RESIDUAL_WARN
from ...filters import design_filter
from ..data import FigureData, SectionData, Table
from ._common import COMBO, KEYS, SEPARATE, TITLES, errors, fit, max_abs, say

#: The accuracy target of the sweep on noise-free data [%].
TARGET_PERCENT = 0.05
#: The paper's filter: half-width M [samples] and cut-off Ω_g [rad/sample].
PAPER_FILTER = (100, 0.2)


def _sweep(exact_model, rec_exact, widths, cutoffs, progress):
    """Fit the exact record with each half-width, derivative filter and cut-off.

    Returns the table rows, the max-error curves per filter and the sweep's records.
    """
    rows, curves, sweep = [], {}, []
    for m in widths:
        for derivatives in ("paper", "consistent"):
            label = f"M = {m}, {derivatives} filters"
            curves[label] = []
            for w in cutoffs:
                say(progress, f"filter sweep {label}, Ω_g = {w}")
                r, warned = fit(
                    exact_model,
                    rec_exact,
                    half_width=m,
                    cutoff=w,
                    derivatives=derivatives,
                    start="linear",
                )
                err = errors(r.parameters, r.combinations[COMBO])
                curves[label].append(max_abs(err))
                rows.append(
                    (
                        m,
                        w,
                        derivatives,
                        max_abs(err),
                        err[COMBO],
                        max(abs(err[n]) for n in SEPARATE),
                        r.cost,
                        float(r.filter_energy_fraction.max()),
                        float(r.relative_residual.max()),
                        "yes" if warned else "no",
                    )
                )
                sweep.append(
                    {
                        "half_width": m,
                        "cutoff": w,
                        "derivatives": derivatives,
                        "errors_percent": err,
                        "J": r.cost,
                        "energy_fraction": r.filter_energy_fraction.max(),
                        "relative_residual": r.relative_residual.max(),
                        "warned": warned,
                        "nfev": r.nfev,
                    }
                )
    return rows, curves, sweep


def compute(exact_model, rec_exact, r_pp, quick, progress, filtr2, j_pd) -> SectionData:
    """The filter sweep; ``r_pp`` is the paper's setting (M = 100, Ω_g = 0.2, its filters,
    measured torque) fitted to the paper-mode data, shared with the noise section.

    Returns
    -------
    SectionData
    """
    cutoffs = (0.2, 0.4, 0.6) if quick else (0.1, 0.2, 0.3, 0.4, 0.6, 0.8)
    widths = (200,) if quick else (100, 200)
    rows, curves, sweep = _sweep(exact_model, rec_exact, widths, cutoffs, progress)
    lp = design_filter("lowpass", *PAPER_FILTER, rec_exact.dt)
    best = min(
        (row for row in sweep if row["derivatives"] == "consistent"),
        key=lambda row: max_abs(row["errors_percent"]),
    )
    pp_error = max_abs(errors(r_pp.parameters, r_pp.combinations[COMBO]))
    paper_edge = r_pp.filter_passband_edge  # depends on the filter only (M = 100, Ω_g = 0.2)
    return SectionData(
        KEYS["filters"],
        TITLES["filters"],
        tables=(
            Table(
                "Exact arm, exact model: errors [%] against the filter (start='linear'; "
                "'warned': a FilterWarning was raised)",
                (
                    "M",
                    "Ω_g",
                    "deriv. filters",
                    "max |err|",
                    "m1·l1² err",
                    "max |err| m2..l4",
                    "J",
                    "Δq energy above flat band",
                    "rel. residual",
                    "warned",
                ),
                rows,
            ),
        ),
        figures=(
            FigureData(
                "manipulator_filter_sweep",
                {"cutoffs": cutoffs, "curves": curves, "target": TARGET_PERCENT},
            ),
        ),
        results={
            "sweep": sweep,
            "paper_setting_measured_torque": {
                "J": r_pp.cost,
                "max_abs_error_percent": pp_error,
                "relative_residual": float(r_pp.relative_residual.max()),
                "errors_percent": errors(r_pp.parameters, r_pp.combinations[COMBO]),
            },
            "paper_setting_pd_torque_J": j_pd,
            "filtr2_gain_error": filtr2,
            "quoted": {
                "paper_half_width": PAPER_FILTER[0],
                "paper_cutoff": PAPER_FILTER[1],
                "paper_passband_edge": paper_edge,
                "lowpass_white_noise_gain": lp.white_noise_gain,
                "energy_fraction_warn_percent": 100 * ENERGY_FRACTION_WARN,
                "residual_warn": RESIDUAL_WARN,
                "best_half_width": best["half_width"],
                "best_cutoff": best["cutoff"],
                "best_max_error_percent": max_abs(best["errors_percent"]),
                "target_percent": TARGET_PERCENT,
                "cutoffs": list(cutoffs),
            },
        },
    )
