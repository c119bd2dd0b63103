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


def _record_first(results: dict[str, Any], first: dict[str, Any], key: str, r) -> None:
    """Keep the first seed's fit of each method and its summary in the results."""
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


def _fit_seeds(setup, trajectory, seeds, iv_iterations, names, kp, kd, results, progress):
    """Simulate each seed's noisy closed loop and fit it by every method.

    Returns the estimates and standard errors per method, the seconds spent, the first fits
    (and the first recording) and the failures; the first seed's summaries go into ``results``.
    """
    model = setup.model
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
            _record_first(results, first, key, r)
        if "recording" not in first:
            first["recording"] = rec
    return est, se, seconds, first, failures


def _noise_free_fits(setup, trajectory, names, kp, kd, seconds, progress):
    """The same closed loop without noise, fitted by IDIM-OLS and by input-error.

    What the fit gives when only the model and the filters err (the filters smear the
    stick/slip switches, weakly excited directions); the noise's own bias (errors in variables,
    what IV is for) is the noisy mean minus this. Returns the OLS estimate and each method's
    own noise-free estimate.
    """
    say(progress, "the same closed loop without noise")
    clean_rec = simulate(setup.model, trajectory["q"], trajectory["t"], noisy=False, kp=kp, kd=kd)
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
    return clean, clean_own


def _method_statistics(est, se, clean_own, true, scale, seconds, names):
    """Bias, noise bias, spread, coverage and time of each method over the seeds."""
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
    return per_method


def _well_excited_statistics(est, se, per_method, true, scale, w_idx) -> None:
    """Mean |error| (each seed's) and the coverage on the well-excited parameters."""
    for k in est:
        e, s = np.array(est[k])[:, w_idx], np.array(se[k])[:, w_idx]
        per_method[k]["mean_abs_error"] = float(np.mean(np.abs(e - true[w_idx]) / scale[w_idx]))
        ok = np.isfinite(s)
        per_method[k]["coverage_well_excited"] = (
            float(np.mean((np.abs(e - true[w_idx]) <= Z95 * s)[ok])) if ok.any() else None
        )
        per_method[k]["mean_relative_stderr_well_excited"] = float(
            np.nanmean(np.where(ok, s, np.nan) / scale[w_idx])
        )


def _tables(names, truth, clean_by_name, per_method, well, mean_clean, mean_abs):
    """The bias-and-spread table and the error/coverage/time table."""
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
    return (
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


def _ratio(num: float, den: float) -> float | None:
    return num / den if den > 0 else None


def _well_excited(per_method, names, seeds) -> list[str]:
    """The base parameters whose IDIM-OLS spread over the seeds is below `WELL_EXCITED`."""
    spread = np.array(list(per_method["idim-ols"]["relative_spread"].values()))
    well = [n for n, v in zip(names, spread, strict=True) if np.isfinite(v) and v < WELL_EXCITED]
    if len(seeds) == 1 or not well:
        well = names
    return well


def _summary(est, se, per_method, well, truth, true, scale, clean, clean_own, seconds, results):
    """The means over the well-excited parameters, written into ``results``.

    Returns the mean |bias| per method, the noise-free OLS error per name
    and its mean over the well-excited parameters.
    """
    names = list(truth)
    clean_error = (clean - true) / scale
    mean_abs = {
        k: float(np.mean([abs(per_method[k]["relative_bias"][n]) for n in well])) for k in est
    }
    mean_noise = {
        k: float(np.mean([abs(per_method[k]["noise_bias"][n]) for n in well])) for k in est
    }
    w_idx = [names.index(n) for n in well]
    _well_excited_statistics(est, se, per_method, true, scale, w_idx)
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
            "iv_over_ols_noise_bias": _ratio(mean_noise["idim-iv"], mean_noise["idim-ols"]),
            "iv_over_ols_bias": _ratio(mean_abs["idim-iv"], mean_abs["idim-ols"]),
            "simulate_wall_time_s": seconds["simulate"],
            "input_error": {
                "run": True,
                "settings": "InputErrorEstimator(model): the defaults, i.e. base parameters, "
                "cutoff='auto', noise='auto'",
                "noise_free_relative_error": dict(zip(names, ie_clean.tolist(), strict=True)),
                "mean_abs_noise_free_error": float(np.mean(np.abs(ie_clean[w_idx]))),
                "noise_free_wall_time_s": seconds["input-error noise-free"],
            },
            "ie_over_ols_bias": _ratio(mean_abs["input-error"], mean_abs["idim-ols"]),
        }
    )
    return mean_abs, clean_by_name, mean_clean


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
    est, se, seconds, first, failures = _fit_seeds(
        setup, trajectory, seeds, iv_iterations, names, kp, kd, results, progress
    )
    results["failures"] = failures
    if not est["idim-ols"]:
        results["available"] = False
        results["error"] = "every fit failed; the first: " + failures[0]["error"]
        return SectionData(KEYS["identification"], TITLES["identification"], results=results), {}
    clean, clean_own = _noise_free_fits(setup, trajectory, names, kp, kd, seconds, progress)
    true = np.array([truth[n] for n in names])
    scale = np.maximum(np.abs(true), 1e-9 * np.abs(true).max())
    per_method = _method_statistics(est, se, clean_own, true, scale, seconds, names)
    well = _well_excited(per_method, names, seeds)
    mean_abs, clean_by_name, mean_clean = _summary(
        est, se, per_method, well, truth, true, scale, clean, clean_own, seconds, results
    )
    tables = _tables(names, truth, clean_by_name, per_method, well, mean_clean, mean_abs)
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
