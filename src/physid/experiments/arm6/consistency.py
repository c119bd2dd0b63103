"""A physically consistent estimate: every link realisable, friction ≥ 0."""

from __future__ import annotations

import time
import warnings
from typing import Any

from ..data import SectionData, Table
from ._common import KEYS, TITLES, say


def compute(setup, first, quick: bool = False, progress=None) -> SectionData:
    """The consistent estimate of the first noisy record and its distance from OLS.

    Returns
    -------
    SectionData
    """
    results: dict[str, Any] = {
        "missing": list(setup.missing),
        "missing_reasons": list(setup.reasons),
    }
    rec = first.get("recording") if first else None
    if rec is None:
        results["available"] = False
        return SectionData(KEYS["consistency"], TITLES["consistency"], results=results)
    if quick:  # the constrained fit costs minutes on a loaded machine: the full demo runs it
        results.update(available=False, skipped_in_quick_run=True)
        return SectionData(KEYS["consistency"], TITLES["consistency"], results=results)
    say(progress, "physically consistent estimate")
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = setup.idim(setup.model, "ols", consistent=True).fit(rec).result_
        c = r.consistent
    except Exception as exc:
        results.update(available=False, error=f"{type(exc).__name__}: {exc}")
        return SectionData(KEYS["consistency"], TITLES["consistency"], results=results)
    if c is None:
        results.update(available=False, error="the estimator returned no consistent estimate")
        return SectionData(KEYS["consistency"], TITLES["consistency"], results=results)
    results.update(
        {
            "available": True,
            "cost_ratio": c.cost_ratio,
            "at_boundary": list(c.at_boundary),
            "n_at_boundary": len(c.at_boundary),
            "min_eigenvalues": dict(c.min_eigenvalues),
            "message": c.message,
            "n_links": len(c.min_eigenvalues),
            "wall_time_s": time.perf_counter() - t0,
        }
    )
    tables = (
        Table(
            "Smallest eigenvalue of each link's pseudo-inertia in the consistent estimate",
            ("link", "smallest eigenvalue [kg·m²]"),
            list(c.min_eigenvalues.items()),
        ),
    )
    return SectionData(KEYS["consistency"], TITLES["consistency"], results=results, tables=tables)
