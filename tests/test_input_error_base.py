"""Input-error identification of a rigid-body arm over its base parameters (the planar two-link
URDF arm, an analytic motion and its exact torque): the estimates, their names and intervals, the
saved result, and the refusals where base parameters do not apply."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import physid
from physid.errors import InputError
from physid.estimators.input_error import InputErrorEstimator
from physid.signals import Recording

PLANAR2 = Path(__file__).parent / "data" / "planar2.urdf"


def _planar2_record(duration=8.0, dt=1e-3):
    """An analytic three-sine motion per joint and its exact inverse-dynamics torque."""
    model = physid.load_model(PLANAR2)
    t = np.arange(0.0, duration, dt)
    w = 2 * np.pi * np.array([[0.3, 0.7, 1.1], [0.5, 0.9, 1.3]])
    a = np.array([[0.8, 0.4, 0.2], [0.9, 0.3, 0.25]])
    ph = np.array([[0.0, 1.0, 2.0], [0.5, 1.5, 2.5]])
    arg_ = [np.outer(t, w[:, k]) + ph[:, k] for k in range(3)]
    q = sum(a[:, k] * np.sin(arg_[k]) for k in range(3))
    qd = sum(a[:, k] * w[:, k] * np.cos(arg_[k]) for k in range(3))
    qdd = sum(-a[:, k] * w[:, k] ** 2 * np.sin(arg_[k]) for k in range(3))
    tau = model.inverse_dynamics(q, qd, qdd)
    return model, Recording.from_columns(t, {"q": q, "tau": tau}), (q, qd, qdd, tau)


def _true_base(model):
    bp = model.base_parameters()
    return dict(zip(bp.base_names, bp.base_matrix @ model.beta(), strict=True))


def test_one_torque_of_the_record_matches_pinocchio():
    pin = pytest.importorskip("pinocchio")  # a dev dependency: always installed by make test
    _, _, (q, qd, qdd, tau) = _planar2_record()
    pm = pin.buildModelFromUrdf(str(PLANAR2))
    k = 1234
    tau_p = pin.rnea(pm, pm.createData(), q[k], qd[k], qdd[k])
    assert np.abs(tau[k] - tau_p).max() < 1e-10 * np.abs(tau_p).max()


def test_base_parameters_recovered_noise_free_and_agree_with_idim_ols():
    from physid.estimators.idim import IDIMEstimator

    model, rec, _ = _planar2_record()
    truth = _true_base(model)
    est = InputErrorEstimator(model, half_width=100, cutoff=0.2)  # the paper's filter
    assert est.parameter_set() == "base"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the paper's cut-off is a little low for this motion
        r = est.fit(rec).result_
    assert r.parameter_set == "base" and r.names == tuple(truth) and r.success
    assert set(r.base_expressions) == set(truth)
    rel = {n: abs(r.parameters[n] / v - 1) for n, v in truth.items()}
    assert max(rel.values()) < 5e-5, rel  # measured 1.2e-5 (filters on a smooth motion)
    assert r.nfev == 1 and r.history.shape == (1, len(truth))
    assert all(np.isfinite(r.stderr[n]) and r.stderr[n] > 0 for n in truth)
    # IDIM-OLS on the same filtered rows (the same FIR bank, no decimation): the same estimate
    ols = IDIMEstimator(
        model, "ols", differentiation="physid", half_width=100, cutoff=0.2, decimate=1
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        o = ols.fit(rec).result_
    assert o.names == r.names and r.columns == o.columns  # one naming: mcx1R, kept column mcx1
    assert r.units == o.units
    idim = dict(zip(o.names, o.beta_vector(), strict=True))
    agree = max(abs(r.parameters[n] - idim[n]) / abs(v) for n, v in truth.items())
    assert agree < 1e-5  # measured 1.1e-6 (IDIM filters τ with its own low-pass)


def test_base_fit_with_auto_cutoff_and_noise_compensation():
    """σ_q = 1e-4 rad on the 2-link URDF arm: plain least squares is biased far beyond its
    standard errors (errors in variables); the default compensates and its intervals hold."""
    model, rec, (q, *_rest) = _planar2_record()
    rng = np.random.default_rng(3)
    noisy = rec.with_channels(
        {f"q{j + 1}": q[:, j] + 1e-4 * rng.normal(size=q.shape[0]) for j in range(2)}
    )
    truth = _true_base(model)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = InputErrorEstimator(model, noise="ignore").fit(noisy).result_
        default = InputErrorEstimator(model).fit(noisy).result_

    def z(r):
        return max(abs(r.parameters[n] - v) / r.stderr[n] for n, v in truth.items())

    assert plain.noise == "ignore" and z(plain) > 8.0  # measured 12.8
    assert default.noise == "compensate" and set(default.noise_shift) == set(truth)
    assert z(default) < 2.5  # measured 0.8
    clean = InputErrorEstimator(model, half_width=100, cutoff=0.2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert clean.fit(rec).result_.noise == "ignore"  # noise-free: nothing to compensate


def test_a_saved_base_result_validates_with_the_fitted_torque(tmp_path):
    from physid.analysis.validation import validate
    from physid.estimators.results import save_result

    model, rec, _ = _planar2_record(duration=4.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = InputErrorEstimator(model, half_width=100, cutoff=0.2).fit(rec).result_
    assert r.fixed == {}  # nothing is held: the base parameters are what the data determine
    path = save_result(r, tmp_path / "fit.json", model=str(PLANAR2))
    report = validate(path, rec)  # the fit's own record: the torque balances to the filter error
    assert report.relative_error["overall"] < 1e-3  # 0.43 before the base columns were held
    # the in-memory result predicts the same torques as the saved one
    pred = r.predict(rec, measured=True)
    tau_hat, tau_f = pred.select(["tau1", "tau2"]), pred.select(["tau1_measured", "tau2_measured"])
    rel = np.linalg.norm(tau_hat - tau_f) / np.linalg.norm(tau_f)
    assert rel == pytest.approx(report.relative_error["overall"], rel=1e-9)


def test_base_names_are_refused_as_model_parameters_and_model_parameters_predict():
    """Base values keyed like standard parameters (mcx1) would be silently taken as standard
    ones by ``params=`` (the other columns at nominal values): a wrong torque without a word. They
    are named as IDIM names them (mcx1R) and refused."""
    model, rec, (q, qd, qdd, _tau) = _planar2_record(duration=4.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = InputErrorEstimator(model, half_width=100, cutoff=0.2).fit(rec).result_
    regrouped = [n for n in r.names if n.endswith("R")]
    assert regrouped and all(n[:-1] in model.parameter_names for n in regrouped)
    with pytest.raises(InputError, match="base parameters"):
        model.inverse_dynamics(q, qd, qdd, r.parameters)
    theta = r.model_parameters()
    assert set(theta) == set(model.parameter_names)
    assert sum(v != 0.0 for v in theta.values()) <= len(r.names)
    # θ (β on the kept columns, 0 elsewhere) gives the true torque: τ = Y θ = W_b β
    tau_theta = model.inverse_dynamics(q, qd, qdd, theta)
    tau_true = model.inverse_dynamics(q, qd, qdd)
    assert np.abs(tau_theta - tau_true).max() < 1e-3 * np.abs(tau_true).max()
    # while the old keying (kept column -> base value, the rest nominal) is visibly wrong
    old = {c: r.parameters[n] for n, c in zip(r.names, r.columns, strict=True)}
    tau_old = model.inverse_dynamics(q, qd, qdd, old)
    assert np.abs(tau_old - tau_true).max() > 0.05 * np.abs(tau_true).max()


def test_base_parameters_refused_where_they_do_not_apply():
    model, rec, _ = _planar2_record(duration=2.0)
    with pytest.raises(InputError, match="fixed"):
        InputErrorEstimator(model, fixed={"m1": 2.3}).fit(rec)
    with pytest.raises(InputError, match="parameters must be one of"):
        InputErrorEstimator(model, parameters="standard").parameter_set()
    arm = physid.load_model("manipulator", kinetic="paper")
    assert InputErrorEstimator(arm).parameter_set() == "model"
    with pytest.raises(InputError, match="linear in its parameters"):
        InputErrorEstimator(arm, parameters="base").parameter_set()


def test_cli_identify_json_names_base_parameters_and_validate_uses_them(tmp_path, capsys):
    """``physid identify --method input-error --json`` on a URDF arm: base names, units, kept
    columns; the saved result validates at the filter's accuracy on its own record."""
    import json

    from physid.cli import main
    from physid.signals import save_recording

    model, rec, _ = _planar2_record(duration=4.0)
    csv = tmp_path / "rec.csv"
    save_recording(rec, csv)
    fit = tmp_path / "fit.json"
    argv = ["identify", str(csv), "--model", str(PLANAR2), "--method", "input-error"]
    code = main(argv + ["--half-width", "100", "--cutoff", "0.2", "--save", str(fit), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["parameter_set"] == "base"
    truth = _true_base(model)
    assert set(out["parameters"]) == set(truth) and set(out["units"]) == set(truth)
    assert out["units"]["mcx1R"] == "kg*m" and out["columns"][0] == "mcx1"
    rel = max(abs(out["parameters"][n] / v - 1) for n, v in truth.items())
    assert rel < 5e-5  # measured 1.2e-5, as in the Python fit above
    assert main(["validate", str(fit), str(csv), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["relative_error"]["overall"] < 1e-3


def test_results_holding_a_compiled_model_pickle_without_it():
    # ResultMixin._unpicklable_fields: a rigid-body model's compiled kernels do not pickle, so
    # IDIM's and input-error's results travel through a process pool without their model
    import pickle

    from physid.estimators.idim import IDIMEstimator

    model, rec, _ = _planar2_record(duration=2.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = [
            InputErrorEstimator(model, half_width=100, cutoff=0.2).fit(rec).result_,
            IDIMEstimator(model, "ols", decimate=1).fit(rec).result_,
        ]
    for r in results:
        back = pickle.loads(pickle.dumps(r))
        assert r.model is model and back.model is None
        assert back.parameters == r.parameters and back.names == r.names
