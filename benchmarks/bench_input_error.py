"""Input-error identification: evaluations and wall time against the paper and Nelder–Mead.

Rows
----
1. Residual evaluations of physid's fit (``scipy.optimize.least_squares``, trust-region
   reflective, analytic ∂τ/∂θ from the model) from the paper's initial values with the paper's
   filter, data and PD-rebuilt torque, against the paper's "about 1450 iterations" (evaluations of
   its derivative-free FindMinimum; Cedro & Janecki, section 5).
2. Wall time of that fit against Nelder–Mead (``scipy.optimize.minimize``, adaptive) on the *same*
   J — the same filtered signals and the same residual function (one ``inverse_dynamics`` call per
   evaluation), l1 held like ours — measured in the same run. Quick mode caps Nelder–Mead at 300
   evaluations (the row says whether it converged, and the time goal is then not judged); the
   full run allows 4000.
3. ``start="linear"``: evaluations and wall time when the fit starts from the linear
   base-parameter solution.
4. Accuracy against the goals: identifiable parameters within 0.1 % and J within 10 % of
   the paper's (paper model, paper data, paper filter); within 0.05 % for the exact model on exact
   data with consistent filters (M = 400, Ω_g = 0.6: 0.020 %, a 2.5x margin; M = 200 gives
   0.0486 %, too close to the limit to be a meaningful check).
"""

from __future__ import annotations

import time
import warnings

import numpy as np
from scipy import optimize

import physid
from physid.estimators.input_error import InputErrorEstimator, quality_factor
from physid.experiments.manipulator_paper import PAPER_INITIAL, PAPER_RESULT, SEPARATE, TRUTH
from physid.simulate.closed_loop import paper_manipulator_experiment

PAPER_J = PAPER_RESULT["J"]
PAPER_FILTER = {"half_width": 100, "cutoff": 0.2}
PAPER_EVALUATIONS = PAPER_RESULT["evaluations"]


def _fit(model, rec, repeats: int = 1, **settings):
    """Fit (best wall time of ``repeats``: the machine is shared, the minimum is the cost).

    The paper's derivative filters unless ``derivatives`` says otherwise (we compare with it).
    """
    settings.setdefault("derivatives", "paper")
    for key, value in PAPER_FILTER.items():  # the paper's filter unless told otherwise
        settings.setdefault(key, value)
    best = np.inf
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(repeats):
            start = time.perf_counter()
            result = InputErrorEstimator(model, **settings).fit(rec, initial=PAPER_INITIAL).result_
            best = min(best, time.perf_counter() - start)
    return result, best


def _max_error(result) -> float:
    errors = [abs(result.parameters[n] / TRUTH[n] - 1) for n in SEPARATE]
    errors.append(abs(result.combinations["m1*l1**2"] / (TRUTH["m1"] * TRUTH["l1"] ** 2) - 1))
    return 100.0 * max(errors)


def _nelder_mead(model, rec, max_evaluations: int):
    """Nelder–Mead on the same J as the fit (same filtered signals and residual), l1 held."""
    est = InputErrorEstimator(model, **PAPER_FILTER, torque="pd", derivatives="paper")
    _, qf, qdf, qddf, tau_f, _, _ = est.filtered_signals(rec)
    names = tuple(model.parameter_names)
    free = [n for n in names if n != "l1"]
    count = {"n": 0}

    def j_of(x):
        count["n"] += 1
        params = dict(PAPER_INITIAL, **dict(zip(free, x.tolist(), strict=True)))
        return quality_factor(model.inverse_dynamics(qf, qdf, qddf, params) - tau_f)

    x0 = np.array([PAPER_INITIAL[n] for n in free])
    start = time.perf_counter()
    sol = optimize.minimize(
        j_of,
        x0,
        method="Nelder-Mead",
        options={"maxfev": max_evaluations, "xatol": 1e-7, "fatol": 1e-12, "adaptive": True},
    )
    return sol, count["n"], time.perf_counter() - start


def run(quick: bool) -> list[dict]:
    paper_model = physid.load_model("manipulator", kinetic="paper")
    rec = paper_manipulator_experiment(kinetic="paper", model=paper_model)
    _fit(paper_model, rec, torque="pd", max_nfev=2)  # warm-up (generated code, FFT plans)

    ours, t_ours = _fit(paper_model, rec, 3, torque="pd")
    linear, t_linear = _fit(paper_model, rec, 3, torque="pd", start="linear")
    nm, nm_evals, t_nm = _nelder_mead(paper_model, rec, 300 if quick else 4000)
    converged = "converged" if nm.success else f"stopped at the cap of {nm_evals}"

    rows = [
        {
            "case": "evaluations of J, paper setting (least_squares + analytic Jacobian)",
            "value": ours.nfev,
            "unit": "evaluations",
            "baseline": "paper's FindMinimum (~1450)",
            "baseline_value": PAPER_EVALUATIONS,
            "ratio": PAPER_EVALUATIONS / ours.nfev,
            "goal": "fewer evaluations than the paper",
            "met": ours.nfev < PAPER_EVALUATIONS,
        },
        {"case": "Jacobian evaluations, paper setting", "value": ours.njev, "unit": "evaluations"},
        {
            "case": f"evaluations of J, Nelder–Mead on the same J ({converged})",
            "value": nm_evals,
            "unit": "evaluations",
            "baseline": "physid least_squares",
            "baseline_value": ours.nfev,
            "ratio": nm_evals / ours.nfev,
            "goal": "fewer evaluations than Nelder-Mead",
            "met": ours.nfev < nm_evals,
        },
        {
            "case": "wall time of the fit, paper setting (best of 3)",
            "value": t_ours,
            "unit": "s",
            "baseline": f"Nelder–Mead, same J ({converged})",
            "baseline_value": t_nm,
            "ratio": t_nm / t_ours,
            "goal": "faster than a converged Nelder-Mead"
            if nm.success
            else "not comparable: Nelder-Mead capped",
            "met": (t_ours < t_nm) if nm.success else None,
        },
        {
            "case": "J at the end: Nelder–Mead / least_squares",
            "value": float(nm.fun) / ours.cost,
            "unit": "ratio",
            "goal": ">= 1 (least squares reaches the minimum)",
            "met": float(nm.fun) >= ours.cost * (1 - 1e-9),
        },
        {
            "case": "evaluations with start='linear'",
            "value": linear.nfev,
            "unit": "evaluations",
            "baseline": "start='initial'",
            "baseline_value": ours.nfev,
            "ratio": ours.nfev / linear.nfev,
        },
        {
            "case": "wall time with start='linear'",
            "value": t_linear,
            "unit": "s",
            "baseline": "start='initial'",
            "baseline_value": t_ours,
            "ratio": t_ours / t_linear,
        },
        {
            "case": "max error m2..m4, l2..l4, paper setting",
            "value": 100 * max(abs(ours.parameters[n] / TRUTH[n] - 1) for n in SEPARATE),
            "unit": "%",
            "goal": "< 0.1 %",
            "met": all(abs(ours.parameters[n] / TRUTH[n] - 1) < 1e-3 for n in SEPARATE),
        },
        {
            "case": "error of m1*l1**2, paper setting (paper: +2.88 %)",
            "value": 100 * (ours.combinations["m1*l1**2"] / 8.0 - 1),
            "unit": "%",
            "goal": "< 0.1 %",
            "met": abs(ours.combinations["m1*l1**2"] / 8.0 - 1) < 1e-3,
        },
        {
            "case": "J, paper setting",
            "value": ours.cost,
            "unit": "N²·m²",
            "baseline": "paper",
            "baseline_value": PAPER_J,
            "ratio": ours.cost / PAPER_J,
            "goal": "within 10 % of the paper's",
            "met": abs(ours.cost / PAPER_J - 1) < 0.10,
        },
    ]
    consistent, _ = _fit(paper_model, rec, torque="pd", derivatives="consistent", start="linear")
    rows.append(
        {
            "case": "max error incl. m1*l1**2, paper setting, consistent filters",
            "value": _max_error(consistent),
            "unit": "%",
            "goal": "< 0.1 %",
            "met": _max_error(consistent) < 0.1,
        }
    )
    exact_model = physid.load_model("manipulator", kinetic="exact")
    exact_rec = paper_manipulator_experiment(kinetic="exact", model=exact_model)
    exact, _ = _fit(
        exact_model, exact_rec, half_width=400, cutoff=0.6, derivatives="consistent", start="linear"
    )
    rows.append(
        {
            "case": "max error incl. m1*l1**2, exact model, M=400, Ω_g=0.6, consistent",
            "value": _max_error(exact),
            "unit": "%",
            "goal": "< 0.05 %",
            "met": _max_error(exact) < 0.05,
        }
    )
    paper_filter_exact, _ = _fit(exact_model, exact_rec, start="linear")
    rows.append(
        {
            "case": "max error incl. m1*l1**2, exact model, paper's filter (M=100, Ω_g=0.2)",
            "value": _max_error(paper_filter_exact),
            "unit": "%",
            "goal": "a few percent (the paper's filter is too low here)",
            "met": 0.5 < _max_error(paper_filter_exact) < 10,
        }
    )
    return rows


if __name__ == "__main__":
    for row in run(quick=True):
        print(row)
