"""Hostile input, room `arch` (issue 16): the sweep's interrupts, resources and messages.

One row per case: ``(case_id, argv, expected_exit, message_regex)``; ``{tmp}`` is a fresh
folder. Uses the shared framework (tests/hostile/_cases.py) when it is present, else the same
checks with a local runner. The SIGTERM case needs a real process and lives in
tests/test_cli_sweep.py (test_sigterm_kills_the_pool_and_exits_143).
"""

from __future__ import annotations

import contextlib
import io
import re
import warnings

import pytest

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


def _run(argv):
    from physid.cli import main

    out, err = io.StringIO(), io.StringIO()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in argv])
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else 2
    return int(code or 0), err.getvalue(), [str(w.message) for w in caught]


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=[c[0] for c in CASES]
)
def test_arch(case_id, argv, expected_exit, message_regex, tmp_path):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    code, err, caught = _run(argv)
    assert code == expected_exit, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert lines and lines[-1].startswith("physid: error:"), err
    assert sum(ln.startswith("physid: error:") for ln in lines) == 1, err
    assert re.search(message_regex, err, re.S), err
    assert not caught, caught
