"""Linear ODE models and the mass–spring–damper conversions."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from physid.errors import InputError, ShapeError
from physid.models import (
    LinearODEModel,
    load_model,
    msd_from_physical,
    msd_model,
    natural_frequency_damping,
    physical_from_theta,
    theta_from_natural,
)


def test_msd_defaults_follow_the_paper():
    """Oueslati et al., section 4: m = 3 kg, c = 0.05 N·s/m, k = 400 N/m; u = F/m (b0 = 1)."""
    model = load_model("msd")
    assert model.name == "msd"
    assert model.order == 2 and model.input_order == 0
    assert model.a_names == ("theta2", "theta1")
    assert model.b_names == ("b0",)
    assert model.coefficient_names == ("theta2", "theta1", "b0")
    assert model.unknown == ("theta1", "theta2")
    p = model.parameters
    assert p["theta1"] == pytest.approx(0.05 / 3, rel=1e-15)
    assert p["theta2"] == pytest.approx(400 / 3, rel=1e-15)
    assert p["b0"] == 1.0
    a, b = model.coefficients()
    np.testing.assert_allclose(a, [400 / 3, 0.05 / 3, 1.0], rtol=1e-15)
    np.testing.assert_allclose(b, [1.0])


def test_msd_force_input_has_gain_one_over_mass():
    model = msd_model(mass=2.0, damping=0.4, stiffness=50.0, input="force")
    # the force form carries its physical parameters m, c, k besides the coefficients
    assert model.parameters == pytest.approx(
        {"theta2": 25.0, "theta1": 0.2, "b0": 0.5, "m": 2.0, "c": 0.4, "k": 50.0}
    )
    assert model.unknown == ("theta2", "theta1", "b0")
    assert load_model("msd", mass=2.0, input="force").parameters["b0"] == 0.5


def test_state_space_has_the_model_transfer_function():
    model = LinearODEModel(
        "third",
        ("a0", "a1", "a2"),
        ("b0", "b1"),
        {"a0": 6.0, "a1": 11.0, "a2": 6.0, "b0": 2.0, "b1": 0.5},
    )
    A, B, C, D = model.state_space()
    num, den = signal.ss2tf(A, B, C, D)
    # G(s) = (0.5 s + 2) / (s³ + 6 s² + 11 s + 6)
    np.testing.assert_allclose(den, [1, 6, 11, 6], atol=1e-12)
    np.testing.assert_allclose(num[0][-2:], [0.5, 2.0], atol=1e-12)
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(A).real), [-3, -2, -1], atol=1e-9)
    # steady-state gain of the MSD: x = b0 u / θ2
    msd = msd_model()
    A, B, C, D = msd.state_space({"theta2": 100.0})
    assert (-C @ np.linalg.solve(A, B))[0, 0] == pytest.approx(1 / 100.0)


def test_params_override_and_errors():
    model = msd_model()
    a, _ = model.coefficients({"theta1": 0.5})
    assert a[1] == 0.5
    a, b = model.coefficients([10.0, 1.0, 2.0])  # ordered like parameter_names
    np.testing.assert_allclose(a, [10.0, 1.0, 1.0])
    np.testing.assert_allclose(b, [2.0])
    with pytest.raises(InputError, match=r"unknown name\(s\) \['omega'\]"):
        model.coefficients({"omega": 1.0})
    with pytest.raises(ShapeError, match="must have 3 entries"):
        model.coefficients([1.0])
    with pytest.raises(InputError, match="input must be 'normalised'"):
        msd_model(input="newton")
    with pytest.raises(InputError, match="mass must be finite and > 0"):
        msd_model(mass=0.0)
    with pytest.raises(InputError, match="input order m = 2 must be below the order n = 2"):
        LinearODEModel(
            "bad",
            ("a0", "a1"),
            ("b0", "b1", "b2"),
            dict.fromkeys(["a0", "a1", "b0", "b1", "b2"], 1.0),
        )
    with pytest.raises(InputError, match=r"unknown option\(s\) \['kinetic'\]"):
        load_model("msd", kinetic="paper")


def test_conversions_round_trip():
    p = msd_from_physical(3.0, 0.05, 400.0)
    omega0, zeta = natural_frequency_damping(p["theta1"], p["theta2"])
    assert omega0 == pytest.approx(np.sqrt(400 / 3), rel=1e-15)
    assert zeta == pytest.approx(0.05 / (2 * np.sqrt(400 * 3)), rel=1e-14)  # ζ = c / (2√(km))
    t1, t2 = theta_from_natural(omega0, zeta)
    assert (t1, t2) == pytest.approx((p["theta1"], p["theta2"]), rel=1e-14)
    back = physical_from_theta(t1, t2, 3.0)
    assert back == pytest.approx({"mass": 3.0, "damping": 0.05, "stiffness": 400.0}, rel=1e-14)


def test_natural_frequency_damping_is_vectorised_with_nan_for_unstable():
    omega0, zeta = natural_frequency_damping([0.2, 1.0, 1.0], [4.0, 0.0, -1.0])
    np.testing.assert_allclose(omega0[0], 2.0)
    np.testing.assert_allclose(zeta[0], 0.05)
    assert np.isnan(omega0[1:]).all() and np.isnan(zeta[1:]).all()
    t1, t2 = theta_from_natural(np.array([1.0, 2.0]), np.array([0.5, 0.1]))
    np.testing.assert_allclose(t1, [1.0, 0.4])
    np.testing.assert_allclose(t2, [1.0, 4.0])


def test_split_coefficients_default_unknowns_exclude_known_names():
    model = msd_model()
    unknown, values = model.split_coefficients(None, {"theta1": 0.0166})
    assert unknown == ("theta2",)
    assert values["theta1"] == 0.0166 and values["b0"] == 1.0
    # explicit unknown + known on the same name is still an error
    with pytest.raises(InputError, match="cannot be both unknown and known"):
        model.split_coefficients(("theta1", "theta2"), {"theta1": 0.0166})
    with pytest.raises(InputError, match="nothing is left to estimate"):
        model.split_coefficients(None, {"theta1": 0.1, "theta2": 100.0})
