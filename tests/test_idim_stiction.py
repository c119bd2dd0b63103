"""IDIM drops the equations of Coulomb joints near rest (stiction), where the regressor is wrong.

With exact Coulomb friction in simulation a PD-controlled joint sticks whenever its
drive torque is below Fc; the holding friction is then anywhere in [−Fc, Fc] while the regressor
writes Fc·sign(0) = 0. On the 1-DOF pendulum (stuck 0.14 s of a 10 s run) keeping those equations
biases mcz1 by ~5 % on noise-free data; dropping them recovers every base parameter to 1e-3.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import physid
from physid.errors import InputError
from physid.estimators.idim import IDIMEstimator, base_regressor_info, idim_rows
from physid.simulate.closed_loop import simulate_closed_loop

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="module")
def case():
    model = physid.load_model(DATA / "pendulum1.toml")
    t = np.arange(0.0, 10.0, 1e-3)
    r = 0.8 * np.sin(2 * np.pi * 0.5 * t) + 0.3 * np.sin(2 * np.pi * 1.3 * t + 0.4)
    rec = simulate_closed_loop(
        model, kp=[200.0], kd=[2 * np.sqrt(40.0)], reference=(r - r[0])[:, None], t=t
    )
    return model, rec


def _errors(model, rec, threshold):
    info = base_regressor_info(model)
    truth = info.from_standard(model.beta())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = IDIMEstimator(model, "ols", stick_threshold=threshold).fit(rec).result_
    return np.abs(res.beta_vector() - truth) / np.abs(truth), res


def test_dropping_stuck_equations_removes_the_stiction_bias(case):
    model, rec = case
    assert rec.metadata["coulomb"]["stick_time"][0] > 0.05  # [s]: the joint really sticks
    kept, _ = _errors(model, rec, 0.0)
    dropped, res = _errors(model, rec, 0.05)
    assert kept.max() > 0.02  # stiction biases the fit that keeps every equation
    assert dropped.max() < 1e-3
    assert res.relative_error["overall"] < 1e-3
    assert "joint equations dropped near rest" in res.message


def test_stuck_mask_marks_rest_and_zeroes_those_rows(case):
    model, rec = case
    rows = idim_rows(model, rec, stick_threshold=0.05)
    assert rows.stuck is not None and 0.05 < rows.stuck.mean() < 0.6
    assert np.all(rows.W[rows.stuck] == 0.0) and np.all(rows.tau[rows.stuck] == 0.0)
    # every stuck sample of the simulation lies inside a dropped row's neighbourhood
    stuck_t = rec.t[rec["qd1"] == 0.0]
    row_t = rows.t[rows.stuck[:, 0]]
    inside = stuck_t[(stuck_t > rows.t[0]) & (stuck_t < rows.t[-1])]
    gap = np.min(np.abs(inside[:, None] - row_t[None, :]), axis=1)
    assert np.all(gap <= rows.decimate * rec.dt * 1.01)
    assert idim_rows(model, rec).stuck is None  # off by default in idim_rows


def test_bad_stick_threshold_is_refused(case):
    model, rec = case
    with pytest.raises(InputError, match="stick_threshold"):
        IDIMEstimator(model, stick_threshold=1.5).fit(rec)


def test_input_error_base_fit_drops_stuck_equations_too(case):
    # input-error over the base parameters of a URDF arm keeps every filtered sample unless told
    # otherwise; near rest it now drops them as IDIM does (before: mcz1, Fv1, Fc1 off by ~5 %).
    from physid.estimators.input_error import InputErrorEstimator

    model, rec = case
    bp = model.base_parameters()
    truth = np.asarray(bp.base_matrix, dtype=float) @ np.asarray(model.beta(), dtype=float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = InputErrorEstimator(model).fit(rec).result_
    est = np.array([res.parameters[n] for n in bp.base_names])
    # measured 1.1e-3 dropping where the joint sticks and next to the reversals whose friction
    # step the residual shows (the earlier speed rule: below 1e-3; every equation kept: 1.1e-2)
    assert np.max(np.abs(est - truth) / np.abs(truth)) < 2e-3
    notes = [w for w in res.warnings if "joint equations dropped: " in w and "sticks" in w]
    assert len(notes) == 1
    dropped, total = (int(x) for x in notes[0].split(" joint")[0].split(" of "))
    assert 0 < dropped < 0.5 * total  # the main lobe, not the whole filter length
