"""Identifiability: m1 and l1 enter only as m1·l1², and J is flat along that valley."""

from __future__ import annotations

import numpy as np

from ...analysis.identifiability import structural_identifiability
from ..data import Erratum, FigureData, SectionData, Table
from ._common import COMBO, KEYS, PAPER, PAPER_INITIAL, PAPER_RESULT, TITLES, see

#: States at which the structural sensitivity is evaluated.
N_STATES = 64
#: l1 [m] at which J is evaluated along the valley m1·l1² = const.
VALLEY_L1 = (0.37, 0.40, 0.43)


def _cost_grid(fast, theta, names, n_grid: int):
    """J over an (m1, l1) grid, the other parameters at ``theta``.

    Returns the m1 and l1 axes and J (rows: l1).
    """
    m1 = np.linspace(40.0, 60.0, n_grid)
    l1 = np.linspace(0.36, 0.44, n_grid)
    i_m1, i_l1 = names.index("m1"), names.index("l1")
    cost = np.empty((l1.size, m1.size))
    for a, lv in enumerate(l1):
        for b, mv in enumerate(m1):
            th = theta.copy()
            th[i_m1], th[i_l1] = mv, lv
            cost[a, b] = fast(th)
    return m1, l1, cost


def _valley(fast, theta, names, product: float) -> list[float]:
    """J along the valley m1·l1² = ``product``, at each l1 of `VALLEY_L1`."""
    i_m1, i_l1 = names.index("m1"), names.index("l1")
    return [
        fast(
            np.where(
                np.arange(len(names)) == i_m1,
                product / lv**2,
                np.where(np.arange(len(names)) == i_l1, lv, theta),
            )
        )
        for lv in VALLEY_L1
    ]


def compute(model, result, fast, nm, quick) -> SectionData:
    """The structural SVD, J over an (m1, l1) grid and along the valley.

    Returns
    -------
    SectionData
    """
    names = fast.names
    s = structural_identifiability(model, n_states=N_STATES)
    theta = np.array([result.parameters[n] for n in names])
    n_grid = 41 if quick else 81
    m1, l1, cost = _cost_grid(fast, theta, names, n_grid)
    paper = PAPER_RESULT["parameters"]
    nm_params = dict(zip(names, nm.x.tolist(), strict=True))
    along = _valley(fast, theta, names, result.combinations[COMBO])
    sv_rows = [(f"σ{i + 1}/σ1", float(v)) for i, v in enumerate(s.singular_values)]
    theta_rank = int(model.base_parameters().theta_rank)
    return SectionData(
        KEYS["identifiability"],
        TITLES["identifiability"],
        tables=(
            Table(
                "Relative singular values of the scaled structural sensitivity",
                ("", "value"),
                sv_rows,
            ),
        ),
        figures=(
            FigureData(
                "manipulator_m1_l1_valley",
                {
                    "m1": m1,
                    "l1": l1,
                    "cost": cost,
                    "product": result.combinations[COMBO],
                    "estimate": (result.parameters["m1"], result.parameters["l1"]),
                    "paper_point": (paper["m1"], paper["l1"]),
                    "start": (PAPER_INITIAL["m1"], PAPER_INITIAL["l1"]),
                    "nelder_mead": (nm_params["m1"], nm_params["l1"]),
                },
            ),
        ),
        results={
            "texts": s.texts,
            "expressions": s.expressions,
            "singular_values": s.singular_values,
            "J_along_valley": dict(zip(("l1=0.37", "l1=0.40", "l1=0.43"), along, strict=True)),
            "models_theta_rank": theta_rank,
            "quoted": {
                "n_states": N_STATES,
                "n_parameters": len(names),
                "combo": result.combinations[COMBO],
                "valley_l1_m": list(VALLEY_L1),
                "paper_m1": paper["m1"],
                "paper_l1": paper["l1"],
                "paper_combo": paper["m1"] * paper["l1"] ** 2,
                "smallest_singular_value": float(s.singular_values[-1]),
                "next_singular_value": float(s.singular_values[-2]),
            },
        },
        errata=(
            Erratum(
                PAPER,
                "Section 2, T1 and K0[k]; section 5, results",
                "θ = [m1..m4, l1..l4] identified as 8 separate parameters; m1 = 49.5818, l1 = "
                "0.407419",
                "only m1·l1² (and m2..m4, l2..l4) can be identified; T1 has no length, so l1 "
                "enters only through J1 = m1·l1²/12",
                f"Structural SVD: relative singular value {s.singular_values[-1]:.1e} along "
                "(δm1/m1, δl1/l1) ∝ (2, −1); J constant along m1·l1² = const (figure "
                "manipulator_m1_l1_valley)." + see("identifiability"),
            ),
        ),
    )
