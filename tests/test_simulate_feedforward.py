"""PD plus gravity (and friction) feed-forward in the closed loop (simulate/feedforward.py)."""

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import physid
from physid.errors import InputError
from physid.simulate import simulate_closed_loop

URDF = Path(__file__).parent / "data" / "planar2.urdf"


def test_gravity_feedforward_removes_the_steady_state_error():
    """A constant reference: PD alone settles at r − Kp⁻¹ g(q); PD + g(q) settles at r."""
    model = physid.load_model(URDF)
    r = np.array([0.6, -0.4])
    kw = dict(kp=[200.0, 100.0], kd=[30.0, 15.0], reference=r, duration=6.0, dt=0.01)
    pd = simulate_closed_loop(model, **kw)
    ff = simulate_closed_loop(model, feedforward="gravity", **kw)
    q_pd = pd.select(["q1", "q2"])[-1]
    q_ff = ff.select(["q1", "q2"])[-1]
    g = model.gravity_forces(q_pd[None])[0]
    assert np.allclose(r - q_pd, g / np.array([200.0, 100.0]), atol=1e-5)  # PD: Kp (r − q) = g
    assert np.max(np.abs(r - q_pd)) > 1e-2
    assert np.max(np.abs(q_ff - r)) < 1e-6
    assert ff.metadata["controller"] == "tau = Kp (r - q) - Kd qd + g(q)"
    # the recorded torque is what the controller applied: PD + g(q)
    tau = ff.select(["tau1", "tau2"])[-1]
    assert np.allclose(tau, model.gravity_forces(q_ff[None])[0], atol=1e-4)


@pytest.mark.parametrize("kind", ["gravity", "gravity+friction"])
def test_feedforward_loop_against_a_direct_integration(kind, tmp_path):
    """The compensated-plant simulation equals integrating M q̈ = PD + ff − h directly (a
    2-link arm with viscous friction)."""
    (tmp_path / "planar2.urdf").write_text(URDF.read_text())
    (tmp_path / "arm.toml").write_text(
        'extends = "planar2.urdf"\n[joints.shoulder]\nviscous = 0.5\n[joints.elbow]\nviscous = 0.3\n'
    )
    model = physid.load_model(tmp_path / "arm.toml")
    theta = None
    kp, kd = np.array([150.0, 80.0]), np.array([20.0, 10.0])

    def ref(t):
        return np.array([0.5 * np.sin(t), 0.3 * np.cos(2 * t) - 0.3])

    rec = simulate_closed_loop(
        model, kp=kp, kd=kd, reference=ref, duration=0.5, dt=0.01, params=theta,
        feedforward=kind, coulomb_smoothing=0.05,
    )  # fmt: skip
    th = model.parameter_vector(theta)
    no_friction = th.copy()
    for i, name in enumerate(model.parameter_names):
        if name.rstrip("0123456789") in ("Fv", "Fc"):
            no_friction[i] = 0.0

    def rhs(t, y):
        q, qd = y[None, :2], y[None, 2:]
        zero = np.zeros_like(q)
        h = model.inverse_dynamics(q, qd, zero, th)[0]
        ff = model.gravity_forces(q, th)[0]
        if kind == "gravity+friction":
            ff = (
                ff
                + h
                - model.inverse_dynamics(q, qd, zero, no_friction)[0]
                - (
                    model.inverse_dynamics(q, zero, zero, th)[0]
                    - model.inverse_dynamics(q, zero, zero, no_friction)[0]
                )
            )
        tau = kp * (ref(t) - y[:2]) - kd * y[2:] + ff
        return np.concatenate([y[2:], np.linalg.solve(model.mass_matrix(q, th)[0], tau - h)])

    t = rec.t
    sol = solve_ivp(rhs, (t[0], t[-1]), np.zeros(4), t_eval=t, rtol=1e-8, atol=1e-10)
    q = rec.select(["q1", "q2"])
    assert np.max(np.abs(q - sol.y[:2].T)) < 1e-5


def test_feedforward_needs_a_rigid_body_model():
    model = physid.load_model("manipulator")
    with pytest.raises(InputError, match=r"feedforward='gravity' needs a rigid-body model"):
        simulate_closed_loop(model, kp=1.0, kd=1.0, reference=np.zeros(4), duration=0.1,
                             dt=0.01, feedforward="gravity")  # fmt: skip
    with pytest.raises(InputError, match=r"feedforward must be one of"):
        simulate_closed_loop(model, kp=1.0, kd=1.0, reference=np.zeros(4), duration=0.1,
                             dt=0.01, feedforward="computed-torque")  # fmt: skip


def test_validate_resimulates_the_logged_controller(tmp_path):
    """simulate --feedforward gravity → identify → validate: the closed-loop re-simulation
    uses the recording's controller (PD + g(q)) and says so; noise-free, it fits to 1e-4."""
    import contextlib
    import io

    from physid.cli import main

    files = {k: str(tmp_path / f"{k}.csv") for k in ("fit", "held")}
    quiet = contextlib.redirect_stderr(io.StringIO())
    with contextlib.redirect_stdout(io.StringIO()), quiet:
        for seed, path in ((None, files["fit"]), (3, files["held"])):
            extra = [] if seed is None else ["--noise-std", "1e-6", "--seed", str(seed)]
            argv = ["simulate", "model", str(URDF), "--feedforward", "gravity", "--duration", "10"]
            assert main([*argv, *extra, "--out", path]) == 0
        saved = str(tmp_path / "fit.json")
        argv = ["identify", files["fit"], "--model", str(URDF), "--method", "idim-ols"]
        assert main([*argv, "--save", saved]) == 0
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        assert main(["validate", saved, files["held"], "--json"]) == 0
    import json

    report = json.loads(out.getvalue())
    assert "controller tau = Kp (r - q) - Kd qd + g(q)" in json.dumps(report)
    assert max(report["output_relative_error"].values()) < 1e-4
