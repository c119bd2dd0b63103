"""Exact simulation of linear ODE models: closed forms, scipy cross-checks, jumps, noise, errors."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.signal import cont2discrete, dlsim, lsim, tf2ss

from physid.errors import InputError, SamplingError, ShapeError
from physid.signals.excitation import Multisine, Sinusoid
from physid.simulate import (
    PAPER_MSD,
    linear_ode_state_space,
    msd_paper_scenario,
    msd_parameters,
    simulate_linear_ode,
    simulate_msd,
)

M, C, K = 3.0, 0.05, 400.0
W0 = np.sqrt(K / M)


def msd_sine_response(t, theta1, theta2, amp, omega, x0=0.0, v0=0.0):
    """Closed-form x(t), ẋ(t) of ẍ + θ1 ẋ + θ2 x = A sin(ω t), underdamped, x(0)=x0, ẋ(0)=v0.

    Particular solution (steady state): x_p = Im[A e^{iωt} / (θ2 − ω² + i θ1 ω)]
      = A [(θ2 − ω²) sin ωt − θ1 ω cos ωt] / ((θ2 − ω²)² + (θ1 ω)²).
    Homogeneous: x_h = e^{−σt} (c1 cos ωd t + c2 sin ωd t), σ = θ1/2, ωd = √(θ2 − σ²),
    with c1 = x0 − x_p(0) and c2 = (v0 − ẋ_p(0) + σ c1) / ωd from the initial conditions.
    """
    den = (theta2 - omega**2) ** 2 + (theta1 * omega) ** 2
    p_sin = amp * (theta2 - omega**2) / den
    p_cos = -amp * theta1 * omega / den
    xp = p_sin * np.sin(omega * t) + p_cos * np.cos(omega * t)
    vp = omega * (p_sin * np.cos(omega * t) - p_cos * np.sin(omega * t))
    sigma = theta1 / 2
    wd = np.sqrt(theta2 - sigma**2)
    c1 = x0 - p_cos
    c2 = (v0 - omega * p_sin + sigma * c1) / wd
    e = np.exp(-sigma * t)
    xh = e * (c1 * np.cos(wd * t) + c2 * np.sin(wd * t))
    vh = e * ((-sigma * c1 + wd * c2) * np.cos(wd * t) + (-sigma * c2 - wd * c1) * np.sin(wd * t))
    return xp + xh, vp + vh


def ivp_reference(a, b0, u, t, x0, rtol=1e-12):
    """Second-order ODE x'' + a1 x' + a0 x = b0 u(t) integrated by DOP853 (independent of us)."""
    sol = solve_ivp(
        lambda s, y: [y[1], b0 * u(s) - a[1] * y[1] - a[0] * y[0]],
        (t[0], t[-1]),
        list(x0),
        method="DOP853",
        t_eval=t,
        rtol=rtol,
        atol=1e-12,
    )
    return sol.y


@pytest.mark.parametrize(
    ("ratio", "x0", "v0"),
    [(1.0, 0.0, 0.0), (10.0, 0.0, 0.0), (0.3, 0.02, -1.5), (2.7, -0.1, 3.0)],
)
def test_msd_exact_sinusoid_matches_closed_form(ratio, x0, v0):
    amp = PAPER_MSD["amplitude"]
    rec = simulate_msd(
        mass=M,
        damping=C,
        stiffness=K,
        amplitude=amp,
        ratio=ratio,
        x0=(x0, v0),
        output_derivatives=True,
    )
    x_ref, v_ref = msd_sine_response(rec.t, C / M, K / M, amp, ratio * W0, x0, v0)
    scale = max(1.0, np.abs(x_ref).max())
    assert np.abs(rec["x"] - x_ref).max() <= 1e-10 * scale
    assert np.abs(rec["x_d1"] - v_ref).max() <= 1e-10 * max(1.0, np.abs(v_ref).max())
    np.testing.assert_allclose(rec["u"], amp * np.sin(ratio * W0 * rec.t), rtol=0, atol=1e-9)
    assert rec.n_samples == 5001 and rec.dt == pytest.approx(1e-3)


def test_msd_exact_sinusoid_matches_solve_ivp_with_strong_damping():
    # ζ = 0.4 so the transient matters; non-zero phase and initial state.
    p = msd_parameters(natural_frequency=7.0, damping_ratio=0.4)
    rec = simulate_msd(
        natural_frequency=7.0,
        damping_ratio=0.4,
        amplitude=5.0,
        angular_frequency=3.0,
        phase=0.7,
        duration=4.0,
        dt=0.01,
        x0=(0.3, -1.0),
    )
    y = ivp_reference(
        [p["theta2"], p["theta1"]], 1.0, lambda s: 5.0 * np.sin(3.0 * s + 0.7), rec.t, (0.3, -1.0)
    )
    np.testing.assert_allclose(rec["x"], y[0], rtol=0, atol=1e-10)


def test_critically_damped_repeated_pole_matches_closed_form():
    # ẍ + 2ẋ + x = 0, x(0)=1, ẋ(0)=0  ->  x = (1 + t) e^{−t}: a defective (Jordan) Φ.
    rec = simulate_linear_ode(([1.0, 2.0, 1.0], [1.0]), duration=10.0, dt=0.01, x0=[1.0, 0.0])
    np.testing.assert_allclose(rec["x"], (1 + rec.t) * np.exp(-rec.t), rtol=0, atol=1e-14)


def test_multisine_is_simulated_exactly():
    ms = Multisine([2.0, 5.0, 11.0], amplitudes=[1.0, 0.5, 2.0])
    p = msd_parameters(natural_frequency=4.0, damping_ratio=0.1)
    rec = simulate_msd(natural_frequency=4.0, damping_ratio=0.1, input=ms, duration=3.0, dt=0.005)
    y = ivp_reference(
        [p["theta2"], p["theta1"]], 1.0, lambda s: ms(np.array([s]))[0], rec.t, (0.0, 0.0)
    )
    np.testing.assert_allclose(rec["x"], y[0], rtol=0, atol=1e-10)
    assert rec.metadata["method"].startswith("exact")


def test_third_order_model_matches_lsim_first_order_hold():
    # x''' + 3.2 x'' + 5 x' + 2 x = 0.5 u' + 2 u, random sampled input, linear between samples.
    a = [2.0, 5.0, 3.2, 1.0]
    b = [2.0, 0.5]
    t = np.arange(2001) * 0.005
    u = np.random.default_rng(3).standard_normal(t.size)
    rec = simulate_linear_ode((a, b), t, input=u, hold="foh")
    _, y_ref, _ = lsim((b[::-1], a[::-1]), u, t)
    np.testing.assert_allclose(rec["x"], y_ref, rtol=0, atol=1e-11 * np.abs(y_ref).max())


def test_third_order_model_matches_discrete_zero_order_hold():
    a = [2.0, 5.0, 3.2, 1.0]
    b = [2.0, 0.5]
    t = np.arange(1001) * 0.01
    u = np.random.default_rng(4).standard_normal(t.size)
    rec = simulate_linear_ode((a, b), t, input=u, hold="zoh")
    sysd = cont2discrete(tf2ss(b[::-1], a[::-1]), 0.01, method="zoh")  # scipy's own realisation
    _, y_ref, _ = dlsim(sysd, u, t)
    np.testing.assert_allclose(rec["x"], y_ref[:, 0], rtol=0, atol=1e-11 * np.abs(y_ref).max())


def test_biproper_model_feedthrough_matches_lsim():
    # (s² + 0.3 s + 4) x = (2 s² + s + 1) u: D = 2 feeds u straight through.
    a = [4.0, 0.3, 1.0]
    b = [1.0, 1.0, 2.0]
    t = np.arange(801) * 0.01
    u = np.sin(1.3 * t) + 0.2 * t
    rec = simulate_linear_ode((a, b), t, input=u)
    _, y_ref, _ = lsim((b[::-1], a[::-1]), u, t)
    np.testing.assert_allclose(rec["x"], y_ref, rtol=0, atol=1e-10)


def test_initial_conditions_are_output_derivatives_for_a_model_with_input_derivatives():
    # x'' + x' + 4x = u' + u with u = sin t: x(0)=0.4, ẋ(0)=-0.2 given as output derivatives.
    # Write z = x − w where ... simpler: integrate the ODE in y directly, treating u' known.
    a = [4.0, 1.0, 1.0]
    b = [1.0, 1.0]
    t = np.linspace(0.0, 6.0, 601)
    rec = simulate_linear_ode((a, b), t, input=Sinusoid(1.0, 1.0), x0=[0.4, -0.2])
    sol = solve_ivp(
        lambda s, y: [y[1], np.cos(s) + np.sin(s) - a[1] * y[1] - a[0] * y[0]],
        (0.0, 6.0),
        [0.4, -0.2],
        method="DOP853",
        t_eval=t,
        rtol=1e-12,
        atol=1e-12,
    )
    np.testing.assert_allclose(rec["x"], sol.y[0], rtol=0, atol=1e-10)


def test_jump_on_the_grid_keeps_state_continuous_and_follows_new_parameters():
    t_jump = 1.234
    rec = simulate_msd(
        mass=M,
        damping=C,
        stiffness=K,
        amplitude=PAPER_MSD["amplitude"],
        ratio=3.0,
        duration=3.0,
        dt=1e-3,
        jumps=[(t_jump, 900.0)],
        output_derivatives=True,
    )
    k = int(round(t_jump / 1e-3))
    assert rec.t[k] == pytest.approx(t_jump, abs=1e-12)
    # Restart from the state at the jump with the new stiffness: the runs must agree.
    restart = simulate_msd(
        mass=M,
        damping=C,
        stiffness=900.0,
        amplitude=PAPER_MSD["amplitude"],
        angular_frequency=3.0 * W0,
        t=rec.t[k:],
        x0=(rec["x"][k], rec["x_d1"][k]),
        output_derivatives=True,
    )
    np.testing.assert_allclose(rec["x"][k:], restart["x"], rtol=0, atol=1e-11)
    np.testing.assert_allclose(rec["x_d1"][k:], restart["x_d1"], rtol=0, atol=1e-9)
    # Before the jump the run equals the one without jump.
    plain = simulate_msd(
        mass=M,
        damping=C,
        stiffness=K,
        amplitude=PAPER_MSD["amplitude"],
        ratio=3.0,
        duration=3.0,
        dt=1e-3,
    )
    np.testing.assert_array_equal(rec["x"][:k], plain["x"][:k])
    assert rec["x"][k] == pytest.approx(plain["x"][k], abs=1e-12)
    assert not np.allclose(rec["x"][k + 50 :], plain["x"][k + 50 :])
    assert rec.metadata["jumps"][0]["natural_frequency"] == pytest.approx(np.sqrt(900.0 / M))


def test_jumps_between_samples_match_piecewise_solve_ivp():
    # Two jumps, both off the grid, one pair closer than a sample period.
    dt = 0.01
    jumps = [
        (0.5037, {"natural_frequency": 20.0}),
        (1.2031, {"damping_ratio": 0.3}),
        (1.2066, {"natural_frequency": 9.0}),
    ]
    rec = simulate_msd(
        natural_frequency=12.0,
        damping_ratio=0.05,
        amplitude=50.0,
        angular_frequency=15.0,
        duration=2.0,
        dt=dt,
        x0=(0.1, 0.0),
        jumps=jumps,
        output_derivatives=True,
    )
    thetas = [
        (2 * 0.05 * 12.0, 144.0),
        (2 * 0.05 * 12.0, 400.0),
        (2 * 0.3 * 20.0, 400.0),
        (2 * 0.3 * 20.0, 81.0),
    ]
    bounds = [0.0, 0.5037, 1.2031, 1.2066, 2.0]
    y = np.array([0.1, 0.0])
    xs, vs, ts = [], [], []
    for (th1, th2), lo, hi in zip(thetas, bounds[:-1], bounds[1:], strict=True):
        grid = rec.t[(rec.t >= lo) & (rec.t < hi)] if hi < 2.0 else rec.t[rec.t >= lo]
        sol = solve_ivp(
            lambda s, z, th1=th1, th2=th2: [z[1], 50 * np.sin(15 * s) - th1 * z[1] - th2 * z[0]],
            (lo, hi),
            y,
            method="DOP853",
            rtol=1e-12,
            atol=1e-13,
            dense_output=True,
        )
        if grid.size:
            xs.append(sol.sol(grid)[0])
            vs.append(sol.sol(grid)[1])
            ts.append(grid)
        y = sol.y[:, -1]
    np.testing.assert_allclose(np.concatenate(ts), rec.t)
    np.testing.assert_allclose(rec["x"], np.concatenate(xs), rtol=0, atol=1e-10)
    np.testing.assert_allclose(rec["x_d1"], np.concatenate(vs), rtol=0, atol=1e-8)


def test_noise_at_snr_and_same_seed_same_bits():
    a = msd_paper_scenario(ratio=10.0, snr_db=25.0, seed=7)
    b = msd_paper_scenario(ratio=10.0, snr_db=25.0, seed=7)
    c = msd_paper_scenario(ratio=10.0, snr_db=25.0, seed=8)
    np.testing.assert_array_equal(a["x"], b["x"])
    assert not np.array_equal(a["x"], c["x"])
    clean = msd_paper_scenario(ratio=10.0)
    np.testing.assert_array_equal(a["x_true"], clean["x"])
    assert "x_true" not in clean
    noise = a["x"] - a["x_true"]
    realised = 10 * np.log10(np.sum(clean["x"] ** 2) / np.sum(noise**2))
    # 5001 samples: the realised SNR scatters by about (10/ln 10)·sqrt(2/5001) = 0.087 dB.
    assert realised == pytest.approx(25.0, abs=0.35)
    assert a.metadata["noise"]["seed"] == 7
    assert a.unit("x") == "m" and a.unit("u") == "m/s^2"


def test_paper_disturbance_adds_aliased_sinusoid():
    rec = msd_paper_scenario(ratio=10.0, disturbance="paper")
    w2 = 500 * W0
    np.testing.assert_allclose(rec["x"] - rec["x_true"], 0.1 * np.sin(w2 * rec.t), atol=1e-12)
    alias = rec.metadata["disturbance"]["alias_angular_frequency"]
    # sin(ω2 k Δ) = −sin(ω_a k Δ) with ω_a = 2π/Δ − ω2 (ω2 lies between Nyquist and ω_s)
    assert alias == pytest.approx(2 * np.pi / 1e-3 - w2, rel=1e-12)
    np.testing.assert_allclose(np.sin(w2 * rec.t), -np.sin(alias * rec.t), atol=1e-9)


def test_force_amplitude_and_amplitude_agree():
    by_force = simulate_msd(mass=M, damping=C, stiffness=K, force_amplitude=1000.0, ratio=1.0)
    by_u = msd_paper_scenario(ratio=1.0)
    np.testing.assert_array_equal(by_force["u"], by_u["u"])
    np.testing.assert_allclose(by_force["x"], by_u["x"], rtol=0, atol=1e-12)
    assert np.abs(by_u["u"]).max() == pytest.approx(1000 / 3, rel=1e-6)


def test_inputs_are_not_mutated_and_callable_equals_array():
    t = np.arange(501) * 0.002
    u = np.cos(3 * t)
    before = u.copy()
    r1 = simulate_linear_ode(([4.0, 0.5, 1.0], [1.0]), t, input=u, hold="zoh")
    r2 = simulate_linear_ode(([4.0, 0.5, 1.0], [1.0]), t, input=lambda s: np.cos(3 * s), hold="zoh")
    np.testing.assert_array_equal(u, before)
    np.testing.assert_array_equal(r1["x"], r2["x"])


class _TwoParameterModel:
    """A stand-in for the models package's LinearODEModel: the contract's duck type."""

    parameter_names = ("theta1", "theta2")
    parameters = {"theta1": 0.4, "theta2": 9.0}

    def coefficients(self, params):
        return np.array([params["theta2"], params["theta1"], 1.0]), np.array([1.0])


def test_model_objects_and_partial_parameter_overrides():
    model = _TwoParameterModel()
    rec = simulate_linear_ode(
        model,
        duration=2.0,
        dt=0.01,
        input=Sinusoid(1.0, 2.0),
        params={"theta2": 16.0},
        jumps=[(1.0, {"theta1": 1.0})],
        output_derivatives=True,
    )
    direct = simulate_linear_ode(
        ([16.0, 0.4, 1.0], [1.0]),
        duration=2.0,
        dt=0.01,
        input=Sinusoid(1.0, 2.0),
        jumps=[(1.0, ([16.0, 1.0, 1.0], [1.0]))],
    )
    np.testing.assert_array_equal(rec["x"], direct["x"])
    with pytest.raises(InputError, match="unknown parameter"):
        simulate_linear_ode(model, duration=1.0, dt=0.1, params={"omega": 1.0})


def test_state_space_realisation():
    A, B, Cm, D = linear_ode_state_space([6.0, 11.0, 6.0, 1.0], [2.0, 1.0])
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(A).real), [-3.0, -2.0, -1.0])
    # transfer function at s = 1j: C (sI − A)^{-1} B + D = (2 + s)/(s³ + 6s² + 11s + 6)
    s = 1j
    h = Cm @ np.linalg.solve(s * np.eye(3) - A, B) + D
    assert h == pytest.approx((2 + s) / (s**3 + 6 * s**2 + 11 * s + 6))


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"hold": "cubic", "input": np.zeros(11)}, InputError, "hold must be"),
        ({"x0": [1.0, 2.0, 3.0]}, ShapeError, "x0 must hold the 2"),
        (
            {"jumps": [(5.0, ([1.0, 0.0, 1.0], [1.0]))]},
            InputError,
            "outside the simulated interval",
        ),
        ({"input": np.zeros(7)}, ShapeError, "one value per time sample"),
        ({"snr_db": 20.0, "noise_std": 0.1}, InputError, "at most one of snr_db"),
        ({"disturbance": (1.0,)}, InputError, "disturbance must be a pair"),
    ],
)
def test_error_paths(kwargs, error, match):
    with pytest.raises(error, match=match):
        simulate_linear_ode(([1.0, 0.0, 1.0], [1.0]), duration=1.0, dt=0.1, **kwargs)


def test_model_and_grid_errors():
    with pytest.raises(InputError, match="improper"):
        simulate_linear_ode(([1.0, 1.0], [1.0, 1.0, 1.0]), duration=1.0, dt=0.1)
    with pytest.raises(InputError, match="leading coefficient"):
        simulate_linear_ode(([1.0, 1.0, 0.0], [1.0]), duration=1.0, dt=0.1)
    with pytest.raises(SamplingError, match="whole number of sample periods"):
        simulate_linear_ode(([1.0, 1.0], [1.0]), duration=1.0, dt=0.3)
    with pytest.raises(InputError, match="common root"):
        simulate_linear_ode(([2.0, 3.0, 1.0], [1.0, 1.0]), duration=1.0, dt=0.1)  # (s+1) cancels
    with pytest.raises(InputError, match="needs the mass"):
        simulate_msd(natural_frequency=3.0, damping_ratio=0.1, force_amplitude=1.0, ratio=1.0)
    with pytest.raises(InputError, match="exactly one of amplitude"):
        simulate_msd(mass=M, damping=C, stiffness=K, ratio=1.0)
    with pytest.raises(InputError, match="exactly one of angular_frequency"):
        simulate_msd(mass=M, damping=C, stiffness=K, amplitude=1.0)
    with pytest.raises(InputError, match="stiffness, which needs the mass"):
        simulate_msd(
            natural_frequency=3.0, damping_ratio=0.1, amplitude=1.0, ratio=1.0, jumps=[(1.0, 5.0)]
        )
    with pytest.raises(InputError, match="either by damping and stiffness"):
        msd_parameters(mass=1.0, stiffness=2.0, natural_frequency=3.0)


def test_builtin_msd_model_object_gives_the_same_run():
    from physid.models import load_model

    by_model = simulate_linear_ode(
        load_model("msd"), duration=5.0, dt=1e-3, input=Sinusoid(PAPER_MSD["amplitude"], 10 * W0)
    )
    np.testing.assert_array_equal(by_model["x"], msd_paper_scenario(ratio=10.0)["x"])
    # the force-input variant (b0 = 1/m) driven by the force 1000 N gives the same motion
    by_force = simulate_linear_ode(
        load_model("msd", input="force"), duration=5.0, dt=1e-3, input=Sinusoid(1000.0, 10 * W0)
    )
    np.testing.assert_allclose(by_force["x"], by_model["x"], rtol=0, atol=1e-13)


def test_msd_plot_draws_measured_and_clean_position():
    rec = msd_paper_scenario(ratio=10.0, snr_db=25.0, seed=1)
    fig = rec.plot()
    ax_x, ax_u = fig.axes
    assert len(ax_x.lines) == 2 and len(ax_u.lines) == 1
    np.testing.assert_array_equal(ax_x.lines[1].get_ydata(), rec["x_true"])
    assert "SNR = 25 dB" in ax_x.get_title() and "Z = ω1/ω0 = 10" in ax_x.get_title()
    generic = rec.plot(names=["u"])  # with names: the generic channel plot
    assert len(generic.axes) == 1


def test_badly_scaled_fourth_order_model_is_accepted_and_matches_lsim():
    # poles at -1000, -2000, -3000±10j rad/s and zeros at -500, -5000: coefficients span 13 decades,
    # which must not be mistaken for a pole-zero cancellation, nor cost accuracy (the companion
    # matrix is balanced before expm; without balancing the error was 3e-6 relative).
    w = 1000.0
    a = np.poly([-w, -2 * w, -3 * w + 10j, -3 * w - 10j]).real[::-1]
    b = np.poly([-0.5 * w, -5 * w]).real[::-1] / w**2
    t = np.arange(1001) * 1e-5
    u = np.sin(3000 * t)
    rec = simulate_linear_ode((a, b), t, input=u)
    _, y_ref, _ = lsim((b[::-1], a[::-1]), u, t)
    np.testing.assert_allclose(rec["x"], y_ref, rtol=0, atol=1e-9 * np.abs(y_ref).max())


def test_simulate_msd_rejects_phase_with_an_explicit_input():
    with pytest.raises(InputError, match="phase=0.3 applies only to the built-in sinusoid"):
        simulate_msd(
            natural_frequency=2.0,
            damping_ratio=0.1,
            input=np.zeros(11),
            phase=0.3,
            duration=1.0,
            dt=0.1,
        )


def test_a_seed_without_noise_is_refused_not_ignored():
    from physid.models import load_model

    with pytest.raises(InputError, match="only seeds the measurement noise"):
        simulate_linear_ode(
            load_model("msd"), duration=0.1, dt=1e-3, input=Sinusoid(1.0, 5.0), rng=3
        )
