"""Oueslati et al. (2011), *On algebraic approach for MSD parametric estimation*, reproduced.

One module per report section, each returning `physid.experiments.data.SectionData` with our
measured numbers beside the paper's claims (`physid.report` renders them):

* `claims` — the claims of section 5 checked one by one (which hold, which do not, and under
  what conditions);
* `variance` — the variance function K(Z, λ) and the optimal input ratio (section 3, Figs. 2–3),
  from `physid.analysis.input_design`;
* `traces` — ω0 estimates against time at 25, 50 and 80 dB for the algebraic and the recursive
  estimator (Figs. 7–12);
* `maps` — convergence-time maps over SNR × Z (Figs. 5–6) from a Monte-Carlo sweep
  (`physid.analysis.montecarlo.msd_sweep`), and the shortest usable algebraic window;
* `disturbance` — the high-frequency disturbance A2 = 0.1 m, ω2 = 500 ω0 (Figs. 13–15) and what
  1 kHz sampling does to it (aliasing);
* `jumps` — a jumping ω0 (Fig. 16): tracking and recovery time after each jump;
* `errata` — the paper's errata with the numbers that show them.

Every record is simulated with a fixed seed (`SEED`), so the numbers are reproducible. The paper's
system: k = 400 N/m, c = 0.05 N·s/m, m = 3 kg (ω0 = 11.547 rad/s, ζ = 7.2e-4), T_s = 1 ms,
u = A1 sin(Z ω0 t) with A1 = 1000/3 m/s² on the normalised equation.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

from ..data import SectionData, errata_list
from . import claims, disturbance, jumps, maps, traces, variance
from . import errata as _errata_module
from ._common import KEYS, PAPER, SEED, TITLES

__all__ = ["run", "SEED", "PAPER", "TITLES"]


def run(quick: bool = False, progress: Callable[[str], None] | None = None) -> list[SectionData]:
    """Reproduce the MSD study of Oueslati et al. (2011) and return the report sections as data.

    Parameters
    ----------
    quick : bool
        Short records and a small sweep grid (well under 30 s on two cores); the full run takes
        a few minutes at most.
    progress : callable, optional
        Receives short progress messages (the CLI prints them on stderr).

    Returns
    -------
    list of SectionData
        The claims summary, the variance analysis, the ω0 traces, the convergence maps, the
        disturbance and the jumping-ω0 studies and the errata list (see `TITLES`), with errata
        attached to the sections that evidence them.
    """
    from ._common import say

    start = time.perf_counter()
    say(progress, "variance function and optimal input")
    variance_section, variance_results = variance.compute(quick)
    traces_section, traces_results = traces.compute(quick, progress)
    maps_section, maps_results = maps.compute(quick, progress)
    say(progress, "shortest algebraic window")
    windows = maps.window_search(quick)
    maps_section = dataclasses.replace(
        maps_section, results={**maps_section.results, "window_search": windows}
    )
    disturbance_section, disturbance_results = disturbance.compute(quick, progress, traces_results)
    jumps_section, _ = jumps.compute(quick, progress)
    say(progress, "errata evidence")
    found, evidence = _errata_module.errata(quick)
    claims_section = claims.compute(
        traces_results, maps_results, windows, disturbance_results, variance_results, quick
    )
    claims_section = dataclasses.replace(
        claims_section,
        errata=tuple(found),
        results={
            **claims_section.results,
            "errata_evidence": evidence,
            "wall_time_s": round(time.perf_counter() - start, 2),
            "quick": quick,
        },
    )
    body = [
        claims_section,
        variance_section,
        traces_section,
        maps_section,
        disturbance_section,
        jumps_section,
    ]
    return [*body, errata_list(body, KEYS["errata"], TITLES["errata"], "Oueslati et al.")]
