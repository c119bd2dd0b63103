"""Optimal excitation: a Fourier trajectory that keeps the base regressor well conditioned,
against random trajectories with the same limits."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..data import FigureData, SectionData, Table
from ._common import DT, KEYS, TITLES, fourier_reference, say

#: Wall-time budget of the excitation design [s], by quick mode.
# An iteration budget, not a time budget: the design (and every number of Part III after it) is
# the same on any machine and under any load. Quick ~1.5 s, full ~12 s of CPU on this machine.
DESIGN_ITERATIONS = {True: 20, False: 60}


def _base_cond(model, idim, info, q, qd, qdd, every: int = 10) -> float:
    """Condition number of the base regressor at every ``every``-th sample (columns scaled)."""
    y = np.asarray(model.regressor(q[::every], qd[::every], qdd[::every]), dtype=float)
    return float(idim.condition_number(y[..., info.columns]))


def _design(setup, model, idim, info, t, harmonics, period, n_random, quick, results, progress):
    """Run the excitation design when one is installed; its numbers go into ``results``.

    Returns the designed trajectory (None when there is none or it failed) and the condition
    numbers of the design's random trajectories (empty when there are none).
    """
    designed = None
    random: list[float] = []
    if setup.excitation is not None:
        say(progress, "designing the excitation (condition number of the base regressor)")
        try:
            res = setup.excitation(
                model,
                harmonics=harmonics,
                period=period,
                n_random=n_random,
                max_iter=DESIGN_ITERATIONS[quick],
                max_seconds=600.0,  # a guard only; the iteration budget ends the search
                seed=0,
            )
            q, qd, qdd = res.trajectory(t)
            designed = {"q": q, "qd": qd, "qdd": qdd, "t": t}
            random = [float(c) for c in res.random_condition_numbers]
            within = [float(c) for c in res.random_within_condition_numbers]
            results["random_within_condition_numbers"] = within
            results["random_within_median"] = float(np.median(within))
            results["improvement_within"] = results["random_within_median"] / float(
                res.condition_number
            )
            results["unscaled_condition_number"] = {k: float(v) for k, v in res.unscaled.items()}
            results["design_starts"] = [float(c) for c in res.starts]
            results["designed_condition_number"] = float(res.condition_number)
            results["design_seconds"] = float(res.seconds)
            results["design_evaluations"] = int(res.nfev)
            results["criterion"] = str(res.criterion)
            results["condition_number_at_record_samples"] = _base_cond(
                model, idim, info, q, qd, qdd
            )
        except Exception as exc:  # say what failed, show no number
            results["design_error"] = f"{type(exc).__name__}: {exc}"
    return designed, random


def _tables(results, random, designed) -> tuple[Table, ...]:
    """The condition numbers: the designed trajectory, the medians, then each random one."""
    label = (
        "random trajectory {}, scaled to the limits" if designed else "random trajectory, seed {}"
    )
    rows = [(label.format(i + 1), c) for i, c in enumerate(random)]
    median = "median of the random trajectories" + (" (scaled to the limits)" if designed else "")
    summary_rows = [(median, results["random_median"])]
    if "random_within_median" in results:
        summary_rows.append(
            (
                "median of the same at random amplitudes within the limits",
                results["random_within_median"],
            )
        )
    if designed is not None:
        summary_rows.insert(0, ("designed trajectory", results["designed_condition_number"]))
    return (
        Table(
            "Condition number of the base regressor (columns scaled to unit norm)",
            ("trajectory", "condition number"),
            summary_rows + rows,
        ),
    )


def compute(setup, quick: bool, progress=None) -> tuple[SectionData, dict[str, Any]]:
    """The designed trajectory and its condition number against random ones.

    Returns
    -------
    (SectionData, dict)
        The section and the trajectory the identification runs (``t``, ``q``, ``qd``, ``qdd``,
        ``designed``).
    """
    period = 4.0 if quick else 10.0
    harmonics = 3 if quick else 5
    n_random = 5 if quick else 20
    t = np.arange(0.0, period, DT)
    results: dict[str, Any] = {
        "period_s": period,
        "harmonics": harmonics,
        "n_random": n_random,
        "missing": list(setup.missing),
        "missing_reasons": list(setup.reasons),
    }
    if setup.model is None or setup.idim is None:
        results["available"] = False
        return SectionData(KEYS["excitation"], TITLES["excitation"], results=results), {}
    import importlib

    idim = importlib.import_module("physid.estimators.idim")
    model = setup.model
    info = idim.base_regressor_info(model)  # the base set: computed once
    designed, random = _design(
        setup, model, idim, info, t, harmonics, period, n_random, quick, results, progress
    )
    if not random:
        say(progress, f"condition numbers of {n_random} random trajectories")
        for seed in range(1, n_random + 1):
            q, qd, qdd = fourier_reference(model, period, harmonics, seed, t)
            random.append(_base_cond(model, idim, info, q, qd, qdd))
    results["available"] = True
    results["random_condition_numbers"] = random
    results["random_median"] = float(np.median(random))
    if designed is not None:
        results["improvement"] = results["random_median"] / results["designed_condition_number"]
        trajectory = designed
    else:  # the best random trajectory stands in, and the report says so
        best = int(np.argmin(random)) + 1
        q, qd, qdd = fourier_reference(model, period, harmonics, best, t)
        trajectory = {"q": q, "qd": qd, "qdd": qdd, "t": t}
        results["stand_in_seed"] = best
        results["stand_in_condition_number"] = float(min(random))
    trajectory["designed"] = designed is not None
    tables = _tables(results, random, designed)
    figures = (
        FigureData(
            "arm6_excitation",
            {
                "t": trajectory["t"],
                "q": trajectory["q"],
                "designed": trajectory["designed"],
                "limits": model.limits,
                "random": random,
                "designed_cond": results.get("designed_condition_number"),
            },
        ),
    )
    section = SectionData(
        KEYS["excitation"], TITLES["excitation"], results=results, tables=tables, figures=figures
    )
    return section, trajectory
