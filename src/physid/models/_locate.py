"""Locating keys in the text of a TOML model file, for error messages ("file, line N (what)")."""

from __future__ import annotations

import bisect
import functools
import re

__all__: list[str] = []


@functools.lru_cache(maxsize=8)
def _lines(text: str) -> tuple[str, ...]:
    return tuple(text.splitlines())


@functools.lru_cache(maxsize=32)
def _table_spans(text: str, table: str) -> tuple[tuple[int, int], ...]:
    """(start, end) line indices of every ``[table]``/``[[table]]`` (and ``[table.x]``) block.

    Computed once per text and table (a 200-joint file is looked up thousands of times: one
    scan per lookup was quadratic, 25 s).
    """
    lines = _lines(text)
    header = re.compile(r"^\s*\[\[?\s*" + re.escape(table) + r"(\.[^\]]*)?\s*\]\]?\s*(#.*)?$")
    hits = [i for i, line in enumerate(lines) if header.match(line)]
    is_hit = set(hits)
    others = [i for i, line in enumerate(lines) if i not in is_hit and re.match(r"^\s*\[", line)]
    spans = []
    for k, start in enumerate(hits):
        nxt = bisect.bisect_right(others, start)
        candidates = [len(lines)]
        if nxt < len(others):
            candidates.append(others[nxt])
        if k + 1 < len(hits):
            candidates.append(hits[k + 1])
        spans.append((start, min(candidates)))
    return tuple(spans)


def _line_of(text: str, key: str, *, table: str | None = None, index: int = 0) -> int | None:
    """1-based line of ``key = ...`` in the ``index``-th ``[table]``/``[[table]]`` (best effort)."""
    if not text:
        return None
    lines = _lines(text)
    start, end = 0, len(lines)
    if table is not None:
        spans = _table_spans(text, table)
        if index < len(spans):
            start, end = spans[index]
        elif spans:
            start = spans[-1][0]
    pattern = re.compile(r"^\s*" + re.escape(key) + r"\s*[=.]")
    for i in range(start, end):
        if pattern.match(lines[i]):
            return i + 1
    if table is not None and start < len(lines):
        return start + 1
    return None


@functools.lru_cache(maxsize=8)
def _parameter_tables(text: str) -> dict[str, int]:
    """Line index of each ``[parameters.NAME]`` sub-table header, by NAME (first one)."""
    sub = re.compile(r"^\s*\[\s*parameters\s*\.\s*[\"']?([^\"'\]\s]+)[\"']?\s*\]\s*(#.*)?$")
    found: dict[str, int] = {}
    for i, line in enumerate(_lines(text)):
        m = sub.match(line)
        if m:
            found.setdefault(m.group(1), i)
    return found


def _parameter_line(text: str, pname: str, key: str | None = None) -> int | None:
    """1-based line of parameter ``pname`` (or of its ``key``, e.g. ``value``) in the text.

    Handles ``pname = {...}`` under ``[parameters]``, a sub-table ``[parameters.pname]`` (then
    ``key`` is looked up inside it), and dotted keys ``pname.value = ...``.
    """
    if not text:
        return None
    lines = _lines(text)
    i = _parameter_tables(text).get(pname)
    if i is not None:
        if key is not None:
            key_pattern = re.compile(r"^\s*" + re.escape(key) + r"\s*=")
            for j in range(i + 1, len(lines)):
                if re.match(r"^\s*\[", lines[j]):
                    break
                if key_pattern.match(lines[j]):
                    return j + 1
        return i + 1
    return _line_of(text, pname, table="parameters")


def _parameter_where(source: str, text: str, pname: str, key: str | None = None) -> str:
    line = _parameter_line(text, pname, key)
    loc = f"{source}, line {line}" if line else source
    return f"{loc} (parameter {pname!r})"


def _where(
    source: str, text: str, what: str, key: str, *, table: str | None = None, index: int = 0
) -> str:
    line = _line_of(text, key, table=table, index=index)
    loc = f"{source}, line {line}" if line else source
    return f"{loc} ({what})"
