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
