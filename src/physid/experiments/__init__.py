"""Paper reproductions and studies, each runnable end to end, returning data for the report.

* `manipulator_paper` — Cedro & Janecki (a 4-DOF arm by the input-error method);
* `msd_paper` — Oueslati et al. (algebraic vs recursive estimation of a mass-spring-damper);
* `arm6` — a 6-DOF arm identified end to end (excitation, IDIM, validation).

Each is a package with one module per report section and ``run(quick=False, progress=None) ->
list[SectionData]`` (`physid.experiments.data`). `physid.report` renders the data; nothing here
imports it. `physid.report.demo.run_demo` runs them all and writes the report.
"""

from .data import Erratum, FigureData, SectionData, Table

__all__ = ["SectionData", "FigureData", "Table", "Erratum"]
