"""Variance factor K(Z, λ, ω0, T_s, m, k) and the optimal input ratio (Oueslati et al., §3.B–D)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sp

from physid import InputError
from physid.analysis.input_design import (
    PAPER_NATURAL_FREQUENCY,
    design_input,
    optimal_ratio,
    resonant_response,
    variance_factor,
    variance_factor_printed,
)
from physid.estimators.recursive import weighted_ls_path

W0 = PAPER_NATURAL_FREQUENCY
PAPER = dict(natural_frequency=W0, sample_period=1e-3, init_samples=3, samples=100)


def test_eq8_solves_the_undamped_msd_and_its_resonant_limit():
    t, w0, z, A = sp.symbols("t omega0 Z A1", positive=True)
    x = A * (z * w0 * sp.sin(w0 * t) - w0 * sp.sin(z * w0 * t)) / (w0 * ((z * w0) ** 2 - w0**2))
    assert sp.simplify(sp.diff(x, t, 2) + w0**2 * x - A * sp.sin(z * w0 * t)) == 0
    assert sp.simplify(x.subs(t, 0)) == 0 and sp.simplify(sp.diff(x, t).subs(t, 0)) == 0
    limit = sp.limit(x / A, z, 1)
    assert sp.simplify(limit - (sp.sin(w0 * t) - w0 * t * sp.cos(w0 * t)) / (2 * w0**2)) == 0


def test_stable_form_equals_eq8_and_is_continuous_through_resonance():
    t = np.linspace(0, 3, 301)
    for Z in (0.01, 0.5, 0.9, 1.3, 2.0, 7.0):
        a = W0 * t
        eq8 = (Z * np.sin(a) - np.sin(Z * a)) / (W0**2 * (Z**2 - 1))
        np.testing.assert_allclose(resonant_response(Z, t, W0), eq8, rtol=1e-10, atol=1e-16)
    resonant = (np.sin(W0 * t) - W0 * t * np.cos(W0 * t)) / (2 * W0**2)
    np.testing.assert_allclose(resonant_response(1.0, t, W0), resonant, rtol=1e-13, atol=1e-18)
    for eps in (1e-6, 1e-9, -1e-12):  # eq. 8 loses all digits here; the stable form does not
        np.testing.assert_allclose(
            resonant_response(1 + eps, t, W0),
            resonant,
            rtol=0,
            atol=10 * abs(eps) * 3 * t.max() ** 2,
        )


@pytest.mark.parametrize(("Z", "lam"), [(0.5, 1.0), (1.0, 0.95), (2.0, 0.98)])
def test_variance_factor_matches_monte_carlo_of_the_recursion(Z, lam):
    """Rows Y_i = θ2 x_i + ρ_i, i = m+1..k, regressed by the batch RLS (eqs. 3-4, one OLS row)."""
    rng = np.random.default_rng(20110901)
    trials, sigma, A1, theta2 = 20_000, 1e-3, 111.1111, W0**2
    t = np.arange(4, 101) * 1e-3
    x = A1 * resonant_response(Z, t, W0)
    Y = theta2 * x + sigma * rng.standard_normal((trials, t.size))
    X = np.broadcast_to(x[None, :, None], (trials, t.size, 1))
    theta, _, _ = weighted_ls_path(X, Y, forgetting=lam, init_end=0)
    empirical = np.var(theta[:, -1, 0]) * A1**2 / sigma**2
    K = float(variance_factor(Z, lam, **PAPER))
    # relative standard error of a variance from N normal draws: √(2/N) = 1 %; allow 3.5 σ
    assert empirical / K == pytest.approx(1.0, abs=0.035)
    # the printed eq. 12 (spurious ω0) is a different function: far off at λ = 1
    if lam == 1.0:
        assert float(variance_factor_printed(Z, **PAPER)) / empirical > 10 or (
            float(variance_factor_printed(Z, **PAPER)) / empirical < 0.1
        )


def test_eq13_is_consistent_with_eq12_at_lambda_one():
    Z = np.array([0.1, 0.7, 1.5, 2.0])
    t = np.arange(4, 101) * 1e-3
    h = Z[:, None] * np.sin(W0 * t) - np.sin(Z[:, None] * W0 * t)
    eq13 = W0**4 * (Z**2 - 1) ** 2 / np.sum(h**2, axis=1)
    np.testing.assert_allclose(variance_factor(Z, 1.0, **PAPER), eq13, rtol=1e-12)


def test_shapes_vectorise_over_ratio_and_forgetting():
    K = variance_factor(np.linspace(0.1, 2, 7), [0.95, 0.99, 1.0], **PAPER)
    assert K.shape == (3, 7)
    assert variance_factor(1.0, 1.0, **PAPER).shape == ()
    one = [float(variance_factor(z, 0.99, **PAPER)) for z in np.linspace(0.1, 2, 7)]
    np.testing.assert_allclose(K[1], one, rtol=1e-12)


def test_paper_horizon_optimum_is_the_upper_end_not_resonance():
    """k = 100, m = 3: K falls monotonically on [0.01, 2] for every λ; λ = 1 is best."""
    lams = np.array([0.95, 0.98, 0.99, 1.0])
    K = variance_factor(np.linspace(0.01, 2, 500), lams, **PAPER)
    assert np.all(np.diff(K, axis=1) < 0)
    z, k_opt, edge = optimal_ratio(lams, ratio_range=(0.01, 2.0), **PAPER)
    np.testing.assert_allclose(z, 2.0, atol=1e-9)
    assert edge.all() and np.all(np.diff(k_opt) < 0)  # smaller K as λ → 1
    # near the start g ≈ Z a³ / (6 ω0²): K(1)/K(2) ≈ 4 for short horizons (here 0.1 s, a ≤ 1.15)
    ratio = float(variance_factor(1.0, 1.0, **PAPER) / variance_factor(2.0, 1.0, **PAPER))
    assert 2.5 < ratio < 4.0


def test_optimum_moves_to_resonance_as_the_horizon_grows():
    long = {**PAPER, "samples": 5000}  # 5 s, 9 natural periods
    z_long, _, edge = optimal_ratio(1.0, ratio_range=(0.01, 2.0), **long)
    assert abs(float(z_long) - 1.0) < 5e-3 and not edge
    # the bounded refinement agrees with a much finer grid around it (spacing 1e-5)
    fine = np.linspace(float(z_long) - 2e-3, float(z_long) + 2e-3, 401)
    assert abs(fine[np.argmin(variance_factor(fine, 1.0, **long))] - float(z_long)) < 1e-5
    z_wide, _, edge = optimal_ratio(1.0, ratio_range=(0.01, 6.0), **PAPER)
    assert 2.9 < float(z_wide) < 3.4 and not edge  # k = 100: interior optimum beyond the range


def test_design_input_result_json_and_plot():
    res = design_input(forgetting=[0.95, 1.0], n_ratios=50, horizons=[100, 1000])
    assert res.variance_factor.shape == (2, 50) and res.horizon_variance_factor.shape == (2, 50)
    assert res.optimal_ratio == pytest.approx((2.0, 2.0))
    assert "widen the ratio range" in res.message and res.success
    d = res.to_dict()
    json.dumps(d, allow_nan=False)
    assert res.optimal_ratio_by_forgetting() == {"0.95": res.optimal_ratio[0], "1": 2.0}
    assert "optimal_ratio(lambda=0.95)" in res.summary()
    fig = res.plot()
    assert len(fig.axes) == 2


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"forgetting": [0.9, 1.2]}, r"forgetting must lie in \(0, 1\]; got \[1.2\]"),
        ({"forgetting": [0.0]}, r"forgetting must lie in \(0, 1\]"),
        ({"ratio_range": (2.0, 1.0)}, "LO < HI"),
        ({"ratio_range": (-1.0, 1.0)}, "LO < HI"),
        ({"samples": 3}, "init_samples < samples"),
        ({"sample_period": 0.0}, "sample_period must be finite and > 0"),
    ],
)
def test_design_input_errors(kwargs, match):
    with pytest.raises(InputError, match=match):
        design_input(**kwargs)
