"""A linear-axis drive in closed loop, identified from its log and checked on a held-out log.

The worked example of docs/your-data.md, section 7, end to end with the documented commands: a
carriage on a prismatic joint (mass 12 kg, viscous friction 8 N·s/m, Coulomb friction 4 N, a
force offset of 1.5 N) under a 5 Hz PD position loop; the drive makes the force F = gtau · vir
from the controller's voltage (gtau = 35.15 N/V); only the encoder position is logged (1 µm).
The script writes the model file `axis.toml`, simulates two drive logs as `.mat` files (`t`,
`qm`, `vir` and the scalar `gtau`; the second with another reference), then runs

    physid identify axis_log.mat --model axis.toml --cutoff 0.5 --half-width 60 --save axis_fit.json
    physid validate axis_fit.json axis_heldout.mat

prints their output and checks the numbers against the ranges the page states
(tests/test_examples.py runs it in CI). The logs are those of the page, so PHYSID_EXAMPLE_QUICK
changes nothing here (the whole run takes a few seconds).

Run:  python examples/linear_axis_drive.py   (in an empty folder: it writes five files)
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import scipy.io

import physid
from physid.simulate import simulate_closed_loop

TRUTH = {"m1": 12.0, "Fv1": 8.0, "Fc1": 4.0, "OF1": 1.5}  # [kg], [N·s/m], [N], [N]
GAIN = 35.15  # gtau [N/V]
#: The ranges docs/your-data.md states for the two commands (relative to the truth / absolute).
RANGES = {"m1": 1e-3, "Fv1": 1e-2, "Fc1": 1e-2, "OF1": 1e-2}
MAX_HELDOUT_ERROR = 0.005  # relative torque (force) error of the inverse model on held-out data

AXIS_TOML = """\
name = "axis"
gravity = [0.0, 0.0, -9.81]          # horizontal axis: gravity does no work along x

[parameters]
m1 = { value = 12.0, unit = "kg" }
Fv1 = { value = 8.0, unit = "N*s/m" }
Fc1 = { value = 4.0, unit = "N" }
OF1 = { value = 1.5, unit = "N" }

[[joints]]
name = "carriage"
type = "prismatic"
transform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
axis = [1, 0, 0]
mass = "m1"
viscous = "Fv1"
coulomb = "Fc1"
torque_offset = "OF1"

[recording]                           # how the drive's log names things (--map overrides)
q1 = "qm"
tau1 = "gtau*vir"
"""


def write_log(path: Path, axis, duration: float, sines) -> None:
    """Simulate the closed loop on the reference Σ a sin(2π f t + φ) and write the drive's log."""
    t = np.arange(int(round(duration * 1e3)) + 1) * 1e-3
    ramp = 0.5 * (1 - np.cos(np.pi * np.clip(t, 0, 1)))
    r = ramp * sum(a * np.sin(2 * np.pi * f * t + phi) for a, f, phi in sines)
    w = 2 * np.pi * 5  # a 5 Hz position loop
    rec = simulate_closed_loop(
        axis,
        kp=[w**2 * 12],
        kd=[2 * w * 12],
        reference=r[:, None],
        t=t,
        coulomb_smoothing=1e-4,  # m/s here: a sharp Coulomb friction
    )
    qm = np.round(rec["q1"] / 1e-6) * 1e-6  # the encoder
    scipy.io.savemat(
        path,
        {"t": t[:, None], "qm": qm[:, None], "vir": (rec["tau1"] / GAIN)[:, None], "gtau": GAIN},
    )


def physid_cli(*args: str) -> str:
    """Run ``physid ARGS`` as a user would; return its stdout (its stderr is shown too)."""
    proc = subprocess.run(
        [sys.executable, "-m", "physid", *args], capture_output=True, text=True, check=False
    )
    print(f"$ physid {' '.join(args)}")
    print(proc.stdout, end="")
    if proc.returncode != 0:
        print(proc.stderr, file=sys.stderr)
        raise SystemExit(f"physid {args[0]} exited with {proc.returncode}")
    return proc.stdout


def main() -> None:
    Path("axis.toml").write_text(AXIS_TOML, encoding="utf-8")
    axis = physid.load_model("axis.toml")
    write_log(Path("axis_log.mat"), axis, 10.0, [(0.10, 0.4, 0), (0.03, 1.3, 1), (0.01, 3.1, 2)])
    write_log(
        Path("axis_heldout.mat"), axis, 10.0, [(0.08, 0.6, 0.5), (0.04, 1.7, 0), (0.01, 2.9, 1)]
    )
    out = physid_cli(
        "identify", "axis_log.mat", "--model", "axis.toml", "--cutoff", "0.5",
        "--half-width", "60", "--save", "axis_fit.json",
    )  # fmt: skip
    values = {k: float(re.search(rf"^\s+{k}\s+=\s+(\S+)", out, re.M).group(1)) for k in TRUTH}
    val = physid_cli("validate", "axis_fit.json", "axis_heldout.mat")
    heldout = float(re.search(r"relative error: overall (\S+),", val).group(1))

    print(
        "identified "
        + ", ".join(f"{k} = {values[k]:.4f}" for k in TRUTH)
        + " (true "
        + ", ".join(f"{v:g}" for v in TRUTH.values())
        + ")"
    )
    errors = {k: abs(values[k] / TRUTH[k] - 1) for k in TRUTH}
    print("relative errors: " + ", ".join(f"{k} {100 * e:.3f} %" for k, e in errors.items()))
    print(f"held-out relative force error {heldout:.4g} (stated: below {MAX_HELDOUT_ERROR:g})")
    ok = all(errors[k] <= RANGES[k] for k in TRUTH) and heldout < MAX_HELDOUT_ERROR
    print(f"within the ranges docs/your-data.md states: {'yes' if ok else 'no'}")
    if not ok:
        raise SystemExit(1)


if __name__ == "__main__":
    main()
