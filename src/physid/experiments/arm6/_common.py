"""What Part III needs, found at run time, and the simulated experiments it shares.

Part III uses pieces that other stages provide: the built-in 6-DOF URDF arm
(`physid.load_model("arm6")`), the IDIM estimators (`physid.estimators.idim`), the excitation
design (`physid.analysis.excitation.design_excitation`) and the validation
(`physid.analysis.validation`). `available()` says which are there; a section whose piece is
missing says so instead of showing a number.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: The part's titles (keys in results.json).
TITLES = {
    "overview": "6-DOF arm: what physid does with a URDF, end to end",
    "excitation": "6-DOF arm: optimal excitation",
    "identification": "6-DOF arm: IDIM-OLS, IDIM-IV and input-error over seeds",
    "consistency": "6-DOF arm: a physically consistent estimate",
    "validation": "6-DOF arm: validation on a held-out trajectory",
}
KEYS = {name: f"arm6.{name}" for name in TITLES}
#: The model of the part.
MODEL = "arm6"
#: Sampling period of every record [s].
DT = 1e-3
#: Encoder noise [rad] and torque noise (fraction of each joint's rms torque).
ENCODER_STD = 1e-3
TORQUE_NOISE = 0.02


def say(progress: Callable[[str], None] | None, text: str) -> None:
    if progress is not None:
        progress(f"arm6: {text}")


@dataclass
class Setup:
    """The model and the pieces found (or why not)."""

    model: Any = None
    model_error: str = ""
    idim: Any = None
    excitation: Any = None
    validation: Any = None
    missing: list[str] = field(default_factory=list)
    #: Why each missing piece is missing (the exception or the absent name), for the report.
    reasons: list[str] = field(default_factory=list)


def _optional(module: str, attr: str | None = None):
    try:
        mod = importlib.import_module(module)
    except ImportError:
        return None
    return mod if attr is None else getattr(mod, attr, None)


def available() -> Setup:
    """Load the arm and look up the estimators, the excitation design and the validation."""
    s = Setup()
    try:
        from ...models import load_model

        s.model = load_model(MODEL)
        if not hasattr(s.model, "regressor") or not hasattr(s.model, "limits"):
            s.model_error = f"physid.load_model({MODEL!r}) has no regressor or limits yet"
            s.model = None
    except Exception as exc:  # report what failed, do not hide it
        s.model_error = f"physid.load_model({MODEL!r}) failed: {type(exc).__name__}: {exc}"
    if s.model is None:
        s.missing.append(f"the built-in {MODEL} model")
        s.reasons.append(s.model_error)
    s.idim = _optional("physid.estimators.idim", "IDIMEstimator")
    if s.idim is None:
        s.missing.append("the IDIM estimators")
        s.reasons.append("physid.estimators.idim is not in this build")
    s.excitation = _optional("physid.analysis.excitation", "design_excitation")
    if s.excitation is None:
        s.missing.append("the excitation design")
        s.reasons.append("physid.analysis.excitation.design_excitation is not in this build")
    s.validation = _optional("physid.analysis.validation")
    if s.validation is None:
        s.missing.append("the validation of physid validate")
        s.reasons.append("physid.analysis.validation is not in this build")
    return s


def gains(model) -> tuple[np.ndarray, np.ndarray]:
    """PD gains that keep the arm near its reference: Kp ∝ the joint's effort limit.

    Kp = 20·effort [N·m/rad] (about 0.05 rad of error at full effort), Kd = 2·√Kp·0.5.
    """
    effort = np.asarray(model.limits["effort"], dtype=float)
    effort = np.where(np.isfinite(effort) & (effort > 0), effort, 50.0)
    kp = 20.0 * effort
    kd = np.sqrt(kp)
    return kp, kd


def truth_base(model, idim_module) -> dict[str, float]:
    """The true base parameters of the model (its nominal standard parameters mapped)."""
    info = idim_module.base_regressor_info(model)
    beta = np.asarray(info.from_standard(model.beta()), dtype=float)
    return dict(zip(info.names, beta.tolist(), strict=True))


def simulate(model, reference, t, *, seed=None, noisy=True, kp=None, kd=None):
    """Closed loop under PD control; encoder noise on q and torque noise on τ when ``noisy``."""
    from ...signals.noise import add_white_noise
    from ...simulate.closed_loop import simulate_closed_loop

    if kp is None or kd is None:
        kp, kd = gains(model)
    rec = simulate_closed_loop(
        model,
        kp=kp,
        kd=kd,
        reference=reference,
        t=t,
        noise_std=ENCODER_STD if noisy else None,
        rng=seed,
    )
    if not noisy:
        return rec
    tau_names = rec.channels("tau")
    tau = rec.select(tau_names)
    std = TORQUE_NOISE * np.sqrt(np.mean(tau**2, axis=0))
    noisy_tau, _ = add_white_noise(tau, std=std, rng=None if seed is None else seed + 7919)
    return rec.with_channels(dict(zip(tau_names, noisy_tau.T, strict=True)))


def fourier_reference(model, period: float, harmonics: int, seed: int, t):
    """A random finite Fourier series trajectory (Swevers) scaled into the joint limits.

    Returns q, qd, qdd at ``t`` [rad, rad/s, rad/s²], each (n, n_joints). Used as the random
    baseline of the excitation design and as the held-out trajectory.
    """
    rng = np.random.default_rng(seed)
    n = model.n_joints
    w = 2 * np.pi / period * np.arange(1, harmonics + 1)
    a = rng.standard_normal((harmonics, n)) / np.arange(1, harmonics + 1)[:, None]
    b = rng.standard_normal((harmonics, n)) / np.arange(1, harmonics + 1)[:, None]
    wt = np.outer(t, w)
    s, c = np.sin(wt), np.cos(wt)
    q = s @ (a / w[:, None]) - c @ (b / w[:, None])
    qd = c @ a + s @ b
    qdd = -(s * w) @ a + (c * w) @ b
    limits = model.limits
    pos = np.asarray(limits["position"], dtype=float)
    vel = np.asarray(limits["velocity"], dtype=float)
    centre = np.where(np.isfinite(pos).all(axis=1), pos.mean(axis=1), 0.0)
    half = np.where(np.isfinite(pos).all(axis=1), 0.5 * np.ptp(pos, axis=1), np.pi)
    q0 = q - q.mean(axis=0)
    scale = np.minimum(0.5 * half / np.maximum(np.abs(q0).max(axis=0), 1e-12), 1.0)
    vmax = np.abs(qd).max(axis=0) * scale
    ok = np.isfinite(vel) & (vel > 0)
    scale = np.where(ok, scale * np.minimum(1.0, 0.5 * np.where(ok, vel, 1.0) / vmax), scale)
    return centre + q0 * scale, qd * scale, qdd * scale
