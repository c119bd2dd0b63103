"""Hostile input to ``physid identify`` on the built-in arm and to `InputErrorEstimator`.

One row per case: ``(case_id, argv, expected_exit, message_regex)``, run by the shared framework
(tests/hostile/_cases.py; ``{arm_csv}`` is a short closed-loop run of the built-in arm).
"""

from __future__ import annotations

import pytest

import physid
from physid.errors import InputError
from physid.estimators.input_error import InputErrorEstimator
from physid.simulate.closed_loop import paper_manipulator_experiment

from ._cases import case_ids, check_case

IDENTIFY = ["identify", "{arm_csv}", "--model", "manipulator"]
CASES = [
    (
        "initial-and-fix-conflict",
        [*IDENTIFY, "--initial", "l1=0.5", "--fix", "l1=0.4"],
        2,
        r"--initial and --fix give different values .*l1: initial 0.5, fixed 0.4.*only one",
    ),
    (
        "fix-unknown-name",
        [*IDENTIFY, "--fix", "mass1=0.4"],
        2,
        r"--fix names unknown parameter\(s\) \['mass1'\]",
    ),
    (
        "cutoff-not-a-number",
        [*IDENTIFY, "--cutoff", "fast"],
        2,
        r"--cutoff: must be 'auto' or a number",
    ),
    (
        "noise-unknown-method",
        [*IDENTIFY, "--noise", "subtract"],
        2,
        r"--noise: invalid choice: 'subtract'",
    ),
]


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=case_ids(CASES)
)
def test_input_error_input(case_id, argv, expected_exit, message_regex, hostile):
    check_case(hostile, argv, expected_exit, message_regex)


def test_fixed_list_is_not_a_traceback():
    """``InputErrorEstimator(arm, fixed=['l1'])`` holds l1; a bare string is a clear error."""
    arm = physid.load_model("manipulator")
    rec = paper_manipulator_experiment(kinetic="exact", model=arm).slice_time(0.0, 1.5)
    result = InputErrorEstimator(arm, fixed=["l1"], max_nfev=2).fit(rec).result_
    assert result.fixed == {"l1": 0.4} and result.parameters["l1"] == 0.4
    with pytest.raises(InputError, match=r"fixed must be a mapping.*got 'l1' of type str"):
        InputErrorEstimator(arm, fixed="l1").fit(rec)
