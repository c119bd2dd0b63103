"""Every link in README.md and docs/*.md resolves inside the repository .

Markdown links ``[text](target)`` must point at a file of this repository (no ``../`` out of
it, no web address: the docs travel with the source), and a ``#fragment`` at a heading of the
target. Code spans that name a repository path (```docs/x.md```, ```examples/y.py```) must exist
too, so a renamed file cannot leave a dangling mention.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"(?<!\!)\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
IMAGE = re.compile(r"!\[[^\]]*\]\(([^)\s]+)\)")
CODE_PATH = re.compile(
    r"`((?:\.\./|\./)?(?:docs|examples|src|tests|benchmarks|tools|shared|\.\./shared)/"
    r"[\w./-]+\.(?:md|py|toml|urdf|json|csv))`"
)
FENCE = re.compile(r"^```.*?^```", re.S | re.M)


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    text = FENCE.sub("", path.read_text(encoding="utf-8"))
    return {_slug(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.+?)\s*#*\s*$", text, re.M)}


def _targets(path: Path):
    text = FENCE.sub("", path.read_text(encoding="utf-8"))
    for pattern, kind in ((LINK, "link"), (IMAGE, "image"), (CODE_PATH, "path")):
        for m in pattern.finditer(text):
            line = text.count("\n", 0, m.start()) + 1
            yield kind, m.group(1), line


def _problem(doc: Path, kind: str, target: str) -> str | None:
    if re.match(r"^[a-z][a-z0-9+.-]*:", target):
        return "points outside the repository (a web address); link a file of the repository"
    file_part, _, fragment = target.partition("#")
    if kind == "path":
        resolved = (ROOT / file_part).resolve()
        if not resolved.exists():
            resolved = (doc.parent / file_part).resolve()
    else:
        resolved = (doc.parent / file_part).resolve() if file_part else doc
    try:
        resolved.relative_to(ROOT)
    except ValueError:
        return f"resolves outside the repository ({resolved})"
    if not resolved.exists():
        return f"names a missing file ({resolved.relative_to(ROOT)})"
    if fragment and resolved.suffix == ".md" and fragment not in _anchors(resolved):
        return f"names a missing heading #{fragment} in {resolved.relative_to(ROOT)}"
    return None


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_link_resolves_inside_the_repository(doc):
    problems = [
        f"{doc.relative_to(ROOT)}:{line}: {kind} {target!r} {why}"
        for kind, target, line in _targets(doc)
        if (why := _problem(doc, kind, target))
    ]
    assert not problems, "\n".join(problems)


def test_the_checker_catches_bad_links(tmp_path):
    doc = ROOT / "docs" / "index.md"
    assert _problem(doc, "link", "https://example.org/x") is not None
    assert _problem(doc, "link", "../../outside.md") is not None
    assert _problem(doc, "link", "no-such-file.md") is not None
    assert _problem(doc, "link", "architecture.md#no-such-heading") is not None
    assert _problem(doc, "link", "architecture.md#recording-files") is None
    assert _problem(doc, "path", "../shared/ARCHITECTURE.md") is not None
    assert len(DOCS) > 5


_FORMAT_WORDS = {
    "hdf5": "HDF5",
    "npz": "NPZ",
    "csv": "CSV",
    "parquet": "Parquet",
    "mat": "MATLAB v7.3",
    "rosbag": "ROS bags",
}


def test_the_docs_name_every_format_read_in_blocks_and_bags_in_fleets():
    """identifying-a-robot.md's list of formats read in blocks covers `BLOCK_FORMATS`, and the
    fleet page says how a ROS bag is read (whole and resampled, or streamed when too large)."""
    from physid.signals.io import BLOCK_FORMATS

    text = " ".join((ROOT / "docs" / "identifying-a-robot.md").read_text().split())
    listed = re.search(r"(HDF5[^()]*?),? are read in blocks", text)
    assert listed is not None
    assert sorted(f for f in BLOCK_FORMATS if _FORMAT_WORDS[f] not in listed.group(1)) == []
    fleets = " ".join((ROOT / "docs" / "fleets.md").read_text().split())
    for words in ("## ROS bags in a fleet", "read whole and resampled onto its mean period",
                  '{"resample": False}', "must be sampled uniformly"):  # fmt: skip
        assert words in fleets
