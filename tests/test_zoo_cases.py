"""The zoo's own simulators (benchmarks/zoo/drives.py) against independent physics.

* the 2-link arm's equations of motion (written by hand) against pinocchio's inverse dynamics
  of the URDF the arm writes, rotor inertia as pinocchio's armature;
* the linear drive's event-driven integrator: velocity exactly 0 while the force lies within
  [Fc−, Fc+], the analytic solution of M v̇ = F − Fv v − Fc± between events, the work–energy
  balance over a closed-loop run, and stops at the instant the analytic solution gives;
* the recipe (benchmarks/zoo/recipe.py) recovers each new case's truth from noise-free data.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")  # a dev dependency: always installed by make test

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.zoo import cases  # noqa: E402
from benchmarks.zoo.drives import LinearDrive, TwoLink  # noqa: E402
from benchmarks.zoo.recipe import Recipe  # noqa: E402


@pytest.fixture(scope="module")
def arm_urdf(tmp_path_factory):
    return TwoLink().urdf(tmp_path_factory.mktemp("zoo") / "two_link.urdf")


def test_two_link_torques_match_pinocchio_rnea(arm_urdf):
    arm = TwoLink()
    model = pin.buildModelFromUrdf(str(arm_urdf))
    model.armature[:] = arm.armature
    data = model.createData()
    rng = np.random.default_rng(5)
    q, qd, qdd = rng.uniform(-3, 3, (3, 40, 2))
    mine = arm.inverse_dynamics(q, qd, qdd, friction=False)
    ref = np.array([pin.rnea(model, data, q[k], qd[k], qdd[k]) for k in range(40)])
    assert np.abs(mine - ref).max() < 1e-9
    M = np.array([pin.crba(model, data, q[k]) for k in range(40)])
    assert np.abs(arm.mass_matrix(q) - np.triu(M) - np.triu(M, 1).transpose(0, 2, 1)).max() < 1e-9


def test_two_link_forward_dynamics_inverts_inverse_dynamics():
    arm = TwoLink()
    rng = np.random.default_rng(6)
    for _ in range(10):
        q, qd, tau = rng.normal(size=2), rng.normal(size=2) * 0.3, rng.normal(size=2) * 5
        acc = np.array(arm._acc(list(q), list(qd), tuple(tau)))
        back = arm.inverse_dynamics(q[None], qd[None], acc[None])[0]  # friction included
        assert np.abs(back - tau).max() < 1e-12


def test_two_link_stribeck_friction_values():
    arm = TwoLink()
    # far above vs and ε: Fc + Fv q̇; just above ε, well below vs: ≈ Fs
    f = arm.friction(np.array([[2.0, -2.0], [0.01, -0.01]]))
    np.testing.assert_allclose(f[0], [1.5 + 1.0 * 2.0, -(0.8 + 0.5 * 2.0)], rtol=1e-12)
    s = math.exp(-((0.01 / 0.05) ** 2))
    assert f[1, 0] == pytest.approx((1.5 + 0.7 * s) * math.tanh(10) + 0.01, rel=1e-12)
    assert f[1, 1] == pytest.approx(-(0.8 + 0.4 * s) * math.tanh(10) - 0.005, rel=1e-12)


def test_linear_drive_sticks_while_force_within_static_band():
    d = LinearDrive()
    for force in (-17.0, -5.0, 0.0, 19.99, 20.0):
        assert d.step(0.1, 0.0, force, 1e-3) == (0.1, 0.0)
    x, v = d.step(0.1, 0.0, 20.5, 1e-3)  # just above Fc+: slides forward
    assert v > 0 and x > 0.1
    x, v = d.step(0.1, 0.0, -17.5, 1e-3)
    assert v < 0 and x < 0.1


def test_linear_drive_between_events_is_the_analytic_solution():
    d = LinearDrive()
    T = d.mass / d.viscous
    v0, force, h = 0.2, 150.0, 0.05
    v_inf = (force - d.coulomb_pos) / d.viscous
    x, v = d.step(0.0, v0, force, h)
    assert v == pytest.approx(v_inf + (v0 - v_inf) * math.exp(-h / T), rel=1e-13)
    assert x == pytest.approx(v_inf * h + (v0 - v_inf) * T * (1 - math.exp(-h / T)), rel=1e-13)
    # braking with F = 0 from 0.01 m/s: stops at t0 = T ln((v0 − v∞)/(−v∞)) and stays
    v_inf = -d.coulomb_pos / d.viscous
    t0 = T * math.log((0.01 - v_inf) / -v_inf)
    x, v = d.step(0.0, 0.01, 0.0, 1.0)
    assert v == 0.0
    assert x == pytest.approx(v_inf * t0 + (0.01 - v_inf) * T * (1 - math.exp(-t0 / T)), 1e-13)
    # a time step split in two gives the same state (exact integration, no step error)
    a = d.step(*d.step(0.0, 0.01, 0.0, 0.004), 0.0, 0.006)
    assert a == pytest.approx(d.step(0.0, 0.01, 0.0, 0.01), rel=1e-12, abs=1e-15)


def test_linear_drive_closed_loop_rests_are_exact_and_energy_balances():
    d = LinearDrive()
    h = 1e-3
    t = np.arange(6000) * h
    r = cases.p2p_reference(t, np.array([0.1]), np.random.default_rng(3), position=0.08)[:, 0]
    x, v, _, u = d.simulate(r, h, cases.DRIVE_KP, cases.DRIVE_KD, 1e-6, cases.DRIVE_GAIN)
    force = cases.DRIVE_GAIN * u
    still = (v[:-1] == 0.0) & (v[1:] == 0.0)
    assert still.mean() > 0.2  # the rests do stick
    assert np.all(np.diff(x)[still] == 0.0)
    assert np.all((force[:-1][still] >= d.coulomb_neg) & (force[:-1][still] <= d.coulomb_pos))
    # work–energy over the run: ∫F dx = ΔKE + ∫Fv v² dt + ∫Fc± |dx|; with the exact motion per
    # period, ∫ F dx = F_k Δx_k and the dissipation is integrated on a fine sub-grid
    fine = 50
    diss = 0.0
    for k in np.flatnonzero(~still):
        xs, vs = [x[k]], [v[k]]
        for _ in range(fine):
            xn, vn = d.step(xs[-1], vs[-1], force[k], h / fine)
            xs.append(xn)
            vs.append(vn)
        vs, dx = np.array(vs), np.diff(xs)
        # the trapezoid of v² on the fine grid, Coulomb on each signed stretch
        diss += d.viscous * np.sum(0.5 * (vs[1:] ** 2 + vs[:-1] ** 2)) * h / fine
        diss += np.sum(np.where(dx > 0, d.coulomb_pos * dx, d.coulomb_neg * dx))
    work = np.sum(force[:-1] * np.diff(x))
    dke = 0.5 * d.mass * (v[-1] ** 2 - v[0] ** 2)
    assert abs(work - dke - diss) < 1e-7 * work  # 3e-10 measured


def test_recipe_recovers_linear_drive_on_moving_rows_of_noise_free_record():
    """The recipe's filtered equations are exact where the carriage moves throughout the
    filter's window (3/fc): there sign(v) is constant and Butterworth, sign and the regressor
    commute; at rest the static friction is any value in [Fc−, Fc+]."""
    c = cases.case_linear_drive()
    rc = Recipe(c.urdf, offset=True)
    cut = 5 * c.bandwidth_hz
    rows = rc.rows(c.train_clean, cut)
    x = np.asarray(c.train_clean.select(["q1"]))[:, 0]
    moving = np.r_[False, np.diff(x) != 0]
    w = int(round(3 / cut / c.train.dt))
    window = np.convolve(moving.astype(float), np.ones(2 * w + 1), mode="same") == 2 * w + 1
    keep = window[np.round(rows.t / c.train.dt).astype(int)]
    assert keep.sum() > 150
    W, y = rows.W[keep].reshape(-1, rc.n_base), rows.tau[keep].ravel()
    beta = np.linalg.lstsq(W, y, rcond=None)[0]
    truth = rc.truth(c.truth)
    assert rc.base_names == ("m1", "Fv1", "Fc1", "OF1")
    np.testing.assert_allclose(truth, [95.0, 200.0, 18.5, 1.5], rtol=1e-12)
    np.testing.assert_allclose(beta, truth, rtol=0.01)


def test_recipe_recovers_two_link_truth_from_exact_states(arm_urdf):
    """The recipe's base regressor (pinocchio + Ia, Fv, Fc columns) on the simulator's own
    states reproduces the arm's base parameters within 1 % (friction without the Stribeck
    hump, which no estimator models: see cases.py (g))."""
    arm = TwoLink(fs=TwoLink().fc)
    h = 2e-4
    t = np.arange(int(4.0 / h)) * h
    r = cases.fourier_reference(t, cases.ARM2_Q0, np.random.default_rng(9), period=4.0)
    q, v, _, cur = arm.simulate(r, h, cases.ARM2_KP, cases.ARM2_KD, cases.ARM2_COUNTS)
    tau = arm.ratio * arm.kt * cur  # held over [t_k, t_k + h)
    acc = np.diff(v, axis=0) / h  # the mean acceleration over the period
    qm, vm = q[:-1] + 0.5 * h * v[:-1], v[:-1] + 0.5 * h * acc  # the period's midpoint
    sel = np.arange(0, t.size - 1, 10)
    sel = sel[np.all(np.abs(vm[sel]) > 0.01, axis=1)]  # tanh(q̇/ε) = sign(q̇) to 1e-8
    rc = Recipe(arm_urdf, armature=True)
    W = rc.base_regressor(qm[sel], vm[sel], acc[sel]).reshape(-1, rc.n_base)
    beta = np.linalg.lstsq(W, tau[sel].ravel(), rcond=None)[0]
    model = pin.buildModelFromUrdf(str(arm_urdf))
    truth = rc.truth(cases.truth_of(model, arm.armature, np.array(arm.fv), np.array(arm.fc)))
    big = np.abs(truth) > 1e-9
    assert big.sum() == 9  # mcz1, mcz2 are 0: the centres of mass lie on the links
    np.testing.assert_allclose(beta[big], truth[big], rtol=0.01)
    np.testing.assert_allclose(beta[~big], 0.0, atol=1e-4)  # kg·m


@pytest.fixture(scope="module")
def two_link_case():
    return cases.case_two_link_motor(train_s=10.0, test_s=1.0)


def test_two_link_motor_log_through_physid_transmission_is_the_recipes_joint_record(
    two_link_case,
):
    """physid's `[transmission]` (q = θm/N, τ = N kt i) turns the motor-side log into the
    joint-side record the recipe reads."""
    import physid
    from physid.signals.joint_side import joint_side

    c = two_link_case
    rec = joint_side(physid.load_model(c.physid_model), c.physid_train)
    for name in ("q1", "q2", "tau1", "tau2"):
        np.testing.assert_allclose(rec[name], c.train[name], rtol=1e-12, atol=1e-15)
    assert np.abs(np.asarray(c.train["tau1"])).max() > 5.0  # N·m: a loaded shoulder


def test_recipe_recovers_two_link_truth_from_noise_free_record_away_from_stribeck(
    two_link_case,
):
    """The recipe's pipeline (Butterworth, central differences) on the noise-free record, its
    equations kept where |q̇^f| > 2 vs (outside the Stribeck hump, which the Coulomb + viscous
    columns do not model): every base parameter within 1 % but the link-2 inertia terms, which
    this Fourier reference excites less (within 3 %)."""
    c = two_link_case
    rc = Recipe(c.urdf, armature=True)
    rows = rc.rows(c.train_clean, 10.0)
    keep = np.abs(rows.qd) > 2 * max(TwoLink().vs)
    beta = np.linalg.lstsq(rows.W[keep], rows.tau[keep], rcond=None)[0]
    truth = rc.truth(c.truth)
    names = rc.base_names
    weak = [names.index(n) for n in ("Iyy2", "Ia2")]
    zero = [names.index(n) for n in ("mcz1", "mcz2")]
    rest = [k for k in range(len(names)) if k not in weak + zero]
    np.testing.assert_allclose(beta[rest], truth[rest], rtol=0.01)
    np.testing.assert_allclose(beta[weak], truth[weak], rtol=0.03)
    np.testing.assert_allclose(beta[zero], 0.0, atol=2e-3)  # kg·m


def test_recipe_fit_on_a_span_is_the_fit_of_the_rows_inside_it(two_link_case):
    """``Recipe.fit(span=...)`` (what `benchmarks/zoo/span.py` compares with physid's rows):
    the whole span gives the plain fit; a shorter one the OLS of exactly the rows inside it."""
    c = two_link_case
    rc = Recipe(c.urdf, armature=True)
    cut = 5 * c.bandwidth_hz
    plain = rc.fit(c.train, cut)
    rows = rc.rows(c.train, cut)
    whole = rc.fit(c.train, cut, span=(rows.t[0], rows.t[-1]))
    np.testing.assert_array_equal(whole.beta, plain.beta)
    assert whole.n_rows == plain.n_rows == rows.t.size
    t0, t1 = rows.t[0] + 2.0, rows.t[-1] - 1.0
    inside = (rows.t >= t0) & (rows.t <= t1)
    part = rc.fit(c.train, cut, span=(t0, t1))
    assert part.n_rows == int(inside.sum()) < plain.n_rows
    ols = np.linalg.lstsq(
        rows.W[inside].reshape(-1, rc.n_base), rows.tau[inside].ravel(), rcond=None
    )
    np.testing.assert_allclose(part.beta, ols[0], rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(part.beta - plain.beta)) > 0  # a different fit, not the same one
