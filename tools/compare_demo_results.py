"""Compare a demo's ``results.json`` with a baseline, value by value (timings aside).

The invariant of the demo: every number a baseline ``results.json`` holds is still there, under
the same path, with the same value. New keys, sections and tables may be added; nothing may change
or vanish. Wall times, dates and installed versions are skipped (they differ run to run).

Usage::

    python tools/compare_demo_results.py NEW/results.json BASELINE/results.json [...]

Each NEW/BASELINE pair is given as two paths; several pairs may follow each other. Exit status 0
when every pair matches, 1 otherwise (the first differences are printed).
"""

from __future__ import annotations

import json
import math
import re
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

#: Paths (dotted, regex on the whole path) whose values change from run to run.
SKIP = re.compile(
    r"(^|\.)(wall_time_s|elapsed_s|run_time_s|total_wall_time_s|created|versions|cpu_count"
    r"|python|physid_version|design_seconds|wall_time_per_fit_s|simulate_wall_time_s"
    r"|noise_free_wall_time_s)(\.|$)"
)
#: Table columns that hold timings.
TIME_COLUMN = re.compile(r"wall time|time \[s\]$|time per fit \[s\]")

#: Old section title -> new one, where a restructuring renamed a section (empty: none renamed).
RENAMED: dict[str, str] = {
    "About this report": "About this report",
}


def _leaves(value: Any, path: str = "") -> Iterator[tuple[str, Any]]:
    if isinstance(value, Mapping):
        for k, v in value.items():
            yield from _leaves(v, f"{path}.{k}" if path else str(k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from _leaves(v, f"{path}[{i}]")
    else:
        yield path, value


def _equal(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == b


def _tables(payload: Mapping[str, Any]) -> dict[str, Any]:
    """Tables keyed by ``section / caption`` with timing columns blanked."""
    out = {}
    for section, tables in payload.get("tables", {}).items():
        for table in tables:
            drop = [i for i, c in enumerate(table["columns"]) if TIME_COLUMN.search(c)]
            rows = [[None if i in drop else c for i, c in enumerate(r)] for r in table["rows"]]
            if "Run time" in table["caption"] or table["caption"].startswith("Software versions"):
                continue
            out[f"{section} / {table['caption']}"] = {"columns": table["columns"], "rows": rows}
    return out


def compare(new: Mapping[str, Any], base: Mapping[str, Any], limit: int = 30) -> list[str]:
    """Differences between ``new`` and ``base`` (empty when ``new`` keeps every baseline value)."""
    problems: list[str] = []
    new_results = dict(new.get("results", {}))
    for old_title, section in base.get("results", {}).items():
        title = RENAMED.get(old_title, old_title)
        if title not in new_results:
            problems.append(f"section missing: {old_title!r}")
            continue
        got = dict(_leaves(new_results[title]))
        for path, value in _leaves(section):
            if SKIP.search(path):
                continue
            if path not in got:
                problems.append(f"{old_title} :: {path}: missing (baseline {value!r})")
            elif not _equal(got[path], value):
                problems.append(f"{old_title} :: {path}: {got[path]!r} != baseline {value!r}")
    new_tables, base_tables = _tables(new), _tables(base)
    for key, table in base_tables.items():
        section, _, caption = key.partition(" / ")
        key_new = f"{RENAMED.get(section, section)} / {caption}"
        if key_new not in new_tables:
            problems.append(f"table missing: {key}")
        elif new_tables[key_new] != table:
            problems.append(f"table changed: {key}")
    if [dict(e) for e in new.get("errata", [])] != [dict(e) for e in base.get("errata", [])]:
        problems.append("errata changed")
    return problems[:limit] + (
        [f"... and {len(problems) - limit} more"] if len(problems) > limit else []
    )


def main(argv: list[str]) -> int:
    if len(argv) < 2 or len(argv) % 2:
        print(__doc__, file=sys.stderr)
        return 2
    status = 0
    for new_path, base_path in zip(argv[::2], argv[1::2], strict=True):
        new = json.loads(Path(new_path).read_text(encoding="utf-8"))
        base = json.loads(Path(base_path).read_text(encoding="utf-8"))
        problems = compare(new, base)
        n = sum(1 for s in base.get("results", {}).values() for _ in _leaves(s))
        if problems:
            status = 1
            print(f"{new_path} differs from {base_path}:")
            for p in problems:
                print(f"  {p}")
        else:
            print(f"{new_path} matches {base_path} ({n} baseline values, timings aside)")
    return status


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
