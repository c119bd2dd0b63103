"""Honest residual verdicts for IDIM results: the torque residual is judged against the colouring
the parallel filter and decimation give white torque noise, noise on the measured positions, and
the model.

A 4 s arm6 run (seeded, no noise as simulated) validated with its true base parameters: with
white torque noise added the residual is coloured exactly as the filter predicts (consistent);
with white noise on the positions it names input noise; with link 3's mass, first moments and
inertia 20 % off it names the model.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import physid
from physid.analysis.validation import validate
from physid.analysis.validation.inverse_residual import (
    bartlett_band,
    expected_autocorrelation,
)
from physid.analysis.validation.loaded import LoadedResult
from physid.cli import main
from physid.estimators.idim import base_regressor_info
from physid.estimators.idim.decimation import decimated_noise_correlation

MODEL = physid.load_model("arm6")
INFO = base_regressor_info(MODEL)
TRUE = INFO.from_standard(MODEL.beta())


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    path = tmp_path_factory.mktemp("arm6") / "run.csv"
    assert main(["simulate", "arm6", "--out", str(path), "--duration", "4", "--quiet"]) == 0
    return physid.load_recording(path)


def _loaded(beta):
    return LoadedResult(
        method="idim-ols", model=MODEL, parameters=dict(zip(INFO.names, beta, strict=True)),
        derived={}, stderr=None, units={}, data={"method": "idim-ols", "names": list(INFO.names)},
    )  # fmt: skip


def _noisy(rec, *, torque=0.0, position=0.0, seed=0):
    """White noise on the torques (a fraction of each one's std) or on the positions [rad]."""
    rng = np.random.default_rng(seed)
    cols = []
    for name in rec.names:
        x = np.asarray(rec[name], dtype=float)
        if name.startswith("tau"):
            x = x + rng.normal(0.0, torque * float(np.std(x)), x.size)
        elif name.startswith("q") and not name.startswith("qd"):
            x = x + rng.normal(0.0, position, x.size)
        cols.append(x)
    return dataclasses.replace(rec, data=np.column_stack(cols))


def _wrong_mass():
    """Link 3's inertial parameters (mass, first moments, inertia) 20 % too large."""
    std = np.array(MODEL.beta(), dtype=float)
    for i, name in enumerate(INFO.column_names):
        if name.endswith("3") and not name.startswith(("F", "Ia")):
            std[i] *= 1.2
    return INFO.from_standard(std)


def test_expected_autocorrelation_without_gaps_is_the_filters():
    rho = decimated_noise_correlation(4, 64)
    got = expected_autocorrelation(rho, np.arange(500), np.ones(500, bool), 5)
    # Σ_{t<n−l} ρ_l / n = ρ_l (1 − l/n): the biased estimate's expectation
    np.testing.assert_allclose(got, rho[1:6] * (1 - np.arange(1, 6) / 500), rtol=1e-12)
    # a gap of 100 rows: pairs across it are uncorrelated (ρ is 0 beyond 64 lags)
    idx = np.r_[np.arange(250), np.arange(350, 600)]
    across = expected_autocorrelation(rho, idx, np.ones(500, bool), 1)[0]
    assert across == pytest.approx(rho[1] * 498 / 500, rel=1e-12)


def test_bartlett_band_of_white_noise_is_one_over_root_n():
    white = np.r_[1.0, np.zeros(30)]
    np.testing.assert_allclose(bartlett_band(white, 400, 25), np.full(25, 0.05), rtol=1e-12)
    # a sample of MA(1) noise: var(r_k) = (1 + 2ρ₁²)/n for k ≥ 2 (Bartlett)
    ma = np.r_[1.0, 0.4, np.zeros(30)]
    assert bartlett_band(ma, 400, 3)[2] == pytest.approx(np.sqrt((1 + 2 * 0.16) / 400))


def test_true_parameters_noise_free_are_consistent(run):
    res = validate(_loaded(TRUE), run).residual
    assert not res["white"]  # the plain test blames the numerical error
    assert res["explanation"] == "resolution"
    assert res["verdict"].startswith("consistent")
    assert res["evidence"]["relative_residual"] < 1e-4


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("level", [0.02, 0.1])
def test_white_torque_noise_is_coloured_as_the_filter_predicts(run, seed, level):
    res = validate(_loaded(TRUE), _noisy(run, torque=level, seed=seed)).residual
    assert res["explanation"] == "filter", res["verdict"]
    assert res["verdict"].startswith("consistent (correlation as the filter predicts)")
    assert "model misses" not in res["verdict"]
    assert res["evidence"]["decimate"] > 1  # the filter colours: ρ₁ ≠ 0
    assert abs(res["evidence"]["rho"][0]) > 0.05
    assert max(res["evidence"]["filter_lags_outside"]) <= 1


@pytest.mark.parametrize("seed", [0, 1])
def test_position_noise_names_input_noise(run, seed):
    res = validate(_loaded(TRUE), _noisy(run, position=1e-3, seed=seed)).residual
    assert not res["white"]
    assert res["explanation"] == "input noise", res["verdict"]
    assert "noise on the measured positions" in res["verdict"]
    assert "model misses" not in res["verdict"]
    # the bound from the positions' second difference is the noise put in (smooth motion)
    assert res["evidence"]["position_noise_bound"] == pytest.approx(1e-3, rel=0.05)
    assert res["evidence"]["position_noise_explained_pooled"] > 0.6


@pytest.mark.parametrize(("torque", "position"), [(0.0, 0.0), (0.02, 0.0), (0.01, 1e-4)])
def test_wrong_mass_is_blamed_on_the_model(run, torque, position):
    rec = _noisy(run, torque=torque, position=position, seed=3)
    res = validate(_loaded(_wrong_mass()), rec).residual
    assert res["explanation"] == "model"
    assert res["verdict"].startswith("the model misses dynamics")
    assert max(res["evidence"]["filter_lags_outside"]) >= 10
    assert res["evidence"]["position_noise_explained_pooled"] < 0.3
