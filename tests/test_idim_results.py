"""What an IDIM fit of the planar two-link arm gives back: predicted torques
(`IDIMResult.predict`, `predict_torque`, the held-out rows of the documented recipe), the
estimator's settings interface, and the consistent (physically feasible) estimate.

Kinds of test: an independent implementation (predict against pinocchio's rnea on the same
filtered states, filtered and decimated by scipy directly), equivalence of forms (predict =
W β = the fit's own residual; validate = predict), and optimality of the consistent estimate
against the log-Cholesky least-squares solution of the same problem.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy import optimize, signal

import physid
from _helpers import DATA, PLANAR2
from _helpers import planar2_pd_run as _run
from physid.analysis.validation import validate
from physid.errors import InputError
from physid.estimators.base import EstimatorMixin
from physid.estimators.consistent import log_cholesky_to_standard, standard_to_log_cholesky
from physid.estimators.idim import IDIMEstimator, base_regressor_info, predict_torque
from physid.filters import filter_derivatives
from physid.models.inertial import pseudo_inertia

KP, KD = (200.0, 100.0), (20.0, 10.0)  # the gains of planar2_pd_run


@pytest.fixture(scope="module")
def clean(planar):
    return _run(planar)


@pytest.fixture(scope="module")
def fitted(planar, clean):
    return IDIMEstimator(planar, "ols").fit(clean)


# ------------------------------------------------------------------------------ predict
def test_predict_with_the_truth_equals_pinocchio_rnea_filtered_and_decimated(planar, clean):
    info = base_regressor_info(planar)
    truth = info.from_standard(planar.beta())
    cutoff, m, nd = 0.3, 40, 6
    pred = predict_torque(
        planar, info.names, truth, clean, cutoff=cutoff, half_width=m, decimate=nd
    )
    # independently: the same FIR state filter, pinocchio's rnea at every filtered state,
    # then scipy's Chebyshev I (order 8, RIPPLE_DB = 0.001 dB, 0.8/nd) forwards and backwards,
    # every nd-th row
    q = clean.select(["q1", "q2"])
    d = filter_derivatives(q, np.arange(q.shape[0]) * clean.dt, m, cutoff, design="consistent")
    pm = pin.buildModelFromUrdf(str(PLANAR2))
    pdata = pm.createData()
    qf, qdf, qddf = (np.asarray(x) for x in (d.value, d.first, d.second))
    tau = np.array([pin.rnea(pm, pdata, qf[s], qdf[s], qddf[s]) for s in range(qf.shape[0])])
    edge = 12 * nd
    sos = signal.cheby1(8, 0.001, 0.8 / nd, output="sos")
    filt = signal.sosfiltfilt(sos, tau, axis=0, padlen=edge)
    kept = np.arange(edge, tau.shape[0] - edge, nd)
    expected = filt[kept]
    got = pred.select(["tau1", "tau2"])
    assert got.shape == expected.shape
    assert np.abs(got - expected).max() < 1e-9 * np.abs(expected).max()
    np.testing.assert_allclose(pred.t, clean.t[m + kept], rtol=0, atol=1e-12)
    assert pred.metadata["decimate"] == nd and pred.units == ("N*m", "N*m")


def test_predict_is_w_beta_and_reproduces_the_fit_residual(fitted, clean):
    r, rows = fitted.result_, fitted.rows_
    pred = r.predict(clean, measured=True)
    assert pred.names == ("tau1", "tau2", "tau1_measured", "tau2_measured")
    tau_hat = pred.select(["tau1", "tau2"])
    np.testing.assert_array_equal(tau_hat, rows.W @ r.beta_vector())
    np.testing.assert_array_equal(pred.select(["tau1_measured", "tau2_measured"]), rows.tau)
    np.testing.assert_array_equal(pred.t, rows.t)
    e = pred.select(["tau1_measured", "tau2_measured"]) - tau_hat
    np.testing.assert_allclose(e, r.residuals, rtol=0, atol=1e-12)
    assert r.relative_error["overall"] < 1e-5  # noise-free


def test_predict_on_held_out_motion_alone_and_validate_agree(planar, fitted):
    held = _run(planar, phase=0.7, duration=3.0)
    r = fitted.result_
    motion = physid.Recording(held.t, held.select(["q1", "q2"]), ["q1", "q2"])
    only = r.predict(motion)
    both = r.predict(held, measured=True)
    np.testing.assert_array_equal(only.data, both.data[:, :2])
    tau_f = both.select(["tau1_measured", "tau2_measured"])
    rel = np.linalg.norm(only.data - tau_f) / np.linalg.norm(tau_f)
    assert rel < 1e-4  # noise-free held-out trajectory: the base parameters are right
    report = validate(r, held)  # the model comes with the result
    assert report.relative_error["overall"] == pytest.approx(rel, rel=1e-12)
    with pytest.raises(InputError, match="measured=True needs the torque"):
        r.predict(motion, measured=True)


def test_predict_refuses_another_models_parameters(planar, fitted, clean):
    arm7 = physid.load_model(DATA / "arm7.urdf")
    r = fitted.result_
    with pytest.raises(InputError, match="fitted with"):
        predict_torque(arm7, r.names, r.beta_vector(), clean)


# ------------------------------------------------------------------------------ the settings interface
def test_idim_estimator_uses_the_shared_mixin(planar, clean):
    est = IDIMEstimator(planar, "iv", kp=KP, kd=KD, decimate=5, max_iter=3)
    assert isinstance(est, EstimatorMixin)
    for name in ("get_params", "set_params", "__repr__", "fit_arrays"):
        assert name not in IDIMEstimator.__dict__, name
    params = est.get_params()
    assert params["method"] == "iv" and params["decimate"] == 5 and params["model"] is planar
    assert len(params) == 17  # feedforward included
    twin = IDIMEstimator(**params)
    assert twin.get_params() == params
    assert twin.set_params(decimate=7, tol=1e-3) is twin and twin.decimate == 7
    assert repr(est) == (
        "IDIMEstimator(model=<RigidBodyModel 'planar2'>, method='iv', decimate=5, "
        "kp=(200.0, 100.0), kd=(20.0, 10.0), max_iter=3)"
    )
    with pytest.raises(InputError, match="no setting"):
        est.set_params(bogus=1)
    ols = IDIMEstimator(planar, "ols", decimate=5)
    arrays = {c: clean[c] for c in ("q1", "q2", "tau1", "tau2")}
    a = ols.fit_arrays(clean.t, **arrays).result_.beta_vector()
    b = IDIMEstimator(planar, "ols", decimate=5).fit(clean).result_.beta_vector()
    np.testing.assert_array_equal(a, b)


# ------------------------------------------------------------------------------ consistent
def _cost(beta, K, a, b, nominal, scale):
    r = a @ (K @ beta) - b
    q = 1e-3 * (beta - nominal) / scale
    return float(r @ r + q @ q)


def test_consistent_estimate_is_optimal_at_the_boundary(planar, fitted):
    """An impossible estimate (YY2 < 0: link 2 cannot have a negative inertia about its axis)
    is moved onto the boundary; the barrier solver's cost is no higher than that of the same
    problem solved in the log-Cholesky parametrisation by least squares to convergence."""
    from physid.estimators.consistent import consistent_estimate

    rows, info = fitted.rows_, fitted.base_
    p = info.n_base
    truth = info.from_standard(planar.beta())
    impossible = truth.copy()
    k = info.names.index("YY2")
    impossible[k] = -0.5 * abs(truth[k])
    rng = np.random.default_rng(3)
    y = rows.W @ impossible
    y = y + 0.01 * np.std(y, axis=0) * rng.standard_normal(y.shape)
    a, b = rows.W.reshape(-1, p), y.ravel()
    beta_hat = np.linalg.lstsq(a, b, rcond=None)[0]
    c = consistent_estimate(planar, info, rows.W, y, beta_hat, np.ones(2))
    assert "link2" in c.at_boundary and c.min_eigenvalues["link2"] < 1e-8
    assert c.cost_ratio > 1.01  # the constraint costs something here
    beta_c = np.array([c.standard[n] for n in info.column_names])
    assert np.linalg.eigvalsh(pseudo_inertia(beta_c[10:]))[0] >= 0
    K = info.matrix
    nominal = planar.beta()
    scale = np.maximum(np.abs(nominal), 1e-3 * np.abs(nominal).max())
    assert len(nominal) == 20  # two links, no drive terms

    def standard(x):
        return np.concatenate([log_cholesky_to_standard(x[:10]), log_cholesky_to_standard(x[10:])])

    def residual(x):
        beta = standard(x)
        return np.concatenate([a @ (K @ beta) - b, 1e-3 * (beta - nominal) / scale])

    x0 = np.concatenate(
        [standard_to_log_cholesky(nominal[:10]), standard_to_log_cholesky(nominal[10:])]
    )
    sol = optimize.least_squares(residual, x0, ftol=1e-15, xtol=1e-15, gtol=1e-15, max_nfev=1000)
    ours = _cost(beta_c, K, a, b, nominal, scale)
    theirs = _cost(standard(sol.x), K, a, b, nominal, scale)
    assert ours <= theirs * (1 + 1e-9)
    e_ols = float(np.sum((a @ beta_hat - b) ** 2))
    torque = float(np.sum((a @ (K @ beta_c) - b) ** 2))
    assert c.cost_ratio == pytest.approx(torque / e_ols, rel=1e-9)
    print(ours, theirs, c.message)


def test_consistent_estimate_of_noise_free_data_is_the_unconstrained_one(planar, clean):
    est = IDIMEstimator(planar, "ols", consistent=True).fit(clean)
    c = est.result_.consistent
    assert c.cost_ratio == pytest.approx(1.0, abs=1e-4)
    base = np.array([c.base[n] for n in est.result_.names])
    np.testing.assert_allclose(base, est.result_.beta_vector(), rtol=1e-4)
    assert c.at_boundary == ()
    assert "Newton steps" in c.message


# --------------------------------------------------------- the documented recipe for held-out rows
def test_identifying_a_robot_doc_recipe_gives_the_fit_rows():
    # docs/identifying-a-robot.md §5 used to say idim_rows(model, held_out), whose "auto"
    # settings are recomputed on the held-out record (other filters than the fit's).
    from physid.estimators.idim import idim_rows

    doc = (Path(__file__).parents[1] / "docs" / "identifying-a-robot.md").read_text()
    assert "cutoff=result.cutoff, half_width=result.half_width, decimate=result.decimate" in doc
    model = physid.load_model(PLANAR2)
    result = IDIMEstimator(model, "ols").fit(_run(model)).result_
    held = _run(model, phase=0.7, duration=3.0)
    rows = idim_rows(
        model,
        held,
        differentiation=result.differentiation,
        cutoff=result.cutoff,
        half_width=result.half_width,
        decimate=result.decimate,
    )
    pred = result.predict(held, measured=True)
    np.testing.assert_array_equal(result.predict_rows(rows), pred.select(["tau1", "tau2"]))
    np.testing.assert_array_equal(rows.tau, pred.select(["tau1_measured", "tau2_measured"]))


# ------------------------------------------------------------------------------ one name each
def test_base_expressions_is_the_one_key_and_old_files_still_load(planar, fitted, tmp_path):
    import json
    import warnings

    from physid.analysis.validation import load_result
    from physid.estimators.results import save_result

    r = fitted.result_
    info = base_regressor_info(planar)
    assert r.base_expressions == dict(zip(info.names, info.expressions, strict=True))
    d = r.to_dict()
    assert "base_expressions" in d and "expressions" not in d
    with pytest.warns(DeprecationWarning, match="read result.base_expressions"):
        assert r.expressions == r.base_expressions
    # a file written with the former key reads back under the current one, value for value
    path = tmp_path / "fit.json"
    save_result(r, path, model=str(PLANAR2))
    data = json.loads(path.read_text(encoding="utf-8"))
    data["expressions"] = data.pop("base_expressions")
    old = tmp_path / "old.json"
    old.write_text(json.dumps(data), encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        loaded = load_result(old, model=planar)
    assert loaded.data["base_expressions"] == r.base_expressions
    assert "expressions" not in loaded.data


@pytest.mark.parametrize("method", ["ols", "wls"])
def test_message_and_summary_quote_the_one_condition_number(planar, clean, method):
    r = IDIMEstimator(planar, method).fit(clean).result_
    quoted = f"condition number {r.condition_number:.4g}"
    assert quoted in r.message
    assert quoted in r.summary()
    assert r.message.count("condition number") == 1
