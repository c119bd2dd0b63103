"""physid's defaults against the robotics recipe on data physid did not make (the zoo).

Cases (benchmarks/zoo/cases.py, README.md there): a 6-DOF arm simulated by pinocchio (no
friction; viscous + Coulomb friction with point-to-point moves and rests; a slow 0.05 Hz sweep at
250 Hz with encoder quantisation), the same arm in MuJoCo (joint frictionloss, damping,
armature; skipped when mujoco is not installed), two real logs (Franka Panda, KUKA LWR4+)
read from ../shared/data/real-robots when that folder exists, a linear drive that sticks and a
geared 2-link arm logged as motor currents.

Rows: per case and physid method, the held-out torque error ‖τ̂ − τ‖/‖τ‖ against the recipe
(benchmarks/zoo/recipe.py: Butterworth filtfilt at 5× the trajectory bandwidth, central
differences, decimation, OLS on pinocchio's base regressor with friction columns); the goal is
judged on physid's default (`physid identify`'s IDIM-OLS): at most the recipe's error, and a
success verdict that agrees (no success above 2× the recipe, no failure at or below it). A
self-check row: the recipe on the noise-free record recovers the truth.

Quick mode: the short case (a) only, IDIM-OLS, WLS and OLS without the stiction rule; no goal
judged but the self-check, whose failure raises (a broken recipe must not pass silently).
Full table (markdown, with per-joint errors and messages): python -m benchmarks.zoo
"""

from __future__ import annotations

import sys

from zoo import compare


def run(quick: bool) -> list[dict]:
    outcomes, facts = compare.run(quick=quick, log=lambda s: print(s, file=sys.stderr, flush=True))
    rows = []
    for out, f in zip(outcomes, facts, strict=True):
        rows += compare.bench_rows(out, f)
    for r in rows:
        if "self-check" in r["case"]:
            if not r["met"]:  # the measuring stick itself is broken: fail loudly
                raise RuntimeError(f"zoo self-check failed: {r['case']}: {r['value']:.3g}")
        elif quick and r.get("goal"):
            r["met"] = None
    return rows


if __name__ == "__main__":
    import json

    print(json.dumps(run("--quick" in sys.argv), indent=1, default=str))
