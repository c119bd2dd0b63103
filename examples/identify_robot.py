"""Identify a 6-DOF arm from a URDF: excitation design → closed loop → IDIM → validation.

The built-in ``arm6`` (a UR5-like URDF with a friction/armature sidecar) stands in for a real
robot: we design a Fourier excitation, run it in closed loop with PD control (noisy encoders,
noisy torque sensors), identify the base parameters with IDIM-WLS and IDIM-IV, and check the
estimate on a second, held-out trajectory. See docs/identifying-a-robot.md.
"""

import warnings

import numpy as np

import physid
from physid.analysis import design_excitation
from physid.estimators import IDIMEstimator
from physid.simulate import simulate_closed_loop

model = physid.load_model("arm6")
kp = np.array([400.0, 400.0, 200.0, 50.0, 50.0, 20.0])  # [N·m/rad]
kd = 0.1 * kp  # [N·m·s/rad]

# 1. excitation: 4 harmonics, 8 s period, within 1 rad/s and 4 rad/s² (and the URDF's positions)
design = design_excitation(
    model,
    harmonics=4,
    period=8.0,
    velocity=1.0,
    acceleration=4.0,
    n_random=4,
    max_iter=20,  # an iteration budget, not a time budget: the same trajectory on any machine
    max_seconds=600,
)
print(design.summary())
reference = design.to_recording(dt=1e-3)
r = reference.select([f"r{j}" for j in range(1, 7)])

# 2. the experiment: PD closed loop, 1e-4 rad encoder noise, 2 % torque noise
rec = simulate_closed_loop(model, kp=kp, kd=kd, reference=r, t=reference.t, noise_std=1e-4, rng=1)
rng = np.random.default_rng(2)
tau_names = [f"tau{j}" for j in range(1, 7)]
tau = rec.select(tau_names)
noisy = rec.with_channels(
    {
        n: tau[:, k] + 0.02 * np.sqrt(np.mean(tau[:, k] ** 2)) * rng.standard_normal(tau.shape[0])
        for k, n in enumerate(tau_names)
    }
)

# 3. identification: weighted least squares, then instrumental variables
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    wls = IDIMEstimator(model, "wls").fit(noisy).result_
    iv = IDIMEstimator(model, "iv", max_iter=4).fit(noisy).result_
print(
    f"WLS: {len(wls.names)} base parameters, condition number {wls.condition_number:.3g}, "
    f"relative torque error {wls.relative_error['overall']:.3g}"
)
print(f"IV: {iv.iterations} iterations, changes {[f'{c:.2g}' for c in iv.iv_changes]}")

# 4. validation on a held-out trajectory (true states, torques from the true model)
t2 = np.arange(0.0, 6.0, 1e-3)
r2 = 0.3 * np.sin(np.outer(t2, 2 * np.pi * np.array([0.3, 0.2, 0.25, 0.4, 0.35, 0.5])))
r2 *= np.clip(t2 / 1.0, 0.0, 1.0)[:, None] ** 3
hold = simulate_closed_loop(model, kp=kp, kd=kd, reference=r2, t=t2)
q = hold.select([f"q{j}" for j in range(1, 7)])
qd = hold.select([f"qd{j}" for j in range(1, 7)])
tau2 = hold.select(tau_names)
qdd = model.forward_dynamics(q, qd, tau2)
columns = [model.regressor_names.index(n) for n in wls.columns]  # the kept regressor columns
W = model.regressor(q, qd, qdd)[:, :, columns]
for label, res in (("WLS", wls), ("IV", iv)):
    err = np.linalg.norm(W @ res.beta_vector() - tau2) / np.linalg.norm(tau2)
    print(f"held-out relative torque error, {label}: {err:.3g}")
    if label == "WLS":
        assert err < 0.05, err  # the example checks itself (measured 0.0027)
