"""IDIM-IV simulates the controller that ran: PD plus gravity (and friction) feed-forward
(estimators/idim/iv.py)."""

from pathlib import Path

import numpy as np
import pytest

import physid
from physid.errors import InputError
from physid.estimators.idim import IDIMEstimator
from physid.estimators.idim.base_parameters import base_regressor_info
from physid.simulate import simulate_closed_loop

URDF = Path(__file__).parent / "data" / "planar2.urdf"
KP, KD = [20.0, 10.0], [2.5, 1.25]  # soft gains: PD alone would sag ~0.3 rad under gravity
ROWS = {"cutoff": 0.25, "decimate": 4}  # light filtering: the noise bias of OLS is large


def _reference(t):
    return np.array(
        [
            0.8 * np.sin(1.1 * t) + 0.3 * np.sin(2.9 * t + 0.4),
            0.9 * np.sin(1.7 * t + 1.0) + 0.4 * np.sin(3.7 * t),
        ]
    )


@pytest.fixture(scope="module")
def planar2():
    model = physid.load_model(URDF)
    info = base_regressor_info(model)
    truth = info.from_standard(model.beta(model.parameter_vector(None)))
    return model, truth


def _log(model, seed, noise=2e-3):
    return simulate_closed_loop(
        model, kp=KP, kd=KD, reference=_reference, duration=8.0, dt=0.005,
        feedforward="gravity", noise_std=noise, rng=seed,
    )  # fmt: skip


def test_iv_with_the_logged_controller_beats_iv_assuming_pd(planar2):
    """PD + g(q), σ_q = 2e-3 rad, 4 seeds. Measured relative errors of the 6 base parameters,
    rms over seeds and parameters: OLS 0.221, IV with PD + g 0.0044, IV assuming PD 0.0162."""
    model, truth = planar2
    errs = {"ols": [], "right": [], "pd": []}
    for seed in range(4):
        rec = _log(model, seed)
        assert rec.metadata["feedforward"] == "gravity"
        fits = {
            "ols": IDIMEstimator(model, "ols", **ROWS),
            "right": IDIMEstimator(model, "iv", **ROWS),  # the controller from the metadata
            "pd": IDIMEstimator(model, "iv", feedforward="none", **ROWS),
        }
        for key, est in fits.items():
            r = est.fit(rec).result_
            errs[key].append(np.abs(r.beta_vector() / truth - 1))
            if key == "right":
                assert r.success and 2 <= r.iterations < 10, r.message
                assert "IV simulated the controller tau = Kp (r - q) - Kd qd + g(q)" in r.message
            if key == "pd":
                assert "IV simulated the controller tau = Kp (r - q) - Kd qd." in r.message
    rms = {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in errs.items()}
    assert max(float(np.max(e)) for e in errs["right"]) < 0.02  # every parameter within 2 %
    assert rms["right"] < 0.006
    assert rms["pd"] > 2.5 * rms["right"]  # measured 3.65×
    assert rms["ols"] > 10 * rms["right"]


def test_explicit_feedforward_overrides_the_metadata(planar2):
    """feedforward="gravity" on a recording whose metadata lost it gives the metadata's fit."""
    from physid.signals.recording import Recording

    model, _ = planar2
    rec = _log(model, 0)
    meta = {k: v for k, v in rec.metadata.items() if k not in ("feedforward", "controller")}
    bare = Recording(rec.t, rec.data, rec.names, metadata=meta)
    a = IDIMEstimator(model, "iv", **ROWS).fit(rec).result_
    b = IDIMEstimator(model, "iv", feedforward="gravity", **ROWS).fit(bare).result_
    c = IDIMEstimator(model, "iv", **ROWS).fit(bare).result_  # no metadata: pure PD
    np.testing.assert_array_equal(a.beta_vector(), b.beta_vector())
    assert "Kd qd." in c.message and not np.array_equal(a.beta_vector(), c.beta_vector())


def test_unknown_feedforward_is_refused(planar2):
    model, _ = planar2
    rec = _log(model, 0)
    with pytest.raises(InputError, match=r"feedforward='computed-torque'.*one of"):
        IDIMEstimator(model, "iv", feedforward="computed-torque", **ROWS).fit(rec)


@pytest.mark.parametrize("value", [["gravity"], {"kind": "gravity"}])
def test_feedforward_of_another_type_is_refused_not_a_type_error(planar2, value):
    """A list or table where the name of a feed-forward belongs (an edited metadata, a Python
    caller): the same clear error as an unknown name, from the fit and from validate."""
    import dataclasses

    from physid.analysis.validation.output_error import check_controller

    model, _ = planar2
    rec = _log(model, 0)
    with pytest.raises(InputError, match="feedforward=.*one of"):
        IDIMEstimator(model, "iv", feedforward=value, **ROWS).fit(rec)
    edited = dataclasses.replace(rec, metadata={**rec.metadata, "feedforward": value})
    with pytest.raises(InputError, match="metadata feedforward=.*one of"):
        IDIMEstimator(model, "iv", **ROWS).fit(edited)
    with pytest.raises(InputError, match="feedforward must be one of"):
        check_controller(2, feedforward=value)


def test_validate_simulates_the_feedforward_the_fit_was_given(planar2, tmp_path):
    """A log without metadata (the user's own), fitted with feedforward="gravity" and the gains
    given: the result file keeps both, and validate re-simulates PD + g(q) with them, not PD
    alone (which sags ~0.3 rad under gravity with these soft gains)."""
    import dataclasses

    from physid.analysis.validation import load_result, validate
    from physid.estimators.results import save_result

    model, _ = planar2
    bare = [dataclasses.replace(_log(model, s, noise=1e-4), metadata={}) for s in (0, 1)]
    fit = IDIMEstimator(model, "iv", kp=KP, kd=KD, feedforward="gravity", **ROWS).fit(bare[0])
    path = save_result(
        fit.result_, tmp_path / "fit.json", model=str(URDF),
        gains={"kp": KP, "kd": KD}, feedforward="gravity",
    )  # fmt: skip
    report = validate(load_result(path), bare[1])
    note = next(n for n in report.notes if n.startswith("(b)"))
    assert "Kd qd + g(q) with kp [20, 10] (from the result file)" in note, note
    assert "feed-forward from the result file" in note
    assert min(report.fit_percent.values()) > 99.0, report.fit_percent


def test_cli_iv_reads_the_controller_from_the_log_or_the_flag(tmp_path):
    """simulate --feedforward gravity → identify --method idim-iv: the log's controller by
    default; --feedforward overrides it; refused with a method that does not simulate."""
    import contextlib
    import io
    import json

    from physid.cli import main

    log = str(tmp_path / "run.csv")
    quiet = contextlib.redirect_stderr(io.StringIO())
    argv = ["simulate", "model", str(URDF), "--feedforward", "gravity", "--duration", "6"]
    with contextlib.redirect_stdout(io.StringIO()), quiet:
        assert main([*argv, "--noise-std", "1e-3", "--seed", "1", "--out", log]) == 0
    messages = {}
    for extra in ([], ["--feedforward", "none"]):
        out = io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
            argv = ["identify", log, "--model", str(URDF), "--method", "idim-iv", "--json"]
            assert main([*argv, *extra]) == 0
        messages[tuple(extra)] = json.loads(out.getvalue())["message"]
    assert "IV simulated the controller tau = Kp (r - q) - Kd qd + g(q)" in messages[()]
    assert (
        "IV simulated the controller tau = Kp (r - q) - Kd qd."
        in messages[("--feedforward", "none")]
    )
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        argv = ["identify", log, "--model", str(URDF), "--method", "idim-ols"]
        assert main([*argv, "--feedforward", "gravity"]) != 0
    assert "--feedforward applies to --method idim-iv" in err.getvalue()
