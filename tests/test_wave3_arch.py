"""Wave 3, room arch: the layout moves of issue 12 and the hardening of issue 16, pinned by numbers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

import physid.estimators.recursive as recursive
from physid.filters import (
    StreamingStateVariableFilter,
    state_variable_filter,
    svf_transient_samples,
)


# ------------------------------------------------------------------ state-variable filter move
def test_svf_lives_in_filters_and_recursive_uses_the_same_objects():
    assert state_variable_filter.__module__ == "physid.filters.state_variable"
    assert recursive.state_variable_filter is state_variable_filter
    assert recursive.StreamingStateVariableFilter is StreamingStateVariableFilter
    assert recursive.svf_transient_samples is svf_transient_samples


def test_svf_dc_gain_is_one_and_derivatives_of_a_constant_vanish():
    d = state_variable_filter(np.full(4000, 2.5), 1e-3, 20.0, n_derivatives=2, filter_order=3)
    np.testing.assert_allclose(d[-1], [2.5, 0.0, 0.0], rtol=0, atol=1e-8)


@pytest.mark.parametrize("dt", [1e-3, 5e-4])
def test_svf_of_a_sinusoid_is_the_analytic_steady_state(dt):
    """w^(i) = Im((jω)^i F(jω) e^{jωt}) after the transient, F the analog Butterworth.

    The FOH discretisation is exact for piecewise-linear input; a sine differs from its chords by
    the interpolation error, relative size (ω dt)² / 12 (1.32e-5 at 1 ms, 3.3e-6 at 0.5 ms), so the
    tolerance is 1.1 (ω dt)² / 12 of each derivative's amplitude, and halving dt divides it by 4.
    """
    fc, order, w0 = 20.0, 3, 2 * np.pi * 2.0
    t = np.arange(int(round(2.0 / dt))) * dt
    d = state_variable_filter(np.sin(w0 * t), dt, fc, n_derivatives=2, filter_order=order)
    b, a = signal.butter(order, 2 * np.pi * fc, analog=True)
    H = signal.freqs(b, a, [w0])[1][0]
    keep = t > 0.5  # 500 ms ≫ svf_transient_samples(20, dt, 3) samples
    assert svf_transient_samples(fc, dt, order) * dt < 0.5
    tol = 1.1 * (w0 * dt) ** 2 / 12
    for i in range(3):
        ref = np.imag((1j * w0) ** i * H * np.exp(1j * w0 * t))
        err = np.abs(d[keep, i] - ref[keep]).max() / (w0**i * abs(H))
        assert err < tol, (i, err, tol)
        assert err > 0.5 * (w0 * dt) ** 2 / 12  # the error is the hold's, not something smaller
