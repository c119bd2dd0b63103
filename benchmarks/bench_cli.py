"""Start-up time of the ``physid`` command: ``--version`` and ``--help``.

Both import nothing heavy (no numpy, scipy, sympy or matplotlib: tests/test_cli_basics.py checks
that structurally), so they cost little more than starting Python. Rows: the median wall time of
``python -m physid --version`` and ``--help`` over several runs (goal < 0.3 s), each beside the
bare interpreter (``python -c pass``) and ``python -c "import numpy"`` measured in the same run;
``ratio`` is the numpy import's time over physid's (> 1: physid starts faster than numpy alone).
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time

GOAL_S = 0.3


def _median_wall(argv: list[str], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        subprocess.run(argv, check=True, capture_output=True)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def run(quick: bool) -> list[dict]:
    repeats = 3 if quick else 11
    py = [sys.executable]
    bare = _median_wall([*py, "-c", "pass"], repeats)
    numpy = _median_wall([*py, "-c", "import numpy"], repeats)
    rows = []
    for flag in ("--version", "--help"):
        value = _median_wall([*py, "-m", "physid", flag], repeats)
        rows.append(
            {
                "benchmark": "cli start-up",
                "case": f"physid {flag} (bare python: {bare:.3f} s)",
                "value": value,
                "unit": "s",
                "baseline": "python -c 'import numpy'",
                "baseline_value": numpy,
                "ratio": numpy / value,
                "goal": f"< {GOAL_S} s",
                "met": value < GOAL_S,
            }
        )
    return rows
