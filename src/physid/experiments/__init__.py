"""Paper reproductions, each runnable end to end: `manipulator_paper` (Cedro & Janecki),
`msd_paper` (Oueslati et al.), and `demo.run_demo`, which runs both and writes the report.

Each paper module exposes ``run(quick=False, progress=None) -> list[ReportSection]``.
"""

from .demo import run_demo

__all__ = ["run_demo"]
