"""Figures (matplotlib; returned, never shown) and the self-contained HTML report.

One module per topic: `figures` (recordings), `filters`, `simulation`, `manipulator`
(input-error fits), `algebraic`, `recursive`, `input_design`, `msd` (sweeps and the MSD study),
and `html` (`write_report`).
"""

from .html import Erratum, FigureSpec, Html, ReportPaths, ReportSection, Table, write_report

__all__ = [
    "write_report",
    "ReportSection",
    "Table",
    "FigureSpec",
    "Erratum",
    "Html",
    "ReportPaths",
]
