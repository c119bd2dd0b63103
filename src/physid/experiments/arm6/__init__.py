"""A 6-DOF arm identified end to end, on the URDF that ships with physid (``"arm6"``).

One module per report section, each returning `physid.experiments.data.SectionData`:

* `excitation` — an optimal Fourier excitation (condition number of the base regressor) against
  random trajectories with the same limits;
* `identification` — closed-loop records with encoder and torque noise, IDIM-OLS, IDIM-IV and
  input-error (over the base parameters) over seeds: bias per base parameter, mean |error|,
  the coverage of the standard errors and the time per fit;
* `consistency` — a physically consistent estimate and how far it is from the unconstrained one;
* `validation` — the torque of a held-out trajectory predicted by each fit, and the residual's
  whiteness;
* `run` adds the part's overview first.

The part needs pieces from other stages (the arm model, the IDIM estimators, the excitation
design, the validation); `_common.available` finds them, and a section whose piece is missing
says so in the report instead of showing a number. ``quick=True`` uses a shorter record, a
shorter excitation period and fewer seeds.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from typing import Any

from ..data import SectionData
from . import consistency, excitation, identification, validation
from ._common import KEYS, MODEL, TITLES, available, say

__all__ = ["run", "TITLES", "MODEL"]


def _overview(setup, sections: dict[str, SectionData], seconds: float) -> SectionData:
    ex = sections["excitation"].results
    ident = sections["identification"].results
    val = sections["validation"].results
    cons = sections["consistency"].results
    results: dict[str, Any] = {
        "missing": list(setup.missing),
        "missing_reasons": list(setup.reasons),
        "wall_time_s": seconds,
    }
    if setup.model is not None:
        results["n_joints"] = setup.model.n_joints
    if ident.get("available"):
        results["n_base"] = ident["n_base"]
        results["ols_bias"] = ident["mean_abs_noise_bias"]["idim-ols"]
        results["iv_bias"] = ident["mean_abs_noise_bias"]["idim-iv"]
        if "input-error" in ident["mean_abs_noise_bias"]:
            results["ie_bias"] = ident["mean_abs_noise_bias"]["input-error"]
        results["noise_free_error"] = ident["mean_abs_noise_free_error"]
        results["n_seeds"] = len(ident["seeds"])
    if ex.get("available"):
        results["random_median"] = ex["random_median"]
        if "designed_condition_number" in ex:
            results["designed_condition_number"] = ex["designed_condition_number"]
            results["improvement"] = ex["improvement"]
    if val.get("available"):
        results["held_out_error_iv"] = val["methods"]["idim-iv"]["relative_error"]["overall"]
        results["held_out_error_ols"] = val["methods"]["idim-ols"]["relative_error"]["overall"]
    if cons.get("available"):
        results["cost_ratio"] = cons["cost_ratio"]
    if "iv_bias" in results and "held_out_error_iv" in results:
        text = (
            f"{results['n_base']} base parameters from a closed loop with encoder noise: "
            f"IDIM-IV bias {100 * results['iv_bias']:.2g} % against IDIM-OLS "
            f"{100 * results['ols_bias']:.2g} %"
            + (f" and input-error {100 * results['ie_bias']:.2g} %" if "ie_bias" in results else "")
            + "; held-out torque error "
            + f"{100 * results['held_out_error_iv']:.2g} %."
        )
    else:
        text = "not run in this build: it needs " + "; ".join(setup.missing) + "."
    results["headline"] = {"text": text}
    return SectionData(KEYS["overview"], TITLES["overview"], results=results)


def _single_threaded():
    """BLAS on one thread while the part runs (threadpoolctl, when installed).

    The regressions of this part are tall and thin: a second BLAS thread gains little, and on a
    shared machine oversubscribed BLAS threads make them many times slower (measured here: one
    IDIM-OLS fit 7.8 s with the default threads under load, 0.54 s with one). Parts I and II are
    left alone: their published numbers depend on the summation order BLAS uses.
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


def run(quick: bool = False, progress: Callable[[str], None] | None = None) -> list[SectionData]:
    """Identify the 6-DOF arm end to end and return the report sections as data.

    Parameters
    ----------
    quick : bool
        A 4 s excitation period with 3 harmonics and 2 noise seeds (the full run: 10 s, 5
        harmonics, 5 seeds).
    progress : callable, optional
        Receives short progress messages.

    Returns
    -------
    list of SectionData
        Overview, excitation, identification, consistency and validation (see `TITLES`).
    """
    start = time.perf_counter()
    say(progress, f"loading {MODEL} and the estimators")
    with _single_threaded():
        setup = available()
        ex, trajectory = excitation.compute(setup, quick, progress)
        ident, first = identification.compute(setup, trajectory, quick, progress)
        cons = consistency.compute(setup, first, quick, progress)
        try:
            val = validation.compute(
                setup, first, ex.results["period_s"], ex.results["harmonics"], progress
            )
        except Exception as exc:  # reported in the section, never fatal to the demo
            val = SectionData(
                KEYS["validation"],
                TITLES["validation"],
                results={"available": False, "error": f"{type(exc).__name__}: {exc}"},
            )
    sections = {"excitation": ex, "identification": ident, "consistency": cons, "validation": val}
    overview = _overview(setup, sections, time.perf_counter() - start)
    return [overview, ex, ident, cons, val]
