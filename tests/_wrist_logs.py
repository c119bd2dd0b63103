"""The simulated 6-DOF arm with a coupled wrist (motor 6 turns with q5 + q6), shared by
tests/test_transmission.py and benchmarks/bench_transmission.py.

Rigid bodies from pinocchio (physid's ``arm6.urdf``), motor terms written from their definition:
θm = K q, τ = Kᵀ τm, each rotor's inertia Im, viscous Fvm and Coulomb Fcm acting on its own angle.
Logs are motor-side (``qm1..qm6`` [rad], ``taum1..taum6`` [N·m]) at 200 Hz, 20 s, a 4-harmonic
Fourier motion of period 10 s per joint (highest harmonic 0.4 Hz).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import physid

URDF = Path(physid.__file__).parent / "models" / "data" / "arm6.urdf"
JOINTS = [
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
]
N = np.array([100.0, 100.0, 80.0, 60.0, 60.0, 50.0])
K = np.diag(N)
K[5, 4] = N[5]  # motor 6 turns with q5 + q6
IM = np.array([4e-5, 4e-5, 3e-5, 2e-5, 2e-5, 1e-4])  # rotor inertias [kg·m²]
FVM = np.array([1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-3])  # motor-side viscous [N·m·s/rad]
FCM = np.array([5e-3, 5e-3, 5e-3, 3e-3, 3e-3, 2e-2])  # motor-side Coulomb [N·m]
HIGHEST_HARMONIC_HZ = 0.4  # of `trajectory`


def toml_matrix(M):
    return "[" + ", ".join("[" + ", ".join(repr(float(v)) for v in r) + "]" for r in M) + "]"


def motor_tables(values=None):
    """``[transmission.motors.motor_k]`` tables: parameter names, or the numbers of ``values``
    (Im, Fvm, Fcm arrays)."""
    out = ""
    for k in range(6):
        if values is None:
            out += (
                f'[transmission.motors.motor_{k + 1}]\ninertia = "Im{k + 1}"\n'
                f'viscous = "Fvm{k + 1}"\ncoulomb = "Fcm{k + 1}"\n'
            )
        else:
            im, fv, fc = (float(v[k]) for v in values)
            out += (
                f"[transmission.motors.motor_{k + 1}]\ninertia = {im!r}\nviscous = {fv!r}\n"
                f"coulomb = {fc!r}\n"
            )
    return out


def sidecar(folder, name, body):
    """A sidecar ``folder/name`` extending a copy of arm6.urdf with ``body``."""
    folder = Path(folder)
    (folder / "arm6.urdf").write_text(URDF.read_text())
    path = folder / name
    path.write_text(f'extends = "arm6.urdf"\n{body}')
    return path


def coupled(folder, values=None, extra=""):
    """The coupled-wrist sidecar ``folder/coupled.toml`` (motor terms identified by default)."""
    body = f"[transmission]\nmotor_from_joint = {toml_matrix(K)}\n{extra}" + motor_tables(values)
    return sidecar(folder, "coupled.toml", body)


def trajectory(seed, T=20.0, fs=200.0):
    """A finite Fourier series per joint (period 10 s), with exact derivatives."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, T, 1.0 / fs)
    w = 2 * np.pi / 10.0
    q, qd, qdd = (np.zeros((t.size, 6)) for _ in range(3))
    for j in range(6):
        for h in range(1, 5):
            a, b = rng.normal(scale=0.4 / h, size=2)
            s, c = np.sin(h * w * t), np.cos(h * w * t)
            q[:, j] += a * s + b * c
            qd[:, j] += h * w * (a * c - b * s)
            qdd[:, j] += -((h * w) ** 2) * (a * s + b * c)
    return t, q, qd, qdd


def truth_torque(q, qd, qdd):
    """pinocchio's rigid bodies + the rotors written from their definition (not physid's)."""
    import pinocchio as pin

    pm = pin.buildModelFromUrdf(str(URDF))
    data = pm.createData()
    tau = np.array([pin.rnea(pm, data, q[s], qd[s], qdd[s]) for s in range(q.shape[0])])
    thd, thdd = qd @ K.T, qdd @ K.T  # θ̇m = K q̇, θ̈m = K q̈
    tau_m = IM * thdd + FVM * thd + FCM * np.sign(thd)  # on the motor side
    return tau + tau_m @ K  # τ = Kᵀ τm


def write_log(path, seed, noise, T=20.0, noise_seed=None):
    """A motor-side log (qm, taum) of the coupled robot, without a q or tau column; ``noise``
    [N·m] is the standard deviation of white noise on the motor torques (drawn with
    ``noise_seed``, by default ``seed + 100``)."""
    t, q, qd, qdd = trajectory(seed, T=T)
    tau = truth_torque(q, qd, qdd)
    rng = np.random.default_rng(seed + 100 if noise_seed is None else noise_seed)
    tau_m = np.linalg.solve(K.T, tau.T).T + noise * rng.normal(size=tau.shape)
    th = q @ K.T
    names = ["t"] + [f"qm{k + 1}" for k in range(6)] + [f"taum{k + 1}" for k in range(6)]
    np.savetxt(
        path, np.column_stack([t, th, tau_m]), delimiter=",", header=",".join(names), comments=""
    )
