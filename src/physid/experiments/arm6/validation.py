"""Validation on a held-out trajectory: torque relative error per joint and residual whiteness.

Computed by `physid.analysis.validation.validate` (the same code as ``physid validate``): each
fit's `IDIMResult.predict` on the held-out record, filtered and decimated as that fit was, and
the residual's autocorrelation against the 99 % band (MATLAB ``resid``).
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from ..data import FigureData, SectionData, Table
from ._common import DT, KEYS, TITLES, fourier_reference, gains, say, simulate

#: Lags of the residual autocorrelation test (MATLAB ``resid``) and the 99 % band's z.
LAGS = 25
Z99 = 2.5758
#: A joint's residual counts as white when at most this share of its lags is outside the band
#: (about what chance alone leaves at the 99 % level, with margin).
WHITE_SHARE = 0.1


def _tables(per_method: dict[str, Any], n: int) -> tuple[Table, ...]:
    """The held-out relative torque error of each joint and each method, and the whiteness."""
    table_rows = [
        (
            f"tau{j + 1}",
            per_method["idim-ols"]["relative_error"][f"tau{j + 1}"],
            per_method["idim-iv"]["relative_error"][f"tau{j + 1}"],
            per_method["idim-iv"]["lags_outside_band"][f"tau{j + 1}"],
        )
        for j in range(n)
    ]
    table_rows.append(
        (
            "overall",
            per_method["idim-ols"]["relative_error"]["overall"],
            per_method["idim-iv"]["relative_error"]["overall"],
            None,
        )
    )
    return (
        Table(
            "Held-out trajectory: relative torque error ‖τ̂ − τ‖/‖τ‖ and the share of residual "
            "autocorrelation lags outside the 99 % band",
            ("joint", "IDIM-OLS error", "IDIM-IV error", "IDIM-IV lags outside band"),
            table_rows,
        ),
    )


def compute(setup, first, period: float, harmonics: int, progress=None) -> SectionData:
    """Predict the torque of a held-out closed-loop record from each fit.

    Returns
    -------
    SectionData
    """
    results: dict[str, Any] = {
        "missing": list(setup.missing),
        "missing_reasons": list(setup.reasons),
        "lags": LAGS,
        "band_percent": 99,  # the whiteness band the report quotes
    }
    if not first or setup.validation is None:
        results["available"] = False
        return SectionData(KEYS["validation"], TITLES["validation"], results=results)
    model = setup.model
    t = np.arange(0.0, period, DT)
    q, _, _ = fourier_reference(model, period, harmonics, 101, t)
    say(progress, "held-out trajectory")
    kp, kd = gains(model)
    held = simulate(model, q, t, seed=101, kp=kp, kd=kd)
    per_method: dict[str, Any] = {}
    series: dict[str, Any] = {}
    verdicts: dict[str, str] = {}
    for key in ("idim-ols", "idim-iv"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            report = setup.validation.validate(first[key], held, model=model, max_lag=LAGS)
        outside = report.residual["autocorrelation_outside"]
        per_method[key] = {
            "relative_error": dict(report.relative_error),
            "lags_outside_band": {
                f"tau{j + 1}": float(n_out) / LAGS for j, n_out in enumerate(outside)
            },
        }
        series[key] = report.series["inverse"]
        verdicts[key] = report.residual["verdict"]
    iv_err = per_method["idim-iv"]["relative_error"]
    joints = [k for k in iv_err if k != "overall"]
    worst = max(joints, key=lambda k: iv_err[k])
    outside = per_method["idim-iv"]["lags_outside_band"]
    results.update(
        {
            "available": True,
            "worst_joint": worst,
            "worst_joint_error": iv_err[worst],
            "white_threshold": WHITE_SHARE,
            "n_not_white": sum(v > WHITE_SHARE for v in outside.values()),
            "n_joints": len(joints),
            "held_out_seed": 101,
            "methods": per_method,
            "validation_module": True,
            "residual_verdict": verdicts["idim-iv"],
            "convention": "filtered and decimated rows, as the fit used (the robotics convention)",
        }
    )
    n = model.n_joints
    tables = _tables(per_method, n)
    t_rows, channels = series["idim-iv"]
    joint_names = [f"tau{j + 1}" for j in range(n)]
    figures = (
        FigureData(
            "arm6_validation_torques",
            {
                "t": np.asarray(t_rows),
                "measured": np.column_stack([channels[c][0] for c in joint_names]),
                "predicted": np.column_stack([channels[c][1] for c in joint_names]),
            },
        ),
    )
    return SectionData(
        KEYS["validation"], TITLES["validation"], results=results, tables=tables, figures=figures
    )
