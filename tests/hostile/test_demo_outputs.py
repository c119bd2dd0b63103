"""Hostile output paths of ``physid demo``: an output that cannot be a folder.

Each is refused before the demo runs (exit 2, one ``physid: error:`` line naming --out and the
fix), and the file in the way is left unchanged (the framework hashes the placeholder inputs).
"""

from __future__ import annotations

import pytest

from ._cases import case_ids, check_case

CASES = [
    # (case_id, argv, expected_exit, message_regex)
    (
        "demo-out-is-a-file",
        ["demo", "--quick", "--out", "{msd_csv}"],
        2,
        r"--out .*is an existing file, not a folder.*Give a new or existing folder",
    ),
    (
        "demo-out-under-a-file",
        ["demo", "--quick", "--out", "{msd_csv}/report"],
        2,
        r"--out .*is a file, so the folder cannot be created there",
    ),
]


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=case_ids(CASES)
)
def test_demo_output(case_id, argv, expected_exit, message_regex, hostile):
    check_case(hostile, argv, expected_exit, message_regex)


def _staged(tmp_path):
    staging = tmp_path / ".out.partial"
    staging.mkdir()
    for name, text in (("report.html", "<p>new</p>"), ("results.json", "{}"), ("b.png", "B")):
        (staging / name).write_text(text)
    return staging


def test_a_rerun_removes_only_the_old_runs_figures(tmp_path):
    """A results.json in the folder that lists other files (crafted, or of another program)
    removes none of them: only regular ``<name>.png`` files, never a link or its target."""
    import json

    from physid.report.demo import _move_in

    out = tmp_path / "out"
    out.mkdir()
    outside = tmp_path / "keep.png"
    outside.write_text("outside")
    (out / "thesis.tex").write_text("mine")
    (out / "a.png").write_text("old figure")
    (out / "notes.png.bak").write_text("mine too")
    (out / "link.png").symlink_to(outside)
    listed = ["thesis.tex", "a.png", "notes.png.bak", "link.png", "../keep.png", 3]
    (out / "results.json").write_text(json.dumps({"metadata": {"figures": listed}}))
    _move_in(_staged(tmp_path), out)
    assert sorted(p.name for p in out.iterdir()) == [
        "b.png", "link.png", "notes.png.bak", "report.html", "results.json", "thesis.tex"
    ]  # fmt: skip
    assert (out / "thesis.tex").read_text() == "mine"
    assert (out / "link.png").is_symlink() and outside.read_text() == "outside"
    assert (out / "report.html").read_text() == "<p>new</p>"


@pytest.mark.parametrize("kind", ["fifo", "symlink"])
def test_a_rerun_never_replaces_a_link_or_fifo_among_its_outputs(tmp_path, kind):
    """The same refusal as every other output; nothing of the old run is moved or removed."""
    import os

    from physid.errors import OutputError
    from physid.report.demo import _move_in

    out = tmp_path / "out"
    out.mkdir()
    (out / "a.png").write_text("old figure")
    (out / "results.json").write_text('{"metadata": {"figures": ["a.png"]}}')
    target = tmp_path / "elsewhere.html"
    target.write_text("not the demo's")
    if kind == "fifo":
        os.mkfifo(out / "report.html")
    else:
        (out / "report.html").symlink_to(target)
    staging = _staged(tmp_path)
    expected = r"FIFO \(named pipe\), not a regular file" if kind == "fifo" else "symbolic link"
    with pytest.raises(OutputError, match=rf"report\.html'?: it is a {expected}"):
        _move_in(staging, out)
    assert (out / "a.png").read_text() == "old figure"
    assert "figures" in (out / "results.json").read_text()
    assert target.read_text() == "not the demo's"
