"""What every part's renderers share: the section builder and the errata paragraph."""

from __future__ import annotations

from collections.abc import Callable

from ..html import Html, ReportSection


def make_section(part: str) -> Callable[..., ReportSection]:
    """A ``section(sd, paragraphs, figures=())`` builder for the sections of ``part``.

    Parameters
    ----------
    part : str
        The part's heading, e.g. ``"Part I — …"``.

    Returns
    -------
    callable
        ``(section_data, paragraphs, figures=()) -> ReportSection`` with the section's title,
        tables, results and errata.
    """

    def section(sd, paragraphs, figures=()) -> ReportSection:
        return ReportSection(
            sd.title,
            paragraphs=tuple(paragraphs),
            tables=sd.tables,
            figures=tuple(figures),
            results=sd.results,
            errata=sd.errata,
            part=part,
        )

    return section


def errata_section(sd, r, section: Callable[..., ReportSection]) -> ReportSection:
    """The errata section of a paper's part: the count and a link to the full table.

    Parameters
    ----------
    sd : SectionData
        The errata section's data.
    r : dict
        Its results (``count``), as read back from JSON.
    section : callable
        The part's builder from `make_section`.

    Returns
    -------
    ReportSection
    """
    paragraphs = [
        Html(
            f"The reproduction found {r['count']} errors or misprints in the paper. Each is "
            "listed here with its correction; the full table at the end of the report gives "
            'what is printed and the evidence (<a href="#errata">Errata found in the papers</a>).'
        )
    ]
    return section(sd, paragraphs)
