"""Helpers shared by several test modules: the planar two-link arm's closed-loop run and an
in-process ``physid`` call that returns its exit status and output."""

from __future__ import annotations

from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parent / "data"
PLANAR2 = DATA / "planar2.urdf"


def planar2_pd_run(model, phase=0.0, duration=4.0):
    """A noise-free PD closed loop of the planar two-link arm at 1 kHz (gains 200/100, 20/10),
    following two sines per joint under a cubic ramp of 0.5 s; ``phase`` shifts the slow ones."""
    from physid.simulate.closed_loop import simulate_closed_loop

    t = np.arange(0.0, duration, 1e-3)
    ramp = np.clip(t / 0.5, 0.0, 1.0)[:, None] ** 3
    reference = ramp * np.column_stack(
        [
            0.5 * np.sin(2 * np.pi * 0.5 * t + phase) + 0.3 * np.sin(2 * np.pi * 1.3 * t),
            0.4 * np.sin(2 * np.pi * 0.7 * t + 1 + phase) + 0.2 * np.sin(2 * np.pi * 1.9 * t),
        ]
    )
    return simulate_closed_loop(model, kp=(200.0, 100.0), kd=(20.0, 10.0), reference=reference, t=t)


def cli_output(argv, capsys):
    """Run ``physid.cli.main`` on ``argv`` (items turned to text); return (code, stdout, stderr)."""
    from physid.cli import main

    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err
