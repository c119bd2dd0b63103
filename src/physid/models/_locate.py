"""Locating keys in the text of a TOML model file, for error messages ("file, line N (what)")."""

from __future__ import annotations

import re

__all__: list[str] = []


def _line_of(text: str, key: str, *, table: str | None = None, index: int = 0) -> int | None:
    """1-based line of ``key = ...`` in the ``index``-th ``[table]``/``[[table]]`` (best effort)."""
    if not text:
        return None
    lines = text.splitlines()
    start, end = 0, len(lines)
    if table is not None:
        header = re.compile(r"^\s*\[\[?\s*" + re.escape(table) + r"(\.[^\]]*)?\s*\]\]?\s*(#.*)?$")
        hits = [i for i, line in enumerate(lines) if header.match(line)]
        if index < len(hits):
            start = hits[index]
            nxt = [
                i
                for i, line in enumerate(lines)
                if i > start and re.match(r"^\s*\[", line) and not header.match(line)
            ]
            same = [i for i in hits if i > start]
            end = min([*nxt, *same, len(lines)])
        elif hits:
            start = hits[-1]
    pattern = re.compile(r"^\s*" + re.escape(key) + r"\s*[=.]")
    for i in range(start, end):
        if pattern.match(lines[i]):
            return i + 1
    if table is not None and start < len(lines):
        return start + 1
    return None


def _parameter_line(text: str, pname: str, key: str | None = None) -> int | None:
    """1-based line of parameter ``pname`` (or of its ``key``, e.g. ``value``) in the text.

    Handles ``pname = {...}`` under ``[parameters]``, a sub-table ``[parameters.pname]`` (then
    ``key`` is looked up inside it), and dotted keys ``pname.value = ...``.
    """
    if not text:
        return None
    lines = text.splitlines()
    name = re.escape(pname)
    sub = re.compile(r"^\s*\[\s*parameters\s*\.\s*[\"']?" + name + r"[\"']?\s*\]\s*(#.*)?$")
    for i, line in enumerate(lines):
        if sub.match(line):
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
