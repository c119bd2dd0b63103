"""Timing helpers shared by the benchmark modules (benchmarks/run.py puts this folder on
sys.path)."""

from __future__ import annotations

import math
import time


def best_of(fn, repeat: int) -> tuple[float, object]:
    """Run ``fn()`` ``repeat`` times; return (the shortest wall time [s], the last result).

    The minimum is the cost on a shared machine: anything above it is other load.
    """
    best, out = math.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def best_time(fn, repeat: int) -> float:
    """The shortest wall time [s] of ``repeat`` runs of ``fn()``."""
    return best_of(fn, repeat)[0]
