"""Validation on a held-out trajectory: torque relative error per joint and residual whiteness."""

from __future__ import annotations

import importlib
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


def _whiteness(residual: np.ndarray) -> dict[str, Any]:
    """Fraction of autocorrelation lags 1..LAGS outside the 99 % band, per joint."""
    out = {}
    for j in range(residual.shape[1]):
        e = residual[:, j] - residual[:, j].mean()
        n = e.size
        denom = float(e @ e)
        r = np.array([float(e[: n - k] @ e[k:]) / denom for k in range(1, LAGS + 1)])
        out[f"tau{j + 1}"] = float(np.mean(np.abs(r) > Z99 / np.sqrt(n)))
    return out


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
    if not first:
        results["available"] = False
        return SectionData(KEYS["validation"], TITLES["validation"], results=results)
    idim = importlib.import_module("physid.estimators.idim")
    model = setup.model
    t = np.arange(0.0, period, DT)
    q, _, _ = fourier_reference(model, period, harmonics, 101, t)
    say(progress, "held-out trajectory")
    kp, kd = gains(model)
    held = simulate(model, q, t, seed=101, kp=kp, kd=kd)
    fit = first["idim-iv"]
    rows = idim.idim_rows(
        model, held, cutoff=fit.cutoff, half_width=fit.half_width, decimate=fit.decimate
    )
    tau = rows.tau if hasattr(rows, "tau") else rows.y
    tau = np.asarray(tau).reshape(-1, model.n_joints)
    per_method: dict[str, Any] = {}
    predicted = {}
    for key in ("idim-ols", "idim-iv"):
        r = first[key]
        pred = np.asarray(r.predict_rows(rows)).reshape(tau.shape)
        predicted[key] = pred
        res = tau - pred
        per_joint = np.linalg.norm(res, axis=0) / np.linalg.norm(tau, axis=0)
        per_method[key] = {
            "relative_error": {
                "overall": float(np.linalg.norm(res) / np.linalg.norm(tau)),
                **{f"tau{j + 1}": float(v) for j, v in enumerate(per_joint)},
            },
            "lags_outside_band": _whiteness(res),
        }
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
            "validation_module": setup.validation is not None,
            "convention": "filtered and decimated rows, as the fit used (the robotics convention)",
        }
    )
    n = model.n_joints
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
    tables = (
        Table(
            "Held-out trajectory: relative torque error ‖τ̂ − τ‖/‖τ‖ and the share of residual "
            "autocorrelation lags outside the 99 % band",
            ("joint", "IDIM-OLS error", "IDIM-IV error", "IDIM-IV lags outside band"),
            table_rows,
        ),
    )
    figures = (
        FigureData(
            "arm6_validation_torques",
            {"t": getattr(rows, "t", None), "measured": tau, "predicted": predicted["idim-iv"]},
        ),
    )
    return SectionData(
        KEYS["validation"], TITLES["validation"], results=results, tables=tables, figures=figures
    )
