"""What an experiment returns: data for the report, never rendering.

An experiment (one package per paper, one module per report section) computes numbers and hands
them back as `SectionData`: its ``results`` (JSON-ready numbers, written to ``results.json``), the
``tables`` (`Table`: cells are numbers or short labels), the ``figures`` as data (`FigureData`:
arrays and result objects, drawn later by `physid.report`) and the ``errata`` it found
(`Erratum`). `physid.report` renders a section: it writes the paragraphs from the results as read
back from JSON, draws the figures with one figure style and writes the page. Nothing here imports
`physid.report` or matplotlib.

Example
-------
>>> sec = SectionData("part.key", "A title", results={"k": 2.0},
...                   tables=(Table("Values", ("name", "value"), (("k", 2.0),)),))
>>> sec.key, sec.tables[0].rows
('part.key', (('k', 2.0),))
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import InputError

__all__ = ["SectionData", "FigureData", "Table", "Erratum", "Cell", "errata_list"]

_NAME_RE = re.compile(r"^[A-Za-z0-9_-]+$")

Cell = str | float | int | None


def _check_cell(cell: Any, caption: str) -> Cell:
    if cell is None or isinstance(cell, str):
        return cell
    if isinstance(cell, (bool, np.bool_)):
        return str(bool(cell))
    if isinstance(cell, (int, np.integer)):
        return int(cell)
    if isinstance(cell, (float, np.floating)):
        return float(cell)
    raise InputError(
        f"Table {caption!r}: a cell must be str, int, float or None; got {type(cell).__name__} "
        f"({cell!r}). Convert it first, e.g. float(x) or str(x)."
    )


@dataclass(frozen=True)
class Table:
    """A table shown in a report section.

    Parameters
    ----------
    caption : str
        One line saying what the table shows.
    columns : sequence of str
        Column headers.
    rows : sequence of sequences of cells
        Each row has one cell per column; a cell is a ``str``, ``int``, ``float`` or ``None``
        (shown as an em dash). Floats are shown with 6 significant digits.
    summary : sequence of cells, optional
        A summary row, one cell per column. Tables longer than the report's limit are shown
        collapsed (``<details>``) behind this row.
    """

    caption: str
    columns: Sequence[str]
    rows: Sequence[Sequence[Cell]]
    summary: Sequence[Cell] | None = None

    def __post_init__(self) -> None:
        columns = tuple(str(c) for c in self.columns)
        rows = tuple(tuple(_check_cell(c, self.caption) for c in r) for r in self.rows)
        checked = list(rows)
        if self.summary is not None:
            summary = tuple(_check_cell(c, self.caption) for c in self.summary)
            object.__setattr__(self, "summary", summary)
            checked.append(summary)
        for i, row in enumerate(checked):
            if len(row) != len(columns):
                raise InputError(
                    f"Table {self.caption!r}: row {i} has {len(row)} cell(s) but there are "
                    f"{len(columns)} column(s) {columns}; give one cell per column."
                )
        object.__setattr__(self, "columns", columns)
        object.__setattr__(self, "rows", rows)


@dataclass(frozen=True)
class Erratum:
    """A misprint or error found in a paper.

    Parameters
    ----------
    paper : str
        Short citation, e.g. ``"Cedro & Janecki"``.
    location : str
        Where in the paper (``"Eq. (12)"``, ``"Table 2, row m1"``).
    printed : str
        What the paper prints.
    correct : str
        What it should be.
    evidence : str
        How we know: a number, a derivation, or the name of a figure in the report.
    """

    paper: str
    location: str
    printed: str
    correct: str
    evidence: str


@dataclass(frozen=True)
class FigureData:
    """The data of one figure; `physid.report` draws it.

    Parameters
    ----------
    name : str
        File stem: letters, digits, ``-`` and ``_`` only; the report saves ``NAME.png``.
    data : mapping
        What the drawing function needs (arrays, recordings, result objects); not written to
        JSON.
    """

    name: str
    data: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME_RE.match(self.name):
            raise InputError(
                f"FigureData name must use only letters, digits, '-' and '_' (it becomes "
                f"NAME.png); got {self.name!r}. Rename the figure, e.g. 'fig2_responses'."
            )


@dataclass(frozen=True)
class SectionData:
    """One report section as data.

    Parameters
    ----------
    key : str
        Which renderer of `physid.report` writes the section (``"manipulator.simulation"``).
    title : str
        Section heading; also its key in ``results.json`` (unique in a report).
    results : mapping
        The section's numbers, JSON-ready after `physid.estimators.results.jsonable`. Every
        number the report writes in a paragraph is taken from here.
    tables : sequence of Table
    figures : sequence of FigureData
    errata : sequence of Erratum
    """

    key: str
    title: str
    results: Mapping[str, Any] = field(default_factory=dict)
    tables: Sequence[Table] = ()
    figures: Sequence[FigureData] = ()
    errata: Sequence[Erratum] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.title, str) or not self.title.strip():
            raise InputError(f"SectionData title must be a non-empty string; got {self.title!r}.")
        for name, kind in (("tables", Table), ("figures", FigureData), ("errata", Erratum)):
            items = tuple(getattr(self, name))
            for item in items:
                if not isinstance(item, kind):
                    raise InputError(
                        f"SectionData {self.title!r}: {name} must hold {kind.__name__} objects; "
                        f"got {type(item).__name__}."
                    )
            object.__setattr__(self, name, items)
        if not isinstance(self.results, Mapping):
            raise InputError(
                f"SectionData {self.title!r}: results must be a mapping name -> value; got "
                f"{type(self.results).__name__}."
            )

    def figure(self, name: str) -> FigureData:
        """The figure data called ``name``."""
        for f in self.figures:
            if f.name == name:
                return f
        raise KeyError(name)


def errata_list(sections: Sequence[SectionData], key: str, title: str, paper: str) -> SectionData:
    """A part's closing list of errata, gathered from its sections (the full table ends the report).

    Parameters
    ----------
    sections : sequence of SectionData
        The part's sections, in order; their ``errata`` are listed in that order.
    key, title : str
        The list section's renderer key and title.
    paper : str
        Authors of the paper, for the table's caption (``"Cedro & Janecki"``).

    Returns
    -------
    SectionData
        ``results={"count": n}`` and one table of (where, correct).

    Examples
    --------
    >>> e = Erratum("X et al.", "eq. 2", "Y = u - ẋ", "Y = u - ẍ", "not the model with ẋ")
    >>> out = errata_list([SectionData("k", "A", errata=(e,))], "p.errata", "Errata", "X et al.")
    >>> out.results, out.tables[0].rows
    ({'count': 1}, (('eq. 2', 'Y = u - ẍ'),))
    >>> out.tables[0].caption
    'Errata of X et al. (evidence in the full table at the end)'
    """
    found = [e for s in sections for e in s.errata]
    return SectionData(
        key,
        title,
        results={"count": len(found)},
        tables=(
            Table(
                f"Errata of {paper} (evidence in the full table at the end)",
                ("where", "correct"),
                [(e.location, e.correct) for e in found],
            ),
        ),
    )
