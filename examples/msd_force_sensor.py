"""Mass, damping and stiffness of a mass-spring-damper logged with a force sensor in newtons.

A data logger wrote a CSV with its own column names and units: the time in milliseconds, the
position in millimetres from an encoder, the force in newtons from a load cell, with a decimal
comma and ';' as the separator, as many European loggers do:

    Zeit [ms];Weg [mm];Kraft [N]
    0,0;0,0;0,0
    1,0;0,00021;1,73

physid reads it with a channel map (`x` is the output, `u` the input), converts every column to
SI, and estimates the force-input MSD  m ẍ + c ẋ + k x = F, written as
ẍ + (c/m) ẋ + (k/m) x = (1/m) F: the three coefficients θ2 = k/m, θ1 = c/m and b0 = 1/m are
estimated, and the result turns them into m, c and k (`fit.derived`) with standard errors
(delta method). Without the force sensor (u = F/m) only k/m and c/m would be identifiable, and
physid says so.

Run:  python examples/msd_force_sensor.py   (PHYSID_EXAMPLE_QUICK=1 for a shorter run)
The same from the command line:
    physid estimate log.csv --model msd-force --map u=Kraft,x=Weg --decimal , --method rls
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

import physid
from physid.estimators.recursive import RecursiveLeastSquares
from physid.signals import Multisine, add_white_noise
from physid.simulate import simulate_msd

QUICK = os.environ.get("PHYSID_EXAMPLE_QUICK") == "1"
MASS, DAMPING, STIFFNESS = 2.5, 3.0, 900.0  # the truth [kg], [N·s/m], [N/m]
DURATION = 4.0 if QUICK else 10.0  # [s]


def write_logger_csv(path: Path) -> None:
    """Simulate the rig and write the file the way the logger does (ms, mm, N; decimal comma)."""
    omega0 = np.sqrt(STIFFNESS / MASS)  # 19 rad/s
    # the simulator's input is u = F/m: a multisine force of 20, 15 and 10 N divided by the mass
    u = Multisine(omega0 * np.array([0.5, 1.0, 2.0]), np.array([20.0, 15.0, 10.0]) / MASS)
    rec = simulate_msd(
        mass=MASS, damping=DAMPING, stiffness=STIFFNESS, input=u, duration=DURATION, dt=1e-3
    )
    pos, _ = add_white_noise(rec["x"], snr_db=50.0, rng=3)
    f_meas, _ = add_white_noise(rec["u"] * MASS, snr_db=50.0, rng=4)  # u = F/m in the simulation
    lines = ["Zeit [ms];Weg [mm];Kraft [N]"]
    for t, x, f in zip(1e3 * rec.t, 1e3 * pos, f_meas, strict=True):
        lines.append(f"{t:.1f};{x:.6f};{f:.5f}".replace(".", ","))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def main() -> None:
    path = Path("logger.csv")
    write_logger_csv(path)
    rec = physid.load_recording(path, {"t": "Zeit", "x": "Weg", "u": "Kraft"}, decimal=",")
    print(f"read {rec.n_samples} samples: {rec!r} (dt = {rec.dt * 1e3:.3g} ms)")
    model = physid.load_model("msd-force")  # θ2 = k/m, θ1 = c/m, b0 = 1/m; m, c, k unknown
    model.check_units(rec)  # u is a force [N], as this model wants
    fit = RecursiveLeastSquares(model).fit(rec).result_
    names = ("theta2", "theta1", "b0")
    coefs = {n: fit.parameters[n] for n in names}
    # the result carries m, c, k (as mass, damping, stiffness) with delta-method standard errors
    # from the coefficients' full final covariance (fit.final_covariance)
    derived = {"m": "mass", "c": "damping", "k": "stiffness"}
    values = {n: fit.derived[d] for n, d in derived.items()}
    stderr = fit.derived_stderr or {}
    truth = {"m": MASS, "c": DAMPING, "k": STIFFNESS}
    units = {"m": "kg", "c": "N·s/m", "k": "N/m"}
    digits = {"m": 4, "c": 3, "k": 1}
    for name, key in derived.items():
        se = f" ± {stderr[key]:.2g}" if np.isfinite(stderr.get(key) or np.nan) else ""
        err = 100 * abs(values[name] / truth[name] - 1)
        print(
            f"{name} = {values[name]:.{digits[name]}f}{se} {units[name]} "
            f"(true {truth[name]:g}, error {err:.2f} %)"
        )
    worst = max(abs(values[n] / truth[n] - 1) for n in ("m", "k"))
    print(f"mass and stiffness within 1 % of the truth: {'yes' if worst < 0.01 else 'no'}")
    # without the force sensor (u = F/m, b = ["1"]) the coefficients give only k/m and c/m
    ratios = Path("ratios.toml")
    ratios.write_text(
        'name = "ratios"\nkind = "linear_ode"\n[parameters]\nm = 1.0\nc = 1.0\nk = 1.0\n'
        '[ode]\na = ["k/m", "c/m"]\nb = ["1"]\n',
        encoding="utf-8",
    )
    only = physid.load_model(ratios).physical_from_coefficients(
        {"a0": coefs["theta2"], "a1": coefs["theta1"]}
    )
    print(f"with u = F/m instead: {only.message}")


if __name__ == "__main__":
    main()
