"""Section 3 of the paper: the variance function K(Z, λ) and the optimal input (Figs. 2–3).

From `physid.analysis.input_design` (its functions, not redone here).
"""

from __future__ import annotations

import math

import numpy as np

from ..data import Erratum, FigureData, SectionData, Table
from ._common import KEYS, PAPER, TITLES, W0, see, verdict

#: The paper's initialisation samples m and horizon k.
M_INIT, K_HORIZON = 3, 100
#: Z ranges searched: the paper's figure range and a wide one.
RATIO_RANGE, WIDE_RANGE = (0.01, 2.0), (0.01, 20.0)
#: A horizon's optimum counts as "Z = 1" within this relative distance.
NEAR_ONE = 0.1


def _eq12_erratum(design, m: int, k: int):
    """The erratum of eq. (12): the printed K against the re-derived one at Z = 0.5 and 2.

    Returns the erratum and the printed and re-derived K at those two ratios.
    """
    z_check = np.array([0.5, 2.0])
    printed = design.variance_factor_printed(z_check, init_samples=m, samples=k)
    correct = design.variance_factor(z_check, 1.0, init_samples=m, samples=k)
    eq12 = Erratum(
        PAPER,
        "Eq. (12), variance factor K",
        "(Z sin(ω0 t_i) − ω0 sin(Z ω0 t_i))² in the sums",
        "(Z sin(ω0 t_i) − sin(Z ω0 t_i))² (eq. 8 with ω1 = Z ω0; eq. 13 has it right)",
        f"At λ = 1, m = {m}, k = {k} the printed K differs from the re-derived one by factors "
        f"{printed[0] / correct[0]:.3g} (Z = 0.5) and {printed[1] / correct[1]:.3g} (Z = 2): a "
        "different function of Z (physid.analysis.input_design.variance_factor_printed). "
        + see("variance"),
    )
    return eq12, printed, correct


def _tables(res) -> tuple[Table, ...]:
    """The optimal ratio per forgetting factor, and against the horizon."""
    rows = [
        (f"{lam:g}", z, kz, "yes" if edge else "no")
        for lam, z, kz, edge in zip(
            res.forgetting,
            res.optimal_ratio,
            res.optimal_variance_factor,
            res.at_boundary,
            strict=False,
        )
    ]
    horizon_rows = [
        (h, h * res.sample_period, z)
        for h, z in zip(res.horizons, res.horizon_optimal_ratio, strict=False)
    ]
    return (
        Table(
            "Optimal ratio Z* in [0.01, 2] per forgetting factor (k = 100, m = 3)",
            ("λ", "Z*", "K(Z*) [s⁻⁴]", "on the range end"),
            rows,
        ),
        Table(
            "Optimal ratio against the horizon k (λ = 1)",
            ("k [samples]", "horizon [s]", "Z*"),
            horizon_rows,
        ),
    )


def _horizon_texts(res, k: int, near_one: list, horizon_periods: dict) -> tuple[str, str]:
    """The optimum at the horizons other than ``k``, and where it is within 10 % of Z = 1."""
    other_horizons = ", ".join(
        f"{h}: {z:.3g} ({horizon_periods[h]:.2g} periods)"
        for h, z in zip(res.horizons, res.horizon_optimal_ratio, strict=False)
        if h != k
    )

    def horizon_list(horizons):
        return ", ".join(
            f"k = {h} ({horizon_periods[h]:.2g} periods, Z* = {z:.3g})"
            for h, z in zip(res.horizons, res.horizon_optimal_ratio, strict=False)
            if h in horizons
        )

    far = [h for h in res.horizons if h not in near_one]
    horizon_text = f"Z* is within 10 % of 1 for {horizon_list(near_one) or 'no horizon'}" + (
        f", not for {horizon_list(far)}" if far else ""
    )
    return other_horizons, horizon_text


def _claim_rows(lambda1_always_best, k, optimum_1, wide_z, other_horizons, horizon_text):
    """The claims rows of section 3: λ = 1 always best, and the optimum at Z = 1."""
    return [
        (
            "λ = 1 is always the optimal forgetting factor (3.C, Fig. 2)",
            "λ = 1",
            "K at λ = 1 is the smallest of λ ∈ {0.95, 0.98, 0.99, 1} at every Z in [0.01, 2]: "
            + ("yes" if lambda1_always_best else "no"),
            verdict(lambda1_always_best),
            "k = 100, m = 3 (the paper's)",
        ),
        (
            "The variance of the Kalman-Bucy estimator is minimal at Z = 1 (3.D, Fig. 3)",
            "Z = 1",
            f"the paper's k = {k}: Z* = {optimum_1:.3g} in [0.01, 2] ({wide_z:.3g} in "
            f"[0.01, 20]); other horizons k: {other_horizons or 'none'}",
            verdict(abs(optimum_1 - 1.0) < 0.05),
            f"λ = 1; {horizon_text}",
        ),
    ]


def compute(quick: bool) -> tuple[SectionData, dict]:
    """K(Z, λ), its optima per λ and per horizon, and the eq. (12) erratum.

    Returns
    -------
    (SectionData, dict)
        The section and the numbers the claims section quotes.
    """
    from ...analysis import input_design as design

    m, k = M_INIT, K_HORIZON  # the paper's
    res = design.design_input(
        forgetting=(0.95, 0.98, 0.99, 1.0),
        ratio_range=RATIO_RANGE,
        n_ratios=200 if quick else 400,
        init_samples=m,
        samples=k,
    )
    # where is the minimum when the range is not cut at Z = 2?
    wide_z, wide_k, wide_edge = design.optimal_ratio(
        1.0, ratio_range=WIDE_RANGE, init_samples=m, samples=k, n_grid=1000 if quick else 4000
    )
    lam_best = np.argmin(res.variance_factor, axis=0)  # the λ with the smallest K at each Z
    lam1 = res.forgetting.index(1.0)
    lambda1_always_best = bool(np.all(lam_best == lam1))
    eq12, printed, correct = _eq12_erratum(design, m, k)
    figures = [FigureData("msd_fig2_3_variance_factor", {"result": res})]
    optimum_1 = res.optimal_ratio[lam1]
    period = 2 * math.pi / W0  # natural period [s]
    horizon_periods = {h: h * res.sample_period / period for h in res.horizons}
    near_one = [  # horizons whose optimum lies within 10 % of Z = 1
        h
        for h, z in zip(res.horizons, res.horizon_optimal_ratio, strict=False)
        if abs(z - 1.0) <= NEAR_ONE
    ]
    other_horizons, horizon_text = _horizon_texts(res, k, near_one, horizon_periods)
    tables = _tables(res)
    results = {
        "optimal_ratio": optimum_1,
        "optimal_ratio_by_forgetting": res.optimal_ratio_by_forgetting(),
        "at_boundary": dict(zip([f"{v:g}" for v in res.forgetting], res.at_boundary, strict=False)),
        "optimal_ratio_wide_range": float(wide_z),
        "horizon_optimal_ratio": dict(
            zip([str(h) for h in res.horizons], res.horizon_optimal_ratio, strict=False)
        ),
        "lambda1_smallest_everywhere": lambda1_always_best,
        "horizon_natural_periods": {str(h): v for h, v in horizon_periods.items()},
        "horizons_with_optimum_near_1": near_one,
        "eq12_printed_over_correct": {
            "0.5": float(printed[0] / correct[0]),
            "2": float(printed[1] / correct[1]),
        },
    }
    claim_rows = _claim_rows(
        lambda1_always_best, k, optimum_1, float(wide_z), other_horizons, horizon_text
    )
    results["quoted"] = {
        "m": m,
        "k": k,
        "sample_period_ms": 1e3 * res.sample_period,
        "horizon_s": k * res.sample_period,
        "horizon_periods": horizon_periods[k],
        "natural_period_s": period,
        "ratio_range": list(RATIO_RANGE),
        "wide_range": list(WIDE_RANGE),
        "at_range_end": bool(res.at_boundary[lam1]),
        "near_one_percent": 100 * NEAR_ONE,
        "horizons": list(res.horizons),
    }
    section = SectionData(
        KEYS["variance"],
        TITLES["variance"],
        tables=tables,
        figures=tuple(figures),
        results=results,
        errata=(eq12,),
    )
    return section, {"claim_rows": claim_rows, **results}
