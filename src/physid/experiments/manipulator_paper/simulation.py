"""Section 4 of the paper: the closed-loop simulation (Fig. 2), paper and exact kinetic energy."""

from __future__ import annotations

import numpy as np

from ...simulate.closed_loop import PAPER_MANIPULATOR
from ..data import FigureData, SectionData, Table
from ._common import KEYS, SEPARATE, TITLES, TRUTH

#: The integrator settings of `physid.simulate.closed_loop` used for both recordings.
INTEGRATOR = {"method": "DOP853", "rtol": 1e-9}


def compute(rec_paper, rec_exact, mismatch, mismatch_at_bound) -> SectionData:
    """Both closed-loop recordings, their difference and the paper model fitted to exact data.

    Parameters
    ----------
    rec_paper, rec_exact : Recording
        The paper's experiment simulated with the paper's and with the exact kinetic energy.
    mismatch : dict
        The separately identifiable parameters of the paper's model fitted to ``rec_exact``.
    mismatch_at_bound : sequence of str
        Parameters of that fit that ended on a bound.

    Returns
    -------
    SectionData
    """
    q = [f"q{i}" for i in range(1, 5)]
    diff = np.abs(rec_exact.select(q) - rec_paper.select(q)).max(axis=0)
    peak = np.abs(rec_paper.select(q)).max(axis=0)
    rows = [(f"joint {j + 1}", float(peak[j]), float(diff[j])) for j in range(4)]
    return SectionData(
        KEYS["simulation"],
        TITLES["simulation"],
        results={
            "n_samples": rec_paper.n_samples,
            "duration_s": rec_paper.duration,
            "max_abs_q_difference_rad": diff.tolist(),
            "paper_model_fitted_to_exact_data": mismatch,
            "paper_model_fitted_to_exact_data_at_bound": list(mismatch_at_bound),
            "setup": {
                "integrator": INTEGRATOR["method"],
                "rtol": INTEGRATOR["rtol"],
                "dt_s": PAPER_MANIPULATOR["dt"],
                "kp": list(PAPER_MANIPULATOR["kp"]),
                "kd": list(PAPER_MANIPULATOR["kd"]),
                "step_height_rad": PAPER_MANIPULATOR["step_height"],
                "step_times_s": list(PAPER_MANIPULATOR["step_times"]),
                "reference_half_width": PAPER_MANIPULATOR["half_width"],
                "reference_cutoff": PAPER_MANIPULATOR["cutoff"],
                "end_time_s": PAPER_MANIPULATOR["end_time"],
            },
            "truth": {n: TRUTH[n] for n in SEPARATE},
            "max_abs_q_difference_overall_rad": float(diff.max()),
        },
        tables=(
            Table(
                "Exact against the paper's kinetic energy: largest |Δq| over the record",
                ("joint", "max |q| paper model [rad]", "max |q_exact − q_paper| [rad]"),
                rows,
            ),
        ),
        figures=(
            FigureData("manipulator_fig2_responses", {"recording": rec_paper}),
            FigureData("manipulator_exact_responses", {"recording": rec_exact}),
        ),
    )
