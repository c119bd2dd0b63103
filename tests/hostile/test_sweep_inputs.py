"""Hostile input to ``physid sweep``: its interrupts, resources and messages.

One row per case: ``(case_id, argv, expected_exit, message_regex)``, run by the shared framework
(tests/hostile/_cases.py; ``{tmp}`` is a fresh folder). The SIGTERM case needs a real process and
lives in tests/test_cli_sweep.py (test_sigterm_kills_the_pool_and_exits_143).
"""

from __future__ import annotations

import pytest

from ._cases import case_ids, check_case

QUIET = ["--no-progress", "--scheduler", "serial"]
SWEEP = ["sweep", "msd", *QUIET]
CASES = [
    (
        "sweep-coarse-dt-blames-dt",
        [*SWEEP, "--dt", "1", "--duration", "5", "--trials", "1", "--out", "{tmp}/o"],
        2,
        r"--dt = 1 s leaves only 5 sample\(s\) in --duration = 5 s.*smaller --dt",
    ),
    (
        "sweep-trials-beyond-memory",
        ["sweep", "msd", "--trials", "1e11", "--out", "{tmp}/o"],
        2,
        r"a sweep of 3,000,000,000,000 trials .* needs about .*B of memory .* available.*"
        r"fewer --trials",
    ),
    (
        "sweep-every-trial-failed",
        [*SWEEP, "--trials", "1", "--snr", "25", "--ratio", "1", "--method", "algebraic"]
        + ["--window", "6", "--out", "{tmp}/o"],
        2,
        r"every trial failed \(1 of 1\).*the first \(row 0: snr_db=25.0, ratio=1.0, "
        r"method=algebraic, window=6.0.*window = 6 s .* longer than the record.*trials\.csv",
    ),
    (
        "sweep-unreachable-scheduler-timeout",
        ["sweep", "msd", "--trials", "1", "--scheduler", "tcp://127.0.0.1:9"]
        + ["--scheduler-timeout", "1", "--out", "{tmp}/o"],
        2,
        r"could not reach the Dask scheduler at 'tcp://127\.0\.0\.1:9' within 1 s.*"
        r"raise --scheduler-timeout SECONDS",
    ),
    (
        "sweep-chain-model-refused",
        ["sweep", "manipulator", *QUIET, "--trials", "1", "--out", "{tmp}/o"],
        2,
        r"must be a linear ODE model",
    ),
    (
        "sweep-trials-not-a-count",
        ["sweep", "msd", "--trials", "2.5", "--out", "{tmp}/o"],
        2,
        r"--trials: expects a whole number >= 1; got '2\.5'",
    ),
]


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=case_ids(CASES)
)
def test_sweep_input(case_id, argv, expected_exit, message_regex, hostile):
    check_case(hostile, argv, expected_exit, message_regex)
