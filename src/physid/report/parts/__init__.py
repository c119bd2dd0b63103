"""Renderers of the report's parts: `physid.experiments.data.SectionData` → `ReportSection`.

Each part module (`manipulator`, `msd`, `arm`) maps section keys to functions
``render(section_data, results) -> ReportSection``; ``results`` is the section's results as read
back from JSON, so the paragraphs quote exactly the numbers of ``results.json``. `render` looks
the key up and calls it.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from ...errors import InputError
from ...estimators.results import jsonable
from ...experiments.data import SectionData
from ..html import ReportSection

__all__ = ["render", "renderers"]


def renderers() -> dict[str, Callable[[SectionData, dict[str, Any]], ReportSection]]:
    """Every known section key and its renderer.

    Returns
    -------
    dict
        Section key → ``renderer(data, results) -> ReportSection``.
    """
    from . import arm, manipulator, msd

    return {**manipulator.RENDERERS, **msd.RENDERERS, **arm.RENDERERS}


def as_json(results) -> dict[str, Any]:
    """``results`` as results.json will hold them (NaN → None, arrays → lists)."""
    return json.loads(json.dumps(jsonable(dict(results)), allow_nan=False))


def render(section: SectionData) -> ReportSection:
    """The `ReportSection` of one section's data.

    Parameters
    ----------
    section : SectionData
        What an experiment returned for one report section.

    Returns
    -------
    ReportSection
        The rendered section (paragraphs, tables, figures, results).

    Raises
    ------
    InputError
        No renderer is registered for ``section.key``.
    """
    table = renderers()
    if section.key not in table:
        raise InputError(
            f"no report renderer for section key {section.key!r} (section {section.title!r}); "
            f"known keys: {sorted(table)}. Register it in physid.report.parts."
        )
    return table[section.key](section, as_json(section.results))
