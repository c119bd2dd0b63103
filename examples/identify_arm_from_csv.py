"""Identify the masses and lengths of a 4-joint arm from a CSV recording.

In real use the CSV comes from your robot: a column ``t`` [s], the joint angles ``q1..q4`` [rad]
and the joint torques ``tau1..tau4`` [N·m] (see docs/conventions.md). Here we make one first, by
simulating the arm of Cedro & Janecki under PD control while each joint steps by 0.5 rad, so the
script runs anywhere; then we do exactly what you would do with your own file:

1. ``physid.load_recording`` reads and checks the CSV (uniform sampling, no NaN, units);
2. ``InputErrorEstimator`` filters the angles (low-pass, d/dt, d²/dt², Harris-windowed FIR) and
   fits the equations of motion to the filtered torques by least squares;
3. the result says which parameters the data cannot separate (for this arm m1 and l1 enter
   only as m1·l1²), holds one of them fixed, and gives standard errors for the others.

Run:  python examples/identify_arm_from_csv.py   (PHYSID_EXAMPLE_QUICK=1 for a shorter record)
The same from the shell:  physid identify arm.csv --model manipulator
"""

from __future__ import annotations

import os
import re
import tempfile
import warnings
from pathlib import Path

import numpy as np

import physid
from physid.estimators.input_error import InputErrorEstimator
from physid.signals import save_recording
from physid.simulate import PAPER_MANIPULATOR, simulate_closed_loop, uniform_time
from physid.simulate.references import filtered_steps

QUICK = os.environ.get("PHYSID_EXAMPLE_QUICK") == "1"
DURATION = 3.0 if QUICK else 5.0  # [s] of recording
DT = 1e-3  # [s]
TRUTH = {
    "m1": 50.0,
    "m2": 25.0,
    "m3": 15.0,
    "m4": 5.0,
    "l1": 0.4,
    "l2": 0.8,
    "l3": 0.6,
    "l4": 0.2,
}  # [kg], [m]


def make_csv(path: Path) -> None:
    """Simulate the arm (exact kinetic energy) and write t, q1..q4, tau1..tau4 to ``path``."""
    model = physid.load_model("manipulator")
    # Smooth 0.5 rad steps of joints 1..4, one after the other, within the record.
    step_times = np.linspace(0.3, DURATION - 1.2, 4)
    reference = filtered_steps(
        uniform_time(duration=DURATION, dt=DT),
        step_times,
        0.5,
        half_width=100,
        cutoff=0.025,
        alignment="centred",
    )
    rec = simulate_closed_loop(
        model,
        kp=PAPER_MANIPULATOR["kp"],
        kd=PAPER_MANIPULATOR["kd"],
        reference=reference,
        duration=DURATION,
        dt=DT,
        params=TRUTH,
    )
    # Keep only what a robot would log: angles and torques.
    columns = [f"q{i}" for i in range(1, 5)] + [f"tau{i}" for i in range(1, 5)]
    logged = physid.Recording(
        rec.t, rec.select(columns), columns, units=[rec.unit(c) for c in columns]
    )
    save_recording(logged, path)


def main() -> None:
    folder = Path(tempfile.mkdtemp(prefix="physid-arm-"))
    csv_path = folder / "arm.csv"
    make_csv(csv_path)
    print(f"wrote {csv_path} ({csv_path.stat().st_size / 1e6:.1f} MB)")

    # --- from here on, this is what you do with your own recording ---------------------------
    rec = physid.load_recording(csv_path)
    print(f"loaded {rec.n_samples} samples at dt = {rec.dt * 1e3:g} ms, channels {rec.names}")
    model = physid.load_model("manipulator")
    initial = {name: 1.1 * value for name, value in TRUTH.items()}  # a rough prior guess (+10 %)

    # The filters must pass the whole spectrum of the motion (docs/choosing-an-estimator.md).
    # These data are noise-free, so a high cut-off costs nothing: M = 60, Ω_g = 0.8 rad/sample.
    # The paper's M = 100, Ω_g = 0.2 is shown second: physid warns that it is too low here.
    for half_width, cutoff in ((60, 0.8), (100, 0.2)):
        estimator = InputErrorEstimator(
            model, half_width=half_width, cutoff=cutoff, torque="measured"
        )
        with warnings.catch_warnings(record=True) as caught:  # identifiability / filter notes
            warnings.simplefilter("always")
            result = estimator.fit(rec, initial=initial).result_
        print(f"\n== filter M = {half_width}, Ω_g = {cutoff} rad/sample ==")
        for w in caught:
            print(f"note: {w.message}")
        print(result.summary())
        errors = compare_with_truth(result)
        worst = max(errors, key=errors.get)
        print(
            f"largest error: {worst} {errors[worst]:.3f} %; J = {result.cost:.4g} N²·m², "
            f"{result.nfev} evaluations"
        )
        ok = all(e < 1.0 for e in errors.values())
        print(f"all identifiable parameters within 1 % of the truth: {'yes' if ok else 'no'}")


def compare_with_truth(result) -> dict[str, float]:
    """Relative errors [%] of what the data determine (possible here: we simulated the data)."""
    errors = {}
    for expr, value in result.combinations.items():  # e.g. m1*l1**2
        true_value = eval(expr, {}, dict(TRUTH))
        errors[expr] = 100.0 * abs(value / true_value - 1.0)
        print(
            f"identified {expr} = {value:.6g} (true {true_value:.6g}), error {errors[expr]:.3f} %"
        )
    in_combination = {
        name for expr in result.combinations for name in TRUTH if re.search(rf"\b{name}\b", expr)
    }
    for name in result.free:
        if name not in in_combination:  # m1 alone is meaningless once l1 is held
            errors[name] = 100.0 * abs(result.parameters[name] / TRUTH[name] - 1.0)
    print(
        f"identified m2 = {result.parameters['m2']:.4f} kg (true 25 kg), error {errors['m2']:.3f} %"
    )
    return errors


if __name__ == "__main__":
    main()
