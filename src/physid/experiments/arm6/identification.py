"""IDIM-OLS, IDIM-IV and input-error side by side over seeds: bias per base parameter and the
measured coverage of the reported standard errors.

Input-error runs with the user's defaults (`InputErrorEstimator(model)`): on this rigid-body
model it estimates the base parameters (``parameters="base"``: the paper's method on the
robot, its FIR filters, no decimation), chooses its filter from the data and compensates the
encoder noise (``noise="auto"``).
"""

from __future__ import annotations

import time
import warnings
from typing import Any

import numpy as np

from ..data import FigureData, SectionData, Table
from ._common import ENCODER_STD, KEYS, TITLES, TORQUE_NOISE, gains, say, simulate, truth_base

#: A base parameter is "well excited" when its relative spread over the seeds is below this.
WELL_EXCITED = 0.10
#: z of a nominal 95 % interval.
Z95 = 1.959964


#: The methods side by side, in the order of the tables.
METHODS = ("idim-ols", "idim-iv", "input-error")


def _fit(setup, method, rec, **settings):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if method == "input-error":  # the user's defaults: base parameters, auto filter, noise
            from ...estimators.input_error import InputErrorEstimator

            return InputErrorEstimator(setup.model, **settings).fit(rec).result_
        return setup.idim(setup.model, method, **settings).fit(rec).result_


def compute(setup, trajectory, quick: bool, progress=None) -> tuple[SectionData, dict[str, Any]]:
    """Closed-loop records with encoder and torque noise, fitted by each method.

    Returns
    -------
    (SectionData, dict)
        The section and what the validation needs (the fitted results of the first seed).
    """
    seeds = (1, 2) if quick else tuple(range(1, 6))
    iv_iterations = 4 if quick else 10
    results: dict[str, Any] = {
        "seeds": list(seeds),
        "encoder_std_rad": ENCODER_STD,
        "torque_noise_fraction": TORQUE_NOISE,
        "well_excited_spread": WELL_EXCITED,
        "iv_max_iterations": iv_iterations,
        "nominal_level": 0.95,
        "missing": list(setup.missing),
        "missing_reasons": list(setup.reasons),
    }
    if not trajectory:
        results["available"] = False
        return SectionData(KEYS["identification"], TITLES["identification"], results=results), {}
    import importlib

    idim = importlib.import_module("physid.estimators.idim")
    model = setup.model
    truth = truth_base(model, idim)
    names = list(truth)

    kp, kd = gains(model)
    results["kp"], results["kd"] = kp.tolist(), kd.tolist()
    reference = trajectory["q"]
    t = trajectory["t"]
    est: dict[str, list[np.ndarray]] = {k: [] for k in METHODS}
    se: dict[str, list[np.ndarray]] = {k: [] for k in METHODS}
    seconds: dict[str, float] = {"simulate": 0.0} | {k: 0.0 for k in METHODS}
    first: dict[str, Any] = {}
    failures: list[dict[str, Any]] = []
    for seed in seeds:
        say(progress, f"closed loop with noise, seed {seed}")
        t0 = time.perf_counter()
        rec = simulate(model, reference, t, seed=seed, kp=kp, kd=kd)
        seconds["simulate"] += time.perf_counter() - t0
        fits = {}
        try:
            for method, key in (("ols", "idim-ols"), ("iv", "idim-iv"), ("input-error",) * 2):
                t0 = time.perf_counter()
                settings = {"max_iter": iv_iterations} if method == "iv" else {}
                fits[key] = _fit(setup, method, rec, **settings)
                seconds[key] += time.perf_counter() - t0
        except Exception as exc:  # a fit that fails is reported, never hidden or fatal
            failures.append({"seed": seed, "error": f"{type(exc).__name__}: {exc}"})
            continue
        for key, r in fits.items():
            est[key].append(np.array([r.parameters[n] for n in names]))  # one naming: mcx1R
            stderr = r.stderr or {}
            se[key].append(np.array([stderr.get(n, np.nan) for n in names], dtype=float))
            if not first.get(key) and key == "input-error":
                first[key] = r
                results["input-error_first_seed"] = {
                    "half_width": r.half_width,
                    "cutoff": r.cutoff,
                    "noise": r.noise,
                    "n_rows": int(r.residuals.shape[0]),
                    "condition_number": r.condition_number,
                    "relative_residual": r.relative_residual.tolist(),
                }
            elif not first.get(key):
                first[key] = r
                results[f"{key}_first_seed"] = {
                    "condition_number": r.condition_number,
                    "relative_error": r.relative_error,
                    "iterations": r.iterations,
                    "iv_changes": list(r.iv_changes),
                    "n_rows": r.n_rows,
                    "decimate": r.decimate,
                }
        if "recording" not in first:
            first["recording"] = rec
    results["failures"] = failures
    if not est["idim-ols"]:
        results["available"] = False
        results["error"] = "every fit failed; the first: " + failures[0]["error"]
        return SectionData(KEYS["identification"], TITLES["identification"], results=results), {}
    # the same trajectory without noise: what the fit gives when only the model and the filters
    # err (the filters smear the stick/slip switches, weakly excited directions); the noise's
    # own bias (errors in variables, what IV is for) is the noisy mean minus this
    say(progress, "the same closed loop without noise")
    clean_rec = simulate(model, reference, t, noisy=False, kp=kp, kd=kd)
    clean_fit = _fit(setup, "ols", clean_rec)
    clean = np.array([clean_fit.parameters[n] for n in names])
    # input-error filters differently (its FIR bank, no decimation): its own noise-free fit
    t0 = time.perf_counter()
    clean_ie_fit = _fit(setup, "input-error", clean_rec)
    seconds["input-error noise-free"] = time.perf_counter() - t0
    clean_own = {
        "idim-ols": clean,
        "idim-iv": clean,
        "input-error": np.array([clean_ie_fit.parameters[n] for n in names]),
    }
    true = np.array([truth[n] for n in names])
    scale = np.maximum(np.abs(true), 1e-9 * np.abs(true).max())
    clean_error = (clean - true) / scale
    per_method = {}
    for key in est:
        e = np.array(est[key])
        s = np.array(se[key])
        noise_bias = (e.mean(axis=0) - clean_own[key]) / scale
        rel_bias = (e.mean(axis=0) - true) / scale
        rel_sd = e.std(axis=0, ddof=1) / scale if e.shape[0] > 1 else np.full(true.size, np.nan)
        covered = np.abs(e - true) <= Z95 * s
        finite = np.isfinite(s)
        per_method[key] = {
            "relative_bias": dict(zip(names, rel_bias.tolist(), strict=True)),
            "noise_bias": dict(zip(names, noise_bias.tolist(), strict=True)),
            "relative_spread": dict(zip(names, rel_sd.tolist(), strict=True)),
            "coverage": float(np.mean(covered[finite])) if finite.any() else None,
            "wall_time_s": seconds[key],
            "wall_time_per_fit_s": seconds[key] / max(e.shape[0], 1),
            "mean_relative_stderr": dict(
                zip(
                    names,
                    (np.nanmean(np.where(finite, s, np.nan), axis=0) / scale).tolist(),
                    strict=True,
                )
            ),
        }
    spread = np.array(list(per_method["idim-ols"]["relative_spread"].values()))
    well = [n for n, v in zip(names, spread, strict=True) if np.isfinite(v) and v < WELL_EXCITED]
    if len(seeds) == 1 or not well:
        well = names
    mean_abs = {
        k: float(np.mean([abs(per_method[k]["relative_bias"][n]) for n in well])) for k in est
    }
    mean_noise = {
        k: float(np.mean([abs(per_method[k]["noise_bias"][n]) for n in well])) for k in est
    }
    w_idx = [names.index(n) for n in well]
    for k in est:  # mean |error| (each seed's), and the coverage on the well-excited parameters
        e, s = np.array(est[k])[:, w_idx], np.array(se[k])[:, w_idx]
        per_method[k]["mean_abs_error"] = float(np.mean(np.abs(e - true[w_idx]) / scale[w_idx]))
        ok = np.isfinite(s)
        per_method[k]["coverage_well_excited"] = (
            float(np.mean((np.abs(e - true[w_idx]) <= Z95 * s)[ok])) if ok.any() else None
        )
        per_method[k]["mean_relative_stderr_well_excited"] = float(
            np.nanmean(np.where(ok, s, np.nan) / scale[w_idx])
        )
    ie_clean = (clean_own["input-error"] - true) / scale
    clean_by_name = dict(zip(names, clean_error.tolist(), strict=True))
    mean_clean = float(np.mean([abs(clean_by_name[n]) for n in well]))
    results.update(
        {
            "available": True,
            "base_names": names,
            "n_base": len(names),
            "truth": truth,
            "methods": per_method,
            "well_excited": well,
            "n_well_excited": len(well),
            "mean_abs_relative_bias": mean_abs,
            "mean_abs_noise_bias": mean_noise,
            "noise_free_relative_error": clean_by_name,
            "mean_abs_noise_free_error": mean_clean,
            "iv_over_ols_noise_bias": mean_noise["idim-iv"] / mean_noise["idim-ols"]
            if mean_noise["idim-ols"] > 0
            else None,
            "iv_over_ols_bias": mean_abs["idim-iv"] / mean_abs["idim-ols"]
            if mean_abs["idim-ols"] > 0
            else None,
            "simulate_wall_time_s": seconds["simulate"],
            "input_error": {
                "run": True,
                "settings": "InputErrorEstimator(model): the defaults, i.e. base parameters, "
                "cutoff='auto', noise='auto'",
                "noise_free_relative_error": dict(zip(names, ie_clean.tolist(), strict=True)),
                "mean_abs_noise_free_error": float(np.mean(np.abs(ie_clean[w_idx]))),
                "noise_free_wall_time_s": seconds["input-error noise-free"],
            },
            "ie_over_ols_bias": mean_abs["input-error"] / mean_abs["idim-ols"]
            if mean_abs["idim-ols"] > 0
            else None,
        }
    )
    rows = [
        (
            n,
            truth[n],
            clean_by_name[n],
            *(per_method[k]["relative_bias"][n] for k in METHODS),
            *(per_method[k]["relative_spread"][n] for k in METHODS),
            "yes" if n in well else "no",
        )
        for n in names
    ]
    summary = (
        f"mean |bias| over the {len(well)} well-excited parameters",
        None,
        mean_clean,
        *(mean_abs[k] for k in METHODS),
        *(None for _ in METHODS),
        None,
    )
    tables = (
        Table(
            "Relative bias and spread of each base parameter over the seeds (relative to |truth|)",
            (
                "base parameter",
                "truth",
                "noise-free OLS error",
                "IDIM-OLS bias",
                "IDIM-IV bias",
                "input-error bias",
                "IDIM-OLS spread",
                "IDIM-IV spread",
                "input-error spread",
                "well excited",
            ),
            rows,
            summary=summary,
        ),
        Table(
            "Error, standard errors and the coverage of their nominal 95 % intervals "
            "(fractions of seeds × parameters), and time per fit",
            (
                "method",
                "mean |error|, well excited",
                "mean stderr / |truth|, well excited",
                "coverage, well excited",
                "coverage, all",
                "time per fit [s]",
            ),
            [
                (
                    k,
                    per_method[k]["mean_abs_error"],
                    per_method[k]["mean_relative_stderr_well_excited"],
                    per_method[k]["coverage_well_excited"],
                    per_method[k]["coverage"],
                    per_method[k]["wall_time_per_fit_s"],
                )
                for k in METHODS
            ],
        ),
    )
    figures = (
        FigureData(
            "arm6_bias_bars",
            {
                "names": names,
                "bias": {k: per_method[k]["noise_bias"] for k in est},
                "spread": {k: per_method[k]["relative_spread"] for k in est},
                "well": well,
            },
        ),
    )
    return (
        SectionData(
            KEYS["identification"],
            TITLES["identification"],
            results=results,
            tables=tables,
            figures=figures,
        ),
        first,
    )
