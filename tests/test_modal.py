"""Modal parameters of structures against analytic eigenvalues, with delta-method errors."""

import numpy as np
import pytest

from physid.errors import InputError
from physid.models.library import model_from_spec
from physid.models.spec import parse_model_text

CHAIN3 = """
kind = "structure"
name = "chain3"
[parameters]
m = { value = 1.5, unit = "kg" }
k = { value = 2000.0, unit = "N/m" }
b = { value = 0.002, unit = "s" }
[[masses]]
name = "a"
mass = "m"
[[masses]]
name = "b"
mass = "m"
[[masses]]
name = "c"
mass = "m"
[[springs]]
between = ["ground", "a"]
stiffness = "k"
[[springs]]
between = ["a", "b"]
stiffness = "k"
[[springs]]
between = ["b", "c"]
stiffness = "k"
[[dampers]]
between = ["ground", "a"]
damping = "b*k"
[[dampers]]
between = ["a", "b"]
damping = "b*k"
[[dampers]]
between = ["b", "c"]
damping = "b*k"
[[forces]]
on = "a"
channel = "F"
[[outputs]]
displacement = "c"
"""


def _model():
    return model_from_spec(parse_model_text(CHAIN3))


def test_three_mass_chain_against_the_analytic_eigenvalues():
    # fixed-free chain of equal masses: ω_j = 2 √(k/m) sin((2j − 1) π / (2 (2N + 1))), N = 3;
    # stiffness-proportional damping C = b K: ζ_j = b ω_j / 2
    model = _model()
    modes = model.modal()
    j = np.arange(1, 4)
    omega = 2 * np.sqrt(2000 / 1.5) * np.sin((2 * j - 1) * np.pi / 14)
    assert np.max(np.abs(modes.frequency - omega) / omega) < 1e-9
    assert np.max(np.abs(modes.damping - 0.002 * omega / 2)) < 1e-9
    # the undamped mode shapes: K φ = ω² M φ, real for proportional damping
    M, C, K = model.matrices()
    for i in range(3):
        phi = modes.shapes[:, i]
        assert np.max(np.abs(phi.imag)) < 1e-9
        assert np.allclose(K @ phi.real, omega[i] ** 2 * M @ phi.real, rtol=1e-8)


def test_delta_method_matches_a_monte_carlo_of_the_parameters():
    model = _model()
    names = ("m", "k", "b")
    cov = np.diag([0.01, 20.0, 1e-5]) ** 2
    modes = model.modal(covariance=cov, names=names)
    rng = np.random.default_rng(0)
    draws = rng.multivariate_normal([1.5, 2000.0, 0.002], cov, size=4000)
    w = np.array([model.modal(dict(zip(names, d, strict=True))).frequency for d in draws])
    z = np.array([model.modal(dict(zip(names, d, strict=True))).damping for d in draws])
    assert np.allclose(w.std(axis=0), modes.frequency_stderr, rtol=0.06)
    assert np.allclose(z.std(axis=0), modes.damping_stderr, rtol=0.06)


def test_covariance_of_the_wrong_shape_is_refused():
    with pytest.raises(InputError, match=r"covariance must be 3×3"):
        _model().modal(covariance=np.eye(2), names=("m", "k", "b"))


def test_frequency_response_is_the_transfer_function():
    from physid.analysis.modal import frequency_response

    model = _model()
    w = np.array([1.0, 30.0, 90.0])
    fr = frequency_response(model, w)
    M, C, K = model.matrices()
    for i, wi in enumerate(w):
        H = np.linalg.solve(-(wi**2) * M + 1j * wi * C + K, [1.0, 0.0, 0.0])[2]
        assert abs(fr.response[i, 0, 0] - H) < 1e-12 * abs(H)


def test_delta_method_jacobian_matches_the_analytic_derivatives():
    """ω_j = 2 √(k/m) sin((2j − 1)π/14) and ζ_j = b ω_j / 2 give ∂ω/∂(m, k, b) and ∂ζ/∂(m, k, b)
    in closed form; the delta method's errors with a correlated covariance equal √(g Σ gᵀ)."""
    model = _model()
    m, k, b = 1.5, 2000.0, 0.002
    j = np.arange(1, 4)
    omega = 2 * np.sqrt(k / m) * np.sin((2 * j - 1) * np.pi / 14)
    g_w = np.column_stack([-omega / (2 * m), omega / (2 * k), np.zeros(3)])
    g_z = np.column_stack([b * g_w[:, 0] / 2, b * g_w[:, 1] / 2, omega / 2])
    sd = np.array([0.01, 20.0, 1e-5])
    corr = np.array([[1.0, 0.8, -0.3], [0.8, 1.0, 0.2], [-0.3, 0.2, 1.0]])
    cov = corr * np.outer(sd, sd)
    modes = model.modal(covariance=cov, names=("m", "k", "b"))
    expected_w = np.sqrt(np.einsum("ip,pq,iq->i", g_w, cov, g_w))
    expected_z = np.sqrt(np.einsum("ip,pq,iq->i", g_z, cov, g_z))
    assert np.allclose(modes.frequency_stderr, expected_w, rtol=1e-6)
    assert np.allclose(modes.damping_stderr, expected_z, rtol=1e-6)
