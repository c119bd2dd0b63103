"""IDIM on the planar two-link arm (tests/data/planar2.urdf) in a PD closed loop: what it checks
and what it reports.

Each test asserts numbers a wrong implementation gets wrong: IV on records of different lengths
(one FIR half-width for all), the sample period in the result, settings checked like every other
argument, ``success`` false for a fit that explains half the torque, a model with known
parameters refused, base parameters named as such, the consistent estimate's cost ratio and
convergence, and an instruments' model that reaches a sign change.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import physid
from _helpers import DATA
from physid.errors import InputError, ShapeError
from physid.estimators.idim import (
    REL_ERROR_FAIL,
    IDIMEstimator,
    base_regressor_info,
)
from physid.simulate.closed_loop import simulate_closed_loop

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
def arm(planar):
    return planar


@pytest.fixture(scope="module")
def truth(arm):
    return base_regressor_info(arm).from_standard(arm.beta())


@pytest.fixture(scope="module")
def run1(arm):
    return _run(arm)


@pytest.fixture(scope="module")
def run2(arm):
    return _run(arm, seed=2, alt=True)


# --------------------------------------------------------------------- records of different lengths
def test_iv_on_recordings_of_different_length(arm, truth, run1, run2):
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


# --------------------------------------------------------------------- the sample period
def test_result_carries_the_sample_period(arm, run1):
    est = IDIMEstimator(arm).fit(run1)
    assert est.result_.dt == pytest.approx(1e-3, rel=1e-9)
    assert est.rows_.dt == pytest.approx(1e-3, rel=1e-9)
    assert est.result_.to_dict()["dt"] == pytest.approx(1e-3, rel=1e-9)


# --------------------------------------------------------------------- settings
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
def test_settings_checked_like_everywhere_else(arm, run1, settings, cls, match):
    settings = dict(settings)
    method = settings.pop("method", "ols")
    with pytest.raises(cls, match=match) as info:
        IDIMEstimator(arm, method, **settings).fit(run1)
    assert type(info.value) is cls


def test_setting_names_are_marked_for_the_cli(arm, run1):
    with pytest.raises(InputError) as info:
        IDIMEstimator(arm, decimate=0).fit(run1)
    assert info.value.render({"decimate": "--decimate"}).startswith("--decimate must be")
    with pytest.raises(InputError) as info:
        IDIMEstimator(arm, cutoff=5.0).fit(run1)
    assert info.value.render({"cutoff": "--cutoff"}).startswith("--cutoff must lie in")


# --------------------------------------------------------------------- the success verdict
def test_success_false_when_the_model_does_not_explain_the_torques(arm, truth, run1):
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


# --------------------------------------------------------------------- known parameters
def test_idim_refuses_a_model_with_known_parameters(arm, run1, tmp_path):
    side = tmp_path / "planar2_side.toml"
    side.write_text(
        f'name = "planar2_side"\nextends = "{(DATA / "planar2.urdf").as_posix()}"\n'
        'identify = ["m2", "mcx2"]\n'
    )
    model = physid.load_model(side)
    assert model.unknown == ("m2", "mcx2")
    with pytest.raises(InputError, match=r"marks m1, mcx1, .* as known") as info:
        IDIMEstimator(model).fit(run1)
    assert "input-error" in info.value.render({"method": "--method"})
    # every parameter unknown (the default): no refusal
    assert IDIMEstimator(arm).fit(run1).result_.success


# --------------------------------------------------------------------- the consistent estimate
def _infeasible(arm, run1):
    """Rows of run1 with torques from a base vector whose YY2 = −0.01 (no real arm has it)."""
    est = IDIMEstimator(arm).fit(run1)
    W, info = est.rows_.W, est.base_
    b = est.result_.beta_vector().copy()
    b[info.names.index("YY2")] = -0.01
    rng = np.random.default_rng(1)
    y = W @ b + 1e-3 * rng.standard_normal(est.rows_.tau.shape)
    return W, y, info


def test_cost_ratio_is_measured_on_the_rows_for_a_non_ls_estimate(arm, run1):
    from physid.estimators.consistent import consistent_estimate
    from physid.estimators.idim import _lstsq

    W, y, info = _infeasible(arm, run1)
    ones = np.ones(2)
    ls = _lstsq(W, y, ones)
    fits = []
    for beta_hat in (1.02 * ls, ls):  # an estimate that is not the LS solution (like IV), LS
        c = consistent_estimate(arm, info, W, y, beta_hat, ones)
        bc = np.array([c.base[n] for n in info.names])
        true_ratio = np.sum((W @ bc - y) ** 2) / np.sum((W @ beta_hat - y) ** 2)
        # a wrong pricing reports 4.03 for the non-LS estimate against the true 3.91
        assert c.cost_ratio == pytest.approx(true_ratio, rel=1e-9)
        assert "link2" in c.at_boundary  # YY2 < 0 is outside the cone: the optimum is on it
        fits.append(c)
    assert fits[0].cost_ratio < 10.0 < 1e4 < fits[1].cost_ratio  # measured 3.91, 7.07e4
    assert all(c.converged for c in fits)


def test_a_solver_that_stops_early_is_reported(arm, run1, monkeypatch):
    import physid.estimators.consistent as cons
    from physid.estimators.idim import _lstsq

    W, y, info = _infeasible(arm, run1)
    ls = _lstsq(W, y, np.ones(2))
    full = cons.consistent_estimate(arm, info, W, y, ls, np.ones(2))
    monkeypatch.setattr(cons, "MAX_NEWTON_STEPS", 5)
    short = cons.consistent_estimate(arm, info, W, y, ls, np.ones(2))
    assert full.converged and "did not converge" not in full.message
    assert not short.converged
    assert "did not converge" in short.message and "(5 Newton steps)" in short.message
    assert short.cost_ratio > full.cost_ratio  # stopped early: a worse feasible point
    # through the estimator: success False, the reason in the message and the warnings
    r = IDIMEstimator(arm, consistent=True).fit(run1).result_
    assert not r.consistent.converged
    assert not r.success
    assert "did not converge" in r.message
    assert any("did not converge" in w for w in r.warnings)


# --------------------------------------------------------------------- base-parameter names
def test_results_are_keyed_by_base_parameter_names(arm, run1, run2, tmp_path):
    from physid.analysis.validation import validate
    from physid.estimators.idim import predict_torque
    from physid.estimators.results import save_result

    r = IDIMEstimator(arm).fit(run1).result_
    bp = arm.base_parameters()
    assert r.names == tuple(bp.base_names) == ("mcx1R", "mcz1", "YY1R", "mcx2", "mcz2", "YY2")
    assert r.columns == tuple(bp.independent) == ("mcx1", "mcz1", "YY1", "mcx2", "mcz2", "YY2")
    assert r.units["mcx1R"] == "kg*m" and r.units["YY1R"] == "kg*m**2"
    assert r.base_expressions["mcx1R"] == bp.expressions[0]
    # mcx1R = mcx1 + 0.45 m2 = 1.001 (the standard mcx1 is 0.506): no longer taken for mcx1
    assert r.parameters["mcx1R"] == pytest.approx(1.001, rel=2e-3)
    q = run2.select(["q1", "q2"])
    with pytest.raises(InputError, match=r"\['mcx1R', 'YY1R'\] are base parameters"):
        arm.inverse_dynamics(q, q, q, params=r.parameters)
    # a result file keyed by the kept columns (an older file) still predicts the same torques
    old = predict_torque(
        arm,
        r.columns,
        r.beta_vector(),
        run2,
        cutoff=r.cutoff,
        half_width=r.half_width,
        decimate=r.decimate,
    )
    new = r.predict(run2)
    np.testing.assert_array_equal(old.data, new.data)
    path = save_result(r, tmp_path / "res.json", model=str(DATA / "planar2.urdf"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = validate(path, run2)
    assert out.relative_error["overall"] < 0.01


# --------------------------------------------------------------------- the instruments' model
def test_instruments_model_reaches_a_sign_change(arm):
    from physid.estimators.idim import _params_for_base

    info = base_regressor_info(arm)
    theta0 = np.asarray(arm.parameter_vector(None), dtype=float)
    target = info.from_standard(arm.beta()).copy()
    k = info.names.index("mcz2")
    assert target[k] > 0  # nominal +0.0132
    target[k] = -0.02
    theta = _params_for_base(arm, info, target, theta0)
    reached = info.from_standard(arm.beta(theta))
    # old: mcz2 stopped at +1.3e-8 (its positive nominal value was taken as a bound)
    np.testing.assert_allclose(reached, target, rtol=1e-6, atol=1e-9)
    # masses keep their sign
    masses = [i for i, n in enumerate(arm.parameter_names) if n in ("m1", "m2")]
    assert np.all(theta[masses] > 0)
