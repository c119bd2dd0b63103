"""Reproduce Cedro & Janecki's manipulator identification and go beyond it.

L. Cedro and D. Janecki, "Identification of a manipulator model using the input error method in
the Mathematica program": a 4-DOF arm under PD control (section 4) is identified from filtered
signals by minimising the quality factor J of eq. (5) (section 5).

One module per report section; each returns `physid.experiments.data.SectionData` (numbers,
tables, figure data, errata) and `physid.report` renders it:

* `simulation` — the closed-loop simulation (Fig. 2), with the paper's and the exact kinetic
  energy;
* `identification` — the fit from the paper's initial values beside the paper's numbers, the
  evaluations needed against the paper's ~1450, and a derivative-free (Nelder–Mead) run on the
  same J;
* `identifiability` — m1 and l1 enter only as m1·l1², with the J valley;
* `filters` — bias against Ω_g and M, for the paper's and for consistent derivative filters;
* `noise` — measurement noise on q (errors-in-variables bias);
* `errata` — the paper's errata, each with its evidence (attached to the sections that show it);
* `run` adds the part's overview (what the paper claims, what we measured) first and the
  errata list last.

``quick=True`` keeps the paper's 9.7 s record but runs fewer filter variants and one noisy record.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable

import numpy as np

from ...estimators.input_error import InputErrorEstimator
from ...models import load_model
from ...simulate.closed_loop import PAPER_MANIPULATOR, paper_manipulator_experiment
from ..data import SectionData, Table, errata_list
from . import errata as _errata_module
from . import filters, identifiability, identification, noise, simulation
from ._common import (
    COMBO,
    KEYS,
    PAPER,
    PAPER_INITIAL,
    PAPER_RESULT,
    SEPARATE,
    TITLES,
    TRUE_COMBO,
    TRUTH,
    FastJ,
    errors,
    filtr2_gain_error,
    fit,
    rod_inertia_share,
    say,
)

__all__ = ["run", "PAPER", "PAPER_RESULT", "PAPER_INITIAL", "TRUTH", "SEPARATE", "COMBO", "TITLES"]


def _overview(ident: SectionData, ident_ability: SectionData, noise_sec: SectionData):
    """What the paper claims beside what we measured (numbers copied from the sections)."""
    ours = ident.results["ours"]
    paper = ident.results["paper"]
    consistent = ident.results["ours_consistent_filters"]
    label = noise_sec.results["quoted"]["paper_label"]
    noisy = noise_sec.results[label]["mean_errors_percent"][COMBO]
    results = {
        "paper_J": paper["J"],
        "our_J": ours["J"],
        "paper_evaluations": paper["evaluations"],
        "our_residual_evaluations": ours["nfev"],
        "our_jacobian_evaluations": ours["njev"],
        "paper_combo_error_percent": ident.results["quoted"]["paper_combo_error_percent"],
        "our_combo_error_percent": ours["errors_percent"][COMBO],
        "consistent_combo_error_percent": consistent["errors_percent"][COMBO],
        "max_separate_error_percent": ident.results["quoted"]["max_separate_error_percent"],
        "paper_parameters_fitted": len(PAPER_INITIAL),
        "identifiable_rank": ident_ability.results["models_theta_rank"],
        "noise_std_rad": noise_sec.results["noise_std_rad"],
        "noisy_combo_error_percent": noisy,
        "n_joints": sum(n.startswith("m") for n in TRUTH),
    }
    rows = (
        ("quality factor J at the optimum [N²·m²]", paper["J"], ours["J"]),
        ("evaluations of J (residual)", paper["evaluations"], ours["nfev"]),
        (
            "error of m1·l1² [%], paper's filters",
            results["paper_combo_error_percent"],
            results["our_combo_error_percent"],
        ),
        (
            "error of m1·l1² [%], consistent filters",
            None,
            results["consistent_combo_error_percent"],
        ),
        (
            "independent parameters among the 8 fitted",
            len(PAPER_INITIAL),
            results["identifiable_rank"],
        ),
        (f"error of m1·l1² [%] with {results['noise_std_rad']:g} rad noise on q", None, noisy),
    )
    return SectionData(
        KEYS["overview"],
        TITLES["overview"],
        results=results,
        tables=(
            Table(
                "The paper's claims beside our measurements", ("quantity", "paper", "physid"), rows
            ),
        ),
    )


def _paper_fits(paper_model, rec_paper, rec_exact):
    """The fits with the paper's settings: as printed, with consistent derivatives, and on the
    exact-kinetic-energy record (the model mismatch).

    Returns the paper fit, its wall time, the consistent-derivatives fit and the mismatch fit.
    """
    t0 = time.perf_counter()
    result, _ = fit(paper_model, rec_paper, half_width=100, cutoff=0.2, torque="pd")
    walltime = time.perf_counter() - t0
    result_consistent, _ = fit(
        paper_model, rec_paper, half_width=100, cutoff=0.2, torque="pd", derivatives="consistent"
    )
    mismatch_fit, _ = fit(
        paper_model, rec_exact, half_width=200, cutoff=0.6, start="linear", derivatives="consistent"
    )
    return result, walltime, result_consistent, mismatch_fit


def _evidence(rec_paper, rec_exact, mismatch, result, nm, filtr2, result_consistent) -> dict:
    """The numbers the errata quote, from the runs above."""
    q = [f"q{i}" for i in range(1, 5)]
    return {
        "dq": np.abs(rec_exact.select(q) - rec_paper.select(q)).max(axis=0).tolist(),
        "mismatch_m2": mismatch["m2"],
        "n": rec_paper.n_samples,
        "nfev": result.nfev,
        "njev": result.njev,
        "nm_nfev": int(nm.nfev),
        "paper_combo_err": 100.0
        * (
            PAPER_RESULT["parameters"]["m1"] * PAPER_RESULT["parameters"]["l1"] ** 2 / TRUE_COMBO
            - 1
        ),
        "combo_err": errors(result.parameters, result.combinations[COMBO])[COMBO],
        "separate_err": max(abs(v) for k, v in errors(result.parameters).items() if k in SEPARATE),
        "filtr2_error": filtr2["paper"],
        "combo_err_consistent": errors(
            result_consistent.parameters, result_consistent.combinations[COMBO]
        )[COMBO],
    }


def run(quick: bool = False, progress: Callable[[str], None] | None = None) -> list[SectionData]:
    """Reproduce the manipulator identification and return the report sections as data.

    Parameters
    ----------
    quick : bool
        Same 9.7 s record, fewer filter variants, one noisy record (< 25 s on two cores);
        the full run takes under 2 minutes.
    progress : callable, optional
        Receives short progress messages (printed on stderr by the CLI).

    Returns
    -------
    list of SectionData
        Overview, simulation, identification, identifiability, filter choice, noise and the
        errata list (see `TITLES`); the errata are attached to the identification and
        identifiability sections.
    """
    t_start = time.perf_counter()
    say(progress, "loading models and simulating the closed loop (paper and exact kinetic energy)")
    paper_model = load_model("manipulator", kinetic="paper")
    exact_model = load_model("manipulator", kinetic="exact")
    rec_paper = paper_manipulator_experiment(kinetic="paper", model=paper_model)
    rec_exact = paper_manipulator_experiment(kinetic="exact", model=exact_model)

    say(progress, "identification with the paper's settings")
    result, walltime, result_consistent, mismatch_fit = _paper_fits(
        paper_model, rec_paper, rec_exact
    )
    mismatch = {n: mismatch_fit.parameters[n] for n in SEPARATE}
    filtr2 = filtr2_gain_error(rec_paper, 100, 0.2)
    inertia_share = rod_inertia_share(paper_model, rec_paper)

    say(progress, "Nelder–Mead on the same J")
    fast = FastJ(
        paper_model,
        InputErrorEstimator(
            paper_model, half_width=100, cutoff=0.2, torque="pd", derivatives="paper"
        ),
        rec_paper,
    )
    nm, nm_history, nm_time = identification.nelder_mead(fast, 3000 if quick else 8000)

    sim = simulation.compute(rec_paper, rec_exact, mismatch, mismatch_fit.at_bound)
    # the paper's setting on the paper's data (measured torque), shared by two sections
    r_pp, _ = fit(paper_model, rec_paper, half_width=100, cutoff=0.2, start="linear")
    filt = filters.compute(exact_model, rec_exact, r_pp, quick, progress, filtr2, result.cost)
    ident = identification.compute(
        result,
        walltime,
        nm,
        nm_history,
        nm_time,
        fast,
        result_consistent,
        filtr2,
        inertia_share,
        [row["nfev"] for row in filt.results["sweep"]],
    )
    say(progress, "identifiability and the m1–l1 valley")
    ident_ability = identifiability.compute(paper_model, result, fast, nm, quick)
    noisy = noise.compute(paper_model, rec_paper, r_pp, quick, progress)

    evidence = _evidence(rec_paper, rec_exact, mismatch, result, nm, filtr2, result_consistent)
    ident = dataclasses.replace(
        ident,
        results={
            **ident.results,
            "run_time_s": time.perf_counter() - t_start,
            "kp": list(PAPER_MANIPULATOR["kp"]),
            "kd": list(PAPER_MANIPULATOR["kd"]),
        },
        errata=_errata_module.errata(evidence),
    )
    body = [sim, ident, ident_ability, filt, noisy]
    say(progress, f"done in {time.perf_counter() - t_start:.1f} s")
    if not math.isfinite(result.cost):  # pragma: no cover - a broken run must not pass silently
        raise RuntimeError("the identification returned a non-finite J")
    return [
        _overview(ident, ident_ability, noisy),
        *body,
        errata_list(body, KEYS["errata"], TITLES["errata"], "Cedro & Janecki"),
    ]
