"""Messages that name the right cause: the scheduler's accepted forms, … (hostile input).

Each case: ``(case_id, argv, expected_exit, message_regex)`` as in ``tests/hostile/_cases.py``.
"""

from __future__ import annotations

import pytest

from ._cases import case_ids, check_case

CASES = [
    (
        "scheduler-file-url",
        [
            "sweep",
            "msd",
            "--snr",
            "25",
            "--ratio",
            "1",
            "--trials",
            "1",
            "--scheduler",
            "file:///etc/passwd",
            "--out",
            "{tmp}/sw",
        ],
        2,
        r"--scheduler 'file:///etc/passwd'.*tcp://.*'local:N'",
    ),
    (
        "scheduler-http-url",
        [
            "sweep",
            "msd",
            "--snr",
            "25",
            "--ratio",
            "1",
            "--trials",
            "1",
            "--scheduler",
            "http://example.invalid:80",
            "--out",
            "{tmp}/sw",
        ],
        2,
        r"--scheduler .*Dask schemes",
    ),
]


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=case_ids(CASES)
)
def test_messages(case_id, argv, expected_exit, message_regex, hostile):
    check_case(hostile, argv, expected_exit, message_regex)
