"""Hostile input to ``physid identify`` and `InputErrorEstimator` (issue 16, room inputerr).

Table rows: ``(case_id, argv, expected_exit, message_regex)``; ``{rec}`` in argv is a small
recording of the paper's arm written once per module. Until the shared runner of
``tests/hostile/_cases.py`` is on main this file runs ``physid.cli.main`` itself.
"""

from __future__ import annotations

import re

import pytest

import physid
from physid.cli import main
from physid.errors import InputError
from physid.estimators.input_error import InputErrorEstimator
from physid.signals import save_recording
from physid.simulate.closed_loop import paper_manipulator_experiment

#: The library names Python arguments (``initial``); the CLI shows them as its flags.
INITIAL, FIX = "--initial", "--fix"

CASES = [
    (
        "initial-and-fix-conflict",
        ["identify", "{rec}", "--model", "manipulator", "--initial", "l1=0.5", "--fix", "l1=0.4"],
        2,
        rf"physid: error: {INITIAL} and {FIX} give different values .*l1: initial 0.5, fixed 0.4",
    ),
    (
        "fix-unknown-name",
        ["identify", "{rec}", "--model", "manipulator", "--fix", "mass1=0.4"],
        2,
        r"physid: error: .*unknown parameter\(s\) \['mass1'\]",
    ),
    (
        "cutoff-not-a-number",
        ["identify", "{rec}", "--model", "manipulator", "--cutoff", "fast"],
        2,
        r"physid: error: .*cutoff.*'auto' or a number",
    ),
]


@pytest.fixture(scope="module")
def rec_path(tmp_path_factory):
    rec = paper_manipulator_experiment(kinetic="paper").slice_time(0.0, 1.5)
    path = tmp_path_factory.mktemp("inputerr") / "arm.csv"
    save_recording(rec, path)
    return path


@pytest.mark.parametrize(("case_id", "argv", "expected_exit", "message_regex"), CASES)
def test_hostile_identify(rec_path, capsys, case_id, argv, expected_exit, message_regex):
    try:
        code = main([a.replace("{rec}", str(rec_path)) for a in argv])
    except SystemExit as exc:  # argparse's own errors exit from inside main
        code = exc.code
    err = capsys.readouterr().err
    assert code == expected_exit, (case_id, err)
    assert re.search(message_regex, err), (case_id, err)


def test_fixed_list_is_not_a_traceback():
    """``InputErrorEstimator(arm, fixed=['l1'])`` holds l1; a bare string is a clear error."""
    arm = physid.load_model("manipulator")
    rec = paper_manipulator_experiment(kinetic="exact", model=arm).slice_time(0.0, 1.5)
    result = InputErrorEstimator(arm, fixed=["l1"], max_nfev=2).fit(rec).result_
    assert result.fixed == {"l1": 0.4} and result.parameters["l1"] == 0.4
    with pytest.raises(InputError, match=r"fixed must be a mapping.*got 'l1' of type str"):
        InputErrorEstimator(arm, fixed="l1").fit(rec)
