"""The zoo's elastic 2-link arm (benchmarks/zoo/flexible.py) against independent physics.

* its joint modes: the simulator's own linearisation (finite differences of its equations of
  motion) and a free vibration it integrates against the eigenvalues of the linearised model
  written from `TwoLink`'s mass matrix and gravity;
* energy: with no friction and no damping, kinetic + gravity + spring energy stays constant;
* at low frequency the elastic arm is the rigid arm with armature N² Jm: on a 0.1 Hz motion the
  motor torque N kt i equals pinocchio's inverse dynamics of the URDF (armature, joint-side
  viscous and Coulomb friction) at the motor angles, to O(1/K);
* the case's motor-side log reads through physid's `[transmission]` as the recipe's record.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")  # a dev dependency: always installed by make test

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.zoo import cases  # noqa: E402
from benchmarks.zoo.drives import TwoLink  # noqa: E402
from benchmarks.zoo.flexible import FlexibleTwoLink  # noqa: E402

Q0 = np.array([0.3, 0.6])  # the zoo's rest pose (cases.ARM2_Q0)


def _lossless(**kw):
    """The arm without friction and damping (energy is conserved)."""
    arm = TwoLink(fc=(0.0, 0.0), fs=(0.0, 0.0), fv=(0.0, 0.0))
    return FlexibleTwoLink(arm=arm, damping=(0.0, 0.0), **kw)


def test_mode_frequencies_are_the_stated_ones():
    """The docstring's numbers (the linearisation itself is checked against the simulator's
    equations in the next test)."""
    arm = FlexibleTwoLink()
    m = arm.modes(Q0)
    np.testing.assert_allclose(m["free"], [17.2, 30.7], atol=0.05)
    np.testing.assert_allclose(m["locked"], [10.6, 26.1], atol=0.05)
    assert np.all(m["pendulum"] < 1.0)
    np.testing.assert_allclose(m["zeta"], [0.071, 0.076], atol=0.002)


def test_simulator_linearisation_has_the_models_modes():
    """Finite differences of the simulator's ds/dt at rest (D = 0, no friction) give
    eigenvalues ±iω with ω the linearised model's (`modes`: `TwoLink`'s mass matrix and
    gravity), to 1e-5."""
    arm = _lossless()
    s0 = np.array(arm.rest_state(Q0))
    tm = tuple(arm.gravity(Q0)[0])  # the motors hold gravity
    assert np.abs(arm._deriv(tuple(s0), tm)).max() < 1e-10  # an equilibrium (rad/s²)
    e = 1e-7
    jac = np.column_stack(
        [
            (
                np.array(arm._deriv(tuple(s0 + e * d), tm))
                - np.array(arm._deriv(tuple(s0 - e * d), tm))
            )
            / (2 * e)
            for d in np.eye(8)
        ]
    )
    lam = np.linalg.eigvals(jac)
    assert np.abs(lam.real).max() < 1e-4 * np.abs(lam).max()  # undamped
    w = np.sort(np.abs(lam.imag[lam.imag > 0])) / (2 * np.pi)
    m = arm.modes(Q0)
    np.testing.assert_allclose(w, np.r_[m["pendulum"], m["free"]], rtol=1e-5)


def test_free_vibration_rings_at_the_elastic_modes():
    """A small spring deflection at rest, motors free: the motor and link angles ring at the
    two elastic modes (zero-padded FFT peak within 0.5 %), and the motor-locked case (rotors
    10^6 times heavier) at the locked link modes."""
    for key, rotor in (("free", (2e-5, 1e-5)), ("locked", (20.0, 10.0))):
        arm = FlexibleTwoLink(
            arm=TwoLink(fc=(0.0, 0.0), fs=(0.0, 0.0), fv=(0.0, 0.0), rotor=rotor),
            damping=(0.0, 0.0),
        )
        s = list(arm.rest_state(Q0))
        tm = tuple(arm.gravity(Q0)[0])
        s[0] += 1e-4
        s[1] -= 2e-4
        s = tuple(s)
        dt, n = 2e-4, 10000  # 2 s; ω dt < 0.04
        x = np.empty((n, 2))
        for k in range(n):
            x[k] = np.array(s[:2]) - np.array(arm.rest_state(Q0)[:2])
            s = arm.rk4(s, tm, dt)
        x -= x.mean(0)
        f = np.fft.rfftfreq(16 * n, dt)
        spec = np.abs(np.fft.rfft(x * np.hanning(n)[:, None], 16 * n, axis=0)).sum(1)
        band = f > 3.0  # above the pendulum modes
        peaks = []
        for lo, hi in ((3.0, 0.5 * sum(arm.modes(Q0)[key])), (0.5 * sum(arm.modes(Q0)[key]), 80)):
            m = (f > lo) & (f < hi) & band
            peaks.append(f[m][np.argmax(spec[m])])
        np.testing.assert_allclose(peaks, arm.modes(Q0)[key], rtol=0.005)


def _energy_drift(arm, s, dt, duration=0.5):
    e0, worst = arm.energy(s), 0.0
    for _ in range(round(duration / dt)):
        s = arm.rk4(s, (0.0, 0.0), dt)
        worst = max(worst, abs(arm.energy(s) - e0))
    return worst, s


def test_energy_is_conserved_without_losses():
    """No friction, no damping, no current: total energy constant to 2e-8 of the kinetic and
    spring energy put in over 0.5 s of a swinging, ringing arm at 1e-4 s, and the drift is
    RK4's: 2e-4 s gives 2^4 = 16 times more (between 8 and 32)."""
    arm = _lossless()
    s0 = (0.3, 0.6, 0.31, 0.58, 0.5, -0.4, 0.2, 0.1)
    put_in = arm.energy(s0) - arm.energy((0.3, 0.6, 0.3, 0.6, 0, 0, 0, 0))
    fine, s = _energy_drift(arm, s0, 1e-4)
    coarse, _ = _energy_drift(arm, s0, 2e-4)
    assert fine < 2e-8 * abs(put_in)
    assert 8 < coarse / fine < 32
    assert abs(s[0] - 0.3) > 0.01  # it moved


def _slow_torque_error(stiffness_scale):
    """Relative rms of N kt i − (rigid inverse dynamics at the motor angles), both through a
    2 Hz zero-phase low-pass (the current is held per period and the PD ripples around it)."""
    from scipy.signal import butter, filtfilt

    base = FlexibleTwoLink()
    arm = FlexibleTwoLink(stiffness=tuple(stiffness_scale * k for k in base.stiffness))
    h = 2e-4
    t = np.arange(int(6.0 / h)) * h
    r = Q0 + np.array([0.6, 0.5]) * np.sin(2 * np.pi * 0.1 * t)[:, None] * np.array([1.0, -1.0])
    _, phi, _, w, _, cur = arm.simulate(r, h, cases.ARM2_KP, cases.ARM2_KD, 2**20, settle=0.5)
    tau = arm.arm.ratio * arm.arm.kt * cur
    acc = np.gradient(w, h, axis=0)
    urdf = arm.arm.urdf(Path(cases._scratch()) / "two_link_flex_test.urdf")
    model = pin.buildModelFromUrdf(str(urdf))
    model.armature[:] = arm.arm.armature
    data = model.createData()
    rigid = np.array([pin.rnea(model, data, phi[k], w[k], acc[k]) for k in range(t.size)])
    fric = np.asarray(arm.arm.fc) * np.tanh(w / arm.arm.eps) + np.asarray(arm.arm.fv) * w
    b, a = butter(2, 2.0 * 2 * h)
    diff = filtfilt(b, a, tau - rigid - fric, axis=0)[1000:-1000]
    ref = filtfilt(b, a, tau, axis=0)[1000:-1000]
    return np.sqrt(np.mean(diff**2, 0) / np.mean(ref**2, 0))


def test_low_frequency_motion_is_the_rigid_arm_with_armature():
    """0.1 Hz, ±0.6 rad: the motor torque is pinocchio's rnea with armature N² Jm plus Fv φ̇ +
    Fc tanh(φ̇/ε) at the motor angles within 1 % per joint; the rest is the static deflection
    K⁻¹ g (about 3 mrad), so 100 times stiffer springs leave 100 times less (within a factor 3)."""
    soft = _slow_torque_error(1.0)
    stiff = _slow_torque_error(100.0)
    assert np.all(soft < 0.01), soft
    assert np.all(soft > 1e-4), soft  # the deflection is there
    ratio = soft / stiff
    assert np.all((ratio > 100 / 3) & (ratio < 300)), ratio


def test_case_h_motor_log_reads_as_the_recipes_joint_record():
    """physid's `[transmission]` (q = θm/N, τ = N kt i) turns the motor-side log into the
    joint-side record the recipe reads; the truth is the rigid arm's with armature N² Jm."""
    import physid
    from physid.signals.joint_side import joint_side

    c = cases.case_flexible_arm(train_s=1.0, test_s=0.5)
    rec = joint_side(physid.load_model(c.physid_model), c.physid_train)
    for name in ("q1", "q2", "tau1", "tau2"):
        np.testing.assert_allclose(rec[name], c.train[name], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(c.truth.armature, [0.2, 0.1], rtol=1e-12)
    np.testing.assert_allclose(c.truth.viscous, TwoLink().fv)
    np.testing.assert_allclose(c.truth.coulomb, TwoLink().fc)
    assert c.test_tau_true.shape == (c.test.n_samples, 2)
    assert "17.2/30.7 Hz" in c.note


def test_automatic_decimation_keeps_the_joint_modes_out_of_the_first_link_inertia():
    """With a current ripple exciting the joint modes, the spectrum puts the state filter's
    cut-off at 477 Hz; the spectrum rule's decimation (nd 8, parallel band 0.4·5000/8 = 250 Hz)
    fits the modes and puts the first link's inertia Iyy1R about 50 % low. `decimate="auto"`
    judges its candidates on the most smoothed rows and picks a band 8× lower (nd 67, 30 Hz,
    on this 10 s record): within 5 %."""
    from benchmarks.zoo import compare
    from benchmarks.zoo.recipe import Recipe

    import physid
    from physid.estimators import make
    from physid.estimators.idim.choose import decimate_candidates
    from physid.signals.joint_side import joint_side

    c = cases.case_flexible_arm(train_s=10.0, test_s=0.5, ripple=0.1)
    model = physid.load_model(c.physid_model)
    rec = joint_side(model, c.physid_train)
    recipe = Recipe(c.urdf, armature=True)
    k = recipe.base_names.index("Iyy1R")
    truth = recipe.truth(c.truth)[k]

    def iyy1_error(**settings):
        res = make("idim-ols", model, **settings).fit(rec).result_
        beta, _ = compare._physid_in_recipe_base(model, res, recipe)
        return res, (beta[k] - truth) / truth

    auto, auto_err = iyy1_error()
    nds = decimate_candidates(auto.cutoff, rec.n_samples, len(auto.names), 2)
    _, spectrum_err = iyy1_error(cutoff=auto.cutoff, decimate=nds[0])
    assert auto.cutoff * 5000 / (2 * np.pi) > 400  # Hz: the modes (17, 31 Hz) are far below
    assert auto.decimate > 4 * nds[0]  # measured 67 of 8
    assert spectrum_err < -0.3  # measured −0.49
    assert abs(auto_err) < 0.05  # measured +0.019
