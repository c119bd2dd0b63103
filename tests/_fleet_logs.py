"""Small fleets of simulated logs for the fleet tests: the planar two-link arm (tests/data/
planar2.urdf) driven by a smooth 5-harmonic Fourier motion, torques from its inverse dynamics
plus 2 % noise, σ_q = 1e-4 rad, 1 kHz, written to .npz."""

from __future__ import annotations

import numpy as np

from _helpers import PLANAR2

MODEL = str(PLANAR2)


def fourier_motion(t, n_joints, seed, f0=0.2, harmonics=5):
    """q, qd, qdd [rad, rad/s, rad/s²] of a random Fourier series (amplitude 0.5/k rad)."""
    rng = np.random.default_rng(seed)
    q = np.zeros((t.size, n_joints))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    for j in range(n_joints):
        for k in range(1, harmonics + 1):
            a, b = rng.normal(0.0, 0.5 / k, 2)
            w = 2 * np.pi * f0 * k
            s, c = np.sin(w * t), np.cos(w * t)
            q[:, j] += a * s + b * c
            qd[:, j] += w * (a * c - b * s)
            qdd[:, j] -= w * w * (a * s + b * c)
    return q, qd, qdd


def write_log(path, model, seed, *, duration=4.0, dt=1e-3, params=None, noise_seed=None):
    """One log of ``model`` (optionally with changed standard parameters) at ``path``: the
    motion from ``seed``, the noise from ``noise_seed`` (default: ``seed``)."""
    from physid.signals import Recording, save_recording

    t = np.arange(0.0, duration, dt)
    n = model.n_joints
    q, qd, qdd = fourier_motion(t, n, seed)
    tau = model.inverse_dynamics(q, qd, qdd, params)
    rng = np.random.default_rng(1000 + (seed if noise_seed is None else noise_seed))
    tau = tau + 0.02 * tau.std(axis=0) * rng.standard_normal(tau.shape)
    q = q + 1e-4 * rng.standard_normal(q.shape)
    names = [f"q{j + 1}" for j in range(n)] + [f"tau{j + 1}" for j in range(n)]
    save_recording(Recording(t, np.column_stack([q, tau]), names), path)
    return str(path)
