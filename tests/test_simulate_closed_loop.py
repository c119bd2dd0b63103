"""Closed-loop PD simulation of the paper's manipulator: invariants, balance, cross-checks."""

import json
from importlib import resources

import numpy as np
import pytest
from scipy.optimize import fsolve

import physid
from _golden import GOLDEN
from physid.errors import InputError, ShapeError, SimulationError
from physid.models import load_model
from physid.simulate import (
    PAPER_MANIPULATOR,
    ReferenceTrajectory,
    closed_loop_rhs,
    paper_manipulator_experiment,
    paper_reference,
    pd_rhs,
    simulate_closed_loop,
)

KP = np.array(PAPER_MANIPULATOR["kp"])
KD = np.array(PAPER_MANIPULATOR["kd"])


@pytest.fixture(scope="module")
def arm():
    return load_model("manipulator", kinetic="exact")


@pytest.fixture(scope="module")
def paper_run(arm):
    """The full 9.7 s experiment, once per module."""
    return paper_manipulator_experiment(model=arm)


def _joint(rec, prefix):
    return rec.select(rec.channels(prefix))


def test_paper_run_layout_and_first_samples(paper_run):
    rec = paper_run
    assert rec.n_samples == 9701
    assert rec.t[0] == 0.0 and rec.t[-1] == pytest.approx(9.7, abs=1e-12)
    assert rec.dt == pytest.approx(1e-3)
    for prefix, unit in (("q", "rad"), ("qd", "rad/s"), ("tau", "N*m"), ("r", "rad")):
        assert rec.channels(prefix) == [f"{prefix}{k}" for k in range(1, 5)]
        assert rec.unit(f"{prefix}1") == unit
    # zero initial state, zero reference until the filter window reaches the first step
    assert np.all(rec.data[0] == 0.0)
    assert np.all(rec["r1"][rec.t < 0.8] == 0.0)
    assert np.all(rec.select(rec.channels("r"))[rec.t < 0.8] == 0.0)
    # gravity moves joints 2..4 from the start, before any reference moves; with the paper's
    # g = (0, 0, +9.81) (V = −m g·p) the links swing towards +z, i.e. q2 > 0
    assert rec["q2"][100] > 1e-3
    meta = rec.metadata
    assert meta["kp"] == list(KP) and meta["kd"] == list(KD)
    assert meta["reference"]["lead_seconds"] == pytest.approx(0.1)
    assert meta["integrator"]["method"] == "DOP853" and meta["integrator"]["rtol"] == 1e-9


def test_recorded_torque_is_the_pd_law_and_the_motion_obeys_the_model(paper_run, arm):
    rec = paper_run
    q, qd, tau, r = (_joint(rec, p) for p in ("q", "qd", "tau", "r"))
    np.testing.assert_allclose(tau, KP * (r - q) - KD * qd, rtol=0, atol=1e-9)
    # q̈ from the model at the recorded (q, q̇, τ) matches the time derivative of the recorded q̇.
    qdd_model = arm.forward_dynamics(q, qd, tau)
    qdd_numeric = np.gradient(qd, rec.dt, axis=0, edge_order=2)
    err = np.abs(qdd_model - qdd_numeric)[2:-2].max(axis=0)
    assert np.all(err < 2e-3 * np.abs(qdd_model).max(axis=0))


def test_paper_reference_leads_the_centred_one_by_m_samples(paper_run):
    centred = paper_reference(paper=False)
    rec = paper_run
    # the paper stamps filtered sample j at j·Δ; the centred stamp is (j + M)·Δ
    np.testing.assert_allclose(
        rec.select(rec.channels("r"))[:9600], centred.values[:9600], atol=1e-12
    )
    np.testing.assert_allclose(centred.t[:9600] - rec.t[:9600], 0.1, atol=1e-12)


def test_final_state_approaches_the_static_gravity_balance(paper_run, arm):
    rec = paper_run
    q_end, qd_end, r_end = (_joint(rec, p)[-1] for p in ("q", "qd", "r"))
    np.testing.assert_allclose(r_end, 0.5, atol=1e-12)
    # static balance of P control against gravity: Kp (r − q*) = G(q*)
    q_star = fsolve(lambda x: KP * (r_end - x) - arm.gravity_forces(x[None])[0], r_end, xtol=1e-14)
    g_star = arm.gravity_forces(q_star[None])[0]
    np.testing.assert_allclose(KP * (r_end - q_star), g_star, atol=1e-8)
    assert q_star[0] == pytest.approx(0.5, abs=1e-12)  # joint 1: vertical axis, no gravity torque
    assert np.all(np.abs(q_star[1:] - 0.5) > 1e-3)  # a real steady-state error on joints 2..4
    # at 9.7 s the arm still rings lightly (ζ ≈ 0.04 on joint 2) but is within 5 mrad of q*
    assert np.abs(q_end - q_star).max() < 5e-3
    # holding the references, the loop settles onto q* exactly
    tail = simulate_closed_loop(
        arm, kp=KP, kd=KD, reference=r_end, q0=q_end, qd0=qd_end, duration=15.0, dt=0.01
    )
    np.testing.assert_allclose(_joint(tail, "q")[-1], q_star, atol=1e-6)
    np.testing.assert_allclose(_joint(tail, "tau")[-1], g_star, rtol=1e-5, atol=1e-3)


def test_backends_agree_with_pinocchio(arm):
    pytest.importorskip("pinocchio")
    ref = paper_reference()
    runs = {
        b: simulate_closed_loop(arm, kp=KP, kd=KD, reference=ref, duration=3.5, dt=1e-3, backend=b)
        for b in ("compiled", "generated", "pinocchio")
    }
    q = {b: _joint(r, "q") for b, r in runs.items()}
    assert np.abs(q["compiled"]).max() > 0.4  # the steps have happened
    np.testing.assert_allclose(q["compiled"], q["pinocchio"], rtol=0, atol=1e-8)
    np.testing.assert_allclose(q["generated"], q["pinocchio"], rtol=0, atol=1e-8)
    assert runs["pinocchio"].metadata["integrator"]["backend"] == "pinocchio"


def test_kinetic_energy_is_conserved_without_gravity_and_control(tmp_path):
    # The built-in arm with g = 0, no control: ½ q̇ᵀ M(q) q̇ is a constant of motion.
    text = (resources.files("physid.models") / "data" / "manipulator.toml").read_text(
        encoding="utf-8"
    )
    assert "gravity = [0.0, 0.0, 9.81]" in text
    path = tmp_path / "arm_no_gravity.toml"
    path.write_text(
        text.replace("gravity = [0.0, 0.0, 9.81]", "gravity = [0.0, 0.0, 0.0]"), encoding="utf-8"
    )
    model = load_model(path)
    rec = simulate_closed_loop(
        model,
        kp=np.zeros(4),
        kd=np.zeros(4),
        reference=np.zeros(4),
        q0=[0.1, -0.4, 0.8, 0.3],
        qd0=[1.5, -2.0, 3.0, -4.0],
        duration=3.0,
        dt=1e-3,
        rtol=1e-10,
        atol=1e-12,
    )
    q, qd = _joint(rec, "q"), _joint(rec, "qd")
    energy = 0.5 * np.einsum("ni,nij,nj->n", qd, model.mass_matrix(q), qd)
    assert np.ptp(q[:, 1]) > 1.0  # it really moves through the workspace
    assert np.abs(energy / energy[0] - 1).max() < 1e-8
    np.testing.assert_array_equal(_joint(rec, "tau"), 0.0)


def test_measurement_noise_is_seeded_and_only_on_q(arm):
    kwargs = dict(kp=KP, kd=KD, reference=[0.2, 0.1, 0.0, -0.1], duration=1.0, dt=1e-3)
    clean = simulate_closed_loop(arm, **kwargs)
    a = simulate_closed_loop(arm, noise_std=1e-3, rng=5, **kwargs)
    b = simulate_closed_loop(arm, noise_std=1e-3, rng=5, **kwargs)
    np.testing.assert_array_equal(a.data, b.data)
    noise = _joint(a, "q") - _joint(clean, "q")
    assert np.std(noise) == pytest.approx(1e-3, rel=0.03)  # 4004 draws: ±1.1 % standard error
    np.testing.assert_array_equal(_joint(a, "qd"), _joint(clean, "qd"))
    np.testing.assert_array_equal(_joint(a, "tau"), _joint(clean, "tau"))
    assert a.metadata["noise"]["seed"] == 5


def test_paper_kinetic_energy_model_runs_and_differs(arm):
    paper_model = load_model("manipulator", kinetic="paper")
    ref = paper_reference()
    exact = simulate_closed_loop(arm, kp=KP, kd=KD, reference=ref, duration=2.0, dt=1e-3)
    simple = simulate_closed_loop(paper_model, kp=KP, kd=KD, reference=ref, duration=2.0, dt=1e-3)
    assert simple.metadata["kinetic"] == "paper"
    assert np.abs(_joint(simple, "q") - _joint(exact, "q")).max() > 1e-4


def test_reference_trajectory_spline_and_hold():
    t = np.linspace(0.0, 1.0, 11)
    values = np.column_stack([t**3, np.sin(t)])
    ref = ReferenceTrajectory(t, values)
    # a cubic spline reproduces a cubic exactly (not-a-knot end conditions)
    assert ref(0.537)[0] == pytest.approx(0.537**3, abs=1e-14)
    np.testing.assert_allclose(ref.sample([0.537])[0], ref(0.537), atol=1e-15)
    assert ref(-5.0) == [0.0, 0.0] and ref(9.0) == pytest.approx([1.0, np.sin(1.0)])
    assert ref.uniform_step == pytest.approx(0.1)


def test_closed_loop_error_paths(arm):
    with pytest.raises(ShapeError, match=r"kp must hold one value per joint"):
        simulate_closed_loop(
            arm, kp=[1.0, 2.0], kd=KD, reference=np.zeros(4), duration=0.1, dt=0.01
        )
    with pytest.raises(ShapeError, match="constant reference must hold 4"):
        simulate_closed_loop(arm, kp=KP, kd=KD, reference=np.zeros(3), duration=0.1, dt=0.01)
    with pytest.raises(InputError, match="backend must be"):
        simulate_closed_loop(
            arm, kp=KP, kd=KD, reference=np.zeros(4), duration=0.1, dt=0.01, backend="jax"
        )
    with pytest.raises(ShapeError, match="q0 must hold 4"):
        simulate_closed_loop(
            arm, kp=KP, kd=KD, reference=np.zeros(4), duration=0.1, dt=0.01, q0=[0.0]
        )

    def bad_reference(t):
        return [np.nan if t > 0.05 else 0.0] * 4

    with pytest.raises(SimulationError, match="integrator stopped"):
        simulate_closed_loop(arm, kp=KP, kd=KD, reference=bad_reference, duration=0.1, dt=0.01)


def test_plot_draws_the_joint_responses(paper_run):
    fig = paper_run.plot()
    (ax,) = fig.axes
    assert len(ax.lines) == 8  # φ1..φ4 and the dashed references
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), paper_run["q1"])
    np.testing.assert_array_equal(ax.lines[1].get_ydata(), paper_run["r1"])
    assert ax.get_ylabel() == "φ [rad]"
    with_tau = paper_run.plot(torques=True)
    assert len(with_tau.axes) == 2 and len(with_tau.axes[1].lines) == 4


def test_compiled_backend_with_callable_reference_matches_generated(arm):
    def wave(t):
        return [0.2 * np.sin(2 * t), 0.1 * np.cos(3 * t) - 0.1, 0.3 * np.sin(t), 0.05 * t]

    from physid.simulate import compiled

    kwargs = dict(kp=KP, kd=KD, reference=wave, duration=1.5, dt=1e-3)
    if compiled.compiler() is None:  # a machine without cc: the compiled path must say so
        with pytest.raises(SimulationError, match="no working C compiler"):
            simulate_closed_loop(arm, backend="compiled", **kwargs)
        return
    fast = simulate_closed_loop(arm, backend="compiled", **kwargs)
    slow = simulate_closed_loop(arm, backend="generated", **kwargs)
    assert fast.metadata["integrator"]["backend"] == "compiled"
    np.testing.assert_allclose(_joint(fast, "q"), _joint(slow, "q"), rtol=0, atol=1e-9)
    np.testing.assert_allclose(_joint(fast, "r")[-1], wave(1.5), atol=1e-15)


def test_without_a_compiler_auto_falls_back_to_generated_code(arm, monkeypatch, tmp_path):
    from physid.simulate import compiled

    monkeypatch.setenv("PHYSID_CACHE_DIR", str(tmp_path))  # no cached library here
    monkeypatch.setattr(compiled, "compiler", lambda: None)
    monkeypatch.setattr(compiled, "_LIBS", {})
    kwargs = dict(kp=KP, kd=KD, reference=np.full(4, 0.1), duration=0.2, dt=1e-3)
    rec = simulate_closed_loop(arm, **kwargs)
    assert rec.metadata["integrator"]["backend"] == "generated"
    with pytest.raises(SimulationError, match="no working C compiler"):
        simulate_closed_loop(arm, backend="compiled", **kwargs)


def test_pinocchio_backend_refuses_the_paper_kinetic_energy():
    pytest.importorskip("pinocchio")
    paper_model = load_model("manipulator", kinetic="paper")
    with pytest.raises(InputError, match="kinetic='exact'"):
        simulate_closed_loop(
            paper_model,
            kp=KP,
            kd=KD,
            reference=np.zeros(4),
            duration=0.1,
            dt=0.01,
            backend="pinocchio",
        )


def test_paper_experiment_rejects_conflicting_or_unused_keywords():
    paper_model = load_model("manipulator", kinetic="paper")
    # kinetic="exact" with a paper-kinetic model would silently run the paper model
    with pytest.raises(InputError, match="kinetic='exact' conflicts with the model given"):
        paper_manipulator_experiment(kinetic="exact", model=paper_model)
    # a seed with no noise seeds nothing (the CLI verb rejects the same)
    with pytest.raises(InputError, match="seed=3 is used only to draw measurement noise"):
        paper_manipulator_experiment(seed=3, model=paper_model)


def test_a_seed_without_noise_is_refused_not_ignored(arm):
    with pytest.raises(InputError, match="only seeds the measurement noise on q"):
        simulate_closed_loop(
            arm, kp=KP, kd=KD, reference=np.zeros(4), duration=0.01, dt=1e-3, rng=3
        )


# ------------------------------------------------------------------ the PD law (physid.simulate.pd)
def test_pd_rhs_is_bit_identical_to_the_golden_manipulator_floats():
    """The symbolic chain's fused PD right-hand side gives the golden floats bit for bit
    (tests/golden/pd_rhs_manipulator.json: the PD law fused into the manipulator's code)."""
    gold = json.loads((GOLDEN / "pd_rhs_manipulator.json").read_text())
    arm = physid.load_model("manipulator")
    rng = np.random.default_rng(7)
    kp = np.array([3800.0, 40000.0, 10000.0, 500.0])
    kd = np.array([159.5, 120.0, 50.0, 2.0])
    r = np.array([0.5, 0.4, 0.3, 0.2])
    f = pd_rhs(arm, {"m3": 14.0}, kp=kp, kd=kd, reference=lambda t: r * t)
    g = pd_rhs(arm, {"m3": 14.0}, kp=kp, kd=kd, reference=r)
    ys = rng.normal(size=(3, 8))
    assert [[float(v).hex() for v in f(1.7, y)] for y in ys] == gold["chain_callable"]
    assert [[float(v).hex() for v in g(0.0, y)] for y in ys] == gold["chain_const"]
    # and it is the closed loop: [q̇, M⁻¹(τ − h)] with τ = Kp (r t − q) − Kd q̇
    y = ys[0]
    tau = kp * (r * 1.7 - y[:4]) - kd * y[4:]
    qdd = arm.forward_dynamics(y[None, :4], y[None, 4:], tau[None], {"m3": 14.0})[0]
    np.testing.assert_allclose(f(1.7, y), np.r_[y[4:], qdd], rtol=1e-10, atol=1e-9)


def test_rigid_pd_rhs_is_the_model_rhs_under_pd_torque_exactly():
    arm6 = physid.load_model("arm6")
    n = arm6.n_joints
    kp, kd = np.linspace(500, 4000, n), np.linspace(2, 150, n)
    f = pd_rhs(arm6, kp=kp, kd=kd, reference=lambda t: np.full(n, 0.3) * t, coulomb_smoothing=0.01)
    accel = arm6.make_rhs(None, coulomb_smoothing=0.01)
    y = np.random.default_rng(7).normal(size=2 * n)
    q, qd = y[:n], y[n:]
    old = np.concatenate([qd, accel(q, qd, kp * (np.full(n, 0.3) * 1.3 - q) - kd * qd)])
    np.testing.assert_array_equal(f(1.3, y), old)
    assert not hasattr(arm6, "make_pd_rhs")  # the model holds no controller any more


def test_closed_loop_generated_backend_uses_the_pd_law():
    arm = physid.load_model("manipulator")
    kp, kd = [3800.0, 40000.0, 10000.0, 500.0], [159.5, 120.0, 50.0, 2.0]
    ref = np.array([0.5, 0.4, 0.3, 0.2])
    f = closed_loop_rhs(arm, kp=kp, kd=kd, reference=lambda t: ref, backend="generated")
    g = pd_rhs(arm, kp=kp, kd=kd, reference=ref)
    y = np.linspace(-0.5, 0.5, 8)
    assert f.backend == "generated"
    assert f(0.2, y) == g(0.2, y)
