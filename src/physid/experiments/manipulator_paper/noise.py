"""Measurement noise on q: the errors-in-variables bias of the input-error fit."""

from __future__ import annotations

import numpy as np

from ...signals.noise import add_white_noise
from ..data import SectionData, Table
from ._common import COMBO, KEYS, SEPARATE, TITLES, TRUE_COMBO, TRUTH, errors, fit, say

#: Noise seeds of the full run (the quick run uses the first).
FULL_SEEDS = (1, 2, 3, 4, 5)


def _fit_setting(paper_model, rec_paper, r_pp, noisy_recs, setting, std, progress, rows) -> dict:
    """Fit the clean and each noisy record with one filter setting; its rows are appended.

    Returns the setting's errors and reported standard errors, clean and noisy.
    """
    m, w, derivatives = setting
    seeds = list(noisy_recs)
    label = f"M={m}, Ω_g={w}, {derivatives}"
    if (m, w, derivatives) == (100, 0.2, "paper"):
        clean_fit = r_pp  # already fitted for the filter section
    else:
        clean_fit, _ = fit(
            paper_model,
            rec_paper,
            half_width=m,
            cutoff=w,
            derivatives=derivatives,
            start="linear",
        )
    clean = errors(clean_fit.parameters, clean_fit.combinations[COMBO])
    errs, stderrs = [], []
    for seed in seeds:
        say(progress, f"noise std {std} rad, seed {seed}, {label}")
        r, _ = fit(
            paper_model,
            noisy_recs[seed],
            half_width=m,
            cutoff=w,
            derivatives=derivatives,
            start="linear",
        )
        errs.append(errors(r.parameters, r.combinations[COMBO]))
        stderr = r.stderr or dict.fromkeys(SEPARATE, float("nan"))  # None: withheld
        stderrs.append(
            {n: 100 * stderr[n] / TRUTH[n] for n in SEPARATE}
            | {COMBO: 100 * r.combination_stderr[COMBO] / TRUE_COMBO}
        )
    for key in (*SEPARATE, COMBO):
        vals = np.array([e[key] for e in errs])
        sd = float(vals.std(ddof=1)) if vals.size > 1 else None
        rows.append(
            (
                label,
                key,
                clean[key],
                float(vals.mean()),
                sd,
                float(np.mean([e[key] for e in stderrs])),
            )
        )
    return {
        "mean_errors_percent": {
            key: float(np.mean([e[key] for e in errs])) for key in (*SEPARATE, COMBO)
        },
        "mean_reported_stderr_percent": {
            key: float(np.mean([e[key] for e in stderrs])) for key in (*SEPARATE, COMBO)
        },
        "clean_errors_percent": clean,
        "noisy_errors_percent": errs,
        "reported_stderr_percent": stderrs,
    }


def compute(paper_model, rec_paper, r_pp, quick, progress) -> SectionData:
    """Fits of noisy records with the paper's filter and a lower, consistent one.

    Returns
    -------
    SectionData
    """
    std = 1e-4
    seeds = FULL_SEEDS[:1] if quick else FULL_SEEDS
    settings = ((100, 0.2, "paper"), (200, 0.1, "consistent"))
    # the noise is added after the integration (it never feeds back), so a noisy record is the
    # clean one plus noise: the same bits as simulating again with noise_std and seed
    q = [f"q{i}" for i in range(1, 5)]
    noisy_recs = {}
    for seed in seeds:
        noisy_q, _ = add_white_noise(rec_paper.select(q), std=std, rng=seed)
        noisy_recs[seed] = rec_paper.with_channels(dict(zip(q, noisy_q.T, strict=True)))
    rows, results = [], {}
    for m, w, derivatives in settings:
        label = f"M={m}, Ω_g={w}, {derivatives}"
        results[label] = _fit_setting(
            paper_model, rec_paper, r_pp, noisy_recs, (m, w, derivatives), std, progress, rows
        )
    paper_label = "M={}, Ω_g={}, {}".format(*settings[0])
    low_label = "M={}, Ω_g={}, {}".format(*settings[1])
    mean_paper = results[paper_label]["mean_errors_percent"]
    mean_low = results[low_label]["mean_errors_percent"]
    se_paper = results[paper_label]["mean_reported_stderr_percent"]
    understated = [abs(mean_paper[k]) / se_paper[k] for k in ("m4", "l4", COMBO) if se_paper[k] > 0]
    cut = abs(mean_paper[COMBO]) / max(abs(mean_low[COMBO]), 1e-12)
    return SectionData(
        KEYS["noise"],
        TITLES["noise"],
        tables=(
            Table(
                f"Errors [%] with noise std {std:g} rad on q (paper model and data, measured "
                "torque, start='linear')",
                (
                    "filter",
                    "quantity",
                    "noise-free error",
                    "noisy: mean error",
                    "noisy: sd over seeds",
                    "reported stderr [%]",
                ),
                rows,
            ),
        ),
        results={
            "noise_std_rad": std,
            "seeds": list(seeds),
            **results,
            "quoted": {
                "n_seeds": len(seeds),
                "full_run_seeds": len(FULL_SEEDS),
                "settings": [
                    {"half_width": m, "cutoff": w, "derivatives": d} for m, w, d in settings
                ],
                "paper_label": paper_label,
                "low_label": low_label,
                "stderr_understated_min": min(understated),
                "stderr_understated_max": max(understated),
                "combo_bias_reduction": cut,
            },
        },
    )
