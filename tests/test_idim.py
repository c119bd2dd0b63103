"""IDIM-OLS / WLS / IV on the paper's arm (Cedro & Janecki) driven by a smooth multisine.

Kinds of test (docs STYLE.md): analytic (noise-free recovery of the base parameters), equivalence
of forms (stacked recordings equal one long regression; the HAC sandwich with lag 0 equals the
White form), an independent implementation (the decimation equals scipy.signal.decimate on
the kept rows), statistics with fixed seeds (IV removes most of the errors-in-variables bias),
and error paths.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import signal

import physid
from physid.errors import IdentifiabilityError, InputError, SamplingError, ShapeError
from physid.estimators.idim import (
    IDIMEstimator,
    base_regressor_info,
    condition_number,
    hac_covariance,
    idim_rows,
    parallel_decimate,
)
from physid.estimators.idim.decimation import RIPPLE_DB
from physid.signals.recording import Recording
from physid.simulate.closed_loop import simulate_closed_loop

KP = (3800.0, 40000.0, 10000.0, 500.0)
KD = (159.5, 120.0, 50.0, 2.0)
W0 = 2 * np.pi * np.array([0.2, 0.3, 0.5, 0.7])


@pytest.fixture(scope="module")
def arm():
    return physid.load_model("manipulator")


@pytest.fixture(scope="module")
def truth(arm):
    info = base_regressor_info(arm)
    return info.from_standard(arm.beta())


def _reference(t, phase=0.0, scale=1.0):
    # smooth start (a step of the reference at t = 0 is broadband and biases any filter)
    ramp = np.clip(t / 1.0, 0.0, 1.0)[:, None] ** 3
    return (
        ramp
        * scale
        * (0.8 * np.sin(np.outer(t, W0) + phase) + 0.3 * np.sin(np.outer(t, 2.3 * W0) + 1 + phase))
    )


def _run(arm, noise=None, seed=None, duration=8.0, phase=0.0, scale=1.0):
    t = np.arange(0.0, duration, 1e-3)
    return simulate_closed_loop(
        arm,
        kp=KP,
        kd=KD,
        reference=_reference(t, phase, scale),
        t=t,
        noise_std=noise,
        rng=seed,
    )


@pytest.fixture(scope="module")
def clean(arm):
    return _run(arm)


@pytest.mark.parametrize("method", ["ols", "wls"])
@pytest.mark.parametrize("differentiation", ["physid", "butterworth"])
def test_noise_free_recovers_base_parameters(arm, truth, clean, method, differentiation):
    est = IDIMEstimator(arm, method, differentiation=differentiation, cutoff=0.3).fit(clean)
    r = est.result_
    assert r.success
    # Butterworth + central differences: the filter's pass band is not flat and the central
    # differences are O(Δ²) accurate, hence the looser tolerance (measured 3.6e-3)
    rtol = 2e-3 if differentiation == "physid" else 1e-2
    np.testing.assert_allclose(r.beta_vector(), truth, rtol=rtol)
    assert r.relative_error["overall"] < 1e-4
    assert set(r.relative_error) == {"overall", "tau1", "tau2", "tau3", "tau4"}
    assert r.method == f"idim-{method}"
    assert r.names == tuple(base_regressor_info(arm).names)
    assert r.units["m1*l1**2"] == "kg*m**2"


def test_result_schema_and_json(arm, clean):
    r = IDIMEstimator(arm, "ols", cutoff=0.3).fit(clean).result_
    d = r.to_dict()
    for key in (
        "names",
        "parameters",
        "base_expressions",
        "stderr",
        "condition_number",
        "relative_error",
        "units",
        "success",
        "message",
    ):
        assert key in d
    assert "history" not in d and "residuals" not in d
    assert d["base_expressions"]["m3*l3"] == "m3*l3 + m4*l3"
    assert "condition number" in r.summary()


def test_parallel_decimate_equals_scipy_decimate_in_the_interior():
    rng = np.random.default_rng(0)
    x = np.cumsum(rng.normal(size=(4000, 3)), axis=0)
    y, kept = parallel_decimate(x, 5)
    # scipy's decimate with physid's filter (its pass-band ripple RIPPLE_DB, flatter than
    # scipy's default 0.05 dB, which put 1.1 % of error into every torque prediction)
    ripple = RIPPLE_DB
    ref = signal.decimate(x, 5, ftype=signal.dlti(*signal.cheby1(8, ripple, 0.8 / 5)), axis=0)
    # scipy's decimate keeps rows 0, 5, 10, ...; ours drops the 12·nd-sample transients
    interior = (kept > 400) & (kept < 3600)
    np.testing.assert_allclose(y[interior], ref[kept[interior] // 5], rtol=1e-6, atol=1e-6)
    same, all_rows = parallel_decimate(x, 1)
    assert same is not None and all_rows.size == 4000


def test_parallel_decimate_skips_zero_columns_bit_for_bit():
    rng = np.random.default_rng(1)
    x = np.zeros((3000, 5, 4))  # (samples, joints, parameters), like a regressor
    x[:, 0, :] = np.cumsum(rng.normal(size=(3000, 4)), axis=0)
    x[:, 3, 1] = rng.normal(size=3000)
    x[1500, 4, 2] = 1.0  # zero except at one sample: filtered, not skipped
    y, kept = parallel_decimate(x, 7, block_columns=3)
    sos = signal.cheby1(8, RIPPLE_DB, 0.8 / 7, output="sos")
    flat = x.reshape(3000, -1)
    ref = signal.sosfiltfilt(sos, flat.T, axis=-1, padlen=84)[:, kept].T.reshape(y.shape)
    np.testing.assert_array_equal(y, ref)  # the skipped columns are exactly zero too
    assert np.count_nonzero(np.any(y != 0, axis=0)) == 6


def test_stacked_recordings_are_filtered_apart(arm, truth, clean):
    other = _run(arm, phase=0.7, scale=0.8)
    info = base_regressor_info(arm)
    rows = idim_rows(arm, [clean, other], info=info, cutoff=0.3, decimate=20)
    one = idim_rows(arm, clean, info=info, cutoff=0.3, decimate=20)
    two = idim_rows(arm, other, info=info, cutoff=0.3, decimate=20)
    np.testing.assert_array_equal(rows.W, np.concatenate([one.W, two.W]))
    assert set(rows.segments.tolist()) == {0, 1}
    r = IDIMEstimator(arm, "ols", cutoff=0.3, decimate=20).fit([clean, other]).result_
    assert r.n_recordings == 2
    np.testing.assert_allclose(r.beta_vector(), truth, rtol=5e-3)  # measured 3.4e-3 (m1*l1**2)


def test_hac_with_zero_lag_is_the_white_sandwich():
    rng = np.random.default_rng(1)
    g = rng.normal(size=(200, 3))
    B = rng.normal(size=(3, 3))
    np.testing.assert_allclose(hac_covariance(g, B, lag=0), B @ g.T @ g @ B.T)
    # lags never pair rows of two recordings
    seg = np.repeat([0, 1], 100)
    full = hac_covariance(g, np.eye(3), seg, lag=2)
    halves = hac_covariance(g[:100], np.eye(3), lag=2) + hac_covariance(g[100:], np.eye(3), lag=2)
    np.testing.assert_allclose(full, halves)


def test_condition_number_is_scale_free():
    rng = np.random.default_rng(2)
    a = rng.normal(size=(50, 4))
    assert condition_number(a) == pytest.approx(condition_number(a * [1, 1e3, 1e-3, 7]))


def test_iv_removes_most_of_the_noise_bias(arm, truth):
    noisy = _run(arm, noise=1e-3, seed=3)
    ols = IDIMEstimator(arm, "ols").fit(noisy).result_
    iv = IDIMEstimator(arm, "iv", max_iter=6, tol=1e-3).fit(noisy).result_
    err_ols = np.abs(ols.beta_vector() / truth - 1)
    err_iv = np.abs(iv.beta_vector() / truth - 1)
    assert iv.iterations >= 2 and len(iv.iv_changes) == iv.iterations
    # one seed: the median error over the 12 base parameters (measured 0.0177 → 0.0052)
    assert np.median(err_iv) < 0.5 * np.median(err_ols)


# ---------------------------------------------------------------------- bad input
def test_iv_without_controller_is_refused(arm, clean):
    bare = Recording(
        clean.t,
        clean.select([f"q{j}" for j in range(1, 5)] + [f"tau{j}" for j in range(1, 5)]),
        tuple(f"q{j}" for j in range(1, 5)) + tuple(f"tau{j}" for j in range(1, 5)),
    )
    with pytest.raises(InputError, match=r"proportional gains \(kp=\[...\]\).*r1"):
        IDIMEstimator(arm, "iv").fit(bare)


def test_recordings_with_other_period_or_joints_are_refused(arm, clean):
    slow = Recording(clean.t * 2, clean.data, clean.names)
    with pytest.raises(SamplingError, match="sample period"):
        IDIMEstimator(arm, "ols", cutoff=0.3).fit([clean, slow])
    five = Recording(
        clean.t,
        np.column_stack([clean.data, clean["q1"], clean["tau1"]]),
        clean.names + ("q5", "tau5"),
    )
    with pytest.raises(ShapeError, match="q5"):
        IDIMEstimator(arm, "ols", cutoff=0.3).fit(five)


def test_unexcited_parameter_is_named(arm, clean):
    t = clean.t
    ref = _reference(t)
    ref[:, 3] = 0.0  # joint 4 never moves relative to joint 3 ... and its mass still matters
    still = simulate_closed_loop(arm, kp=KP, kd=KD, reference=np.zeros((t.size, 4)), t=t)
    with pytest.raises(IdentifiabilityError, match=r"excites|condition number"):
        IDIMEstimator(arm, "ols", cutoff=0.3).fit(still)


def test_decimation_leaving_too_few_rows_is_refused(arm, clean):
    short = clean.slice_time(0.0, 1.0)
    with pytest.raises(SamplingError, match="decimate"):
        IDIMEstimator(arm, "ols", cutoff=0.3, decimate=60).fit(short)


def test_poor_conditioning_warns_with_the_number(arm):
    t = np.arange(0.0, 4.0, 1e-3)
    slow = simulate_closed_loop(
        arm, kp=KP, kd=KD, reference=0.05 * np.sin(np.outer(t, W0[:1] * [1, 1, 1, 1])), t=t
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            IDIMEstimator(arm, "ols", cutoff=0.3).fit(slow)
        except IdentifiabilityError as exc:
            assert "condition number" in str(exc) or "excites" in str(exc)
            return
    assert any("design-excitation" in str(w.message) for w in caught)


@pytest.mark.parametrize(
    ("settings", "match"),
    [
        ({"method": "lasso"}, "method must be one of"),
        ({"stderr": "bootstrap"}, "stderr must be"),
        ({"cutoff": "fast"}, "cutoff must be"),
        ({"cutoff": 4.0}, r"cutoff must lie in \(0, π\]"),
        ({"decimate": 0}, "decimate must be an integer >= 1"),
        ({"differentiation": "spline"}, "differentiation must be one of"),
    ],
)
def test_bad_settings(arm, clean, settings, match):
    method = settings.pop("method", "ols")
    with pytest.raises(InputError, match=match):
        IDIMEstimator(arm, method, **settings).fit(clean)


def test_get_set_params_and_repr(arm):
    est = IDIMEstimator(arm, "wls", decimate=7)
    assert est.get_params()["decimate"] == 7
    est.set_params(decimate=9)
    assert est.decimate == 9
    with pytest.raises(InputError, match="no setting"):
        est.set_params(bogus=1)
    assert "wls" in repr(est)
