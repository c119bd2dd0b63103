"""Equation-error and output-error identification of structures (seeded, stated tolerances)."""

from pathlib import Path

import numpy as np
import pytest

import physid
from physid.errors import EstimationError
from physid.estimators import make
from physid.estimators.equation_error import channel_noise, fit_percent
from physid.models.library import model_from_spec
from physid.models.spec import parse_model_text
from physid.signals.excitation import multisine
from physid.signals.recording import Recording
from physid.simulate.structure import simulate_structure

CHAIN2 = Path(__file__).resolve().parents[1] / "examples" / "models" / "chain2.toml"
DUFFING = """
kind = "structure"
name = "duffing"
[parameters]
m = { value = 1.0, unit = "kg" }
c = { value = 4.0, unit = "N*s/m" }
k = { value = 400.0, unit = "N/m" }
k3 = { value = 1.0e5, unit = "N/m**3" }
[[masses]]
name = "x"
mass = "m"
[[springs]]
between = ["ground", "x"]
stiffness = "k"
cubic = "k3"
[[dampers]]
between = ["ground", "x"]
damping = "c"
[[forces]]
on = "x"
channel = "F"
[[outputs]]
displacement = "x"
"""


def chain_record(model, seed, *, out_snr=40.0, in_snr=None, duration=20.0, outputs=("x1", "x2")):
    """A multisine force test of the chain: simulated at 10 kHz, sampled at 1 kHz."""
    rng = np.random.default_rng(seed)
    fine = np.arange(int(duration * 10_000)) * 1e-4
    omegas = 2 * np.pi * np.arange(0.25, 25.01, 0.25)
    force = 10 * multisine(fine, omegas, 1.0, phases=rng.uniform(0, 2 * np.pi, omegas.size))
    names = ["F", *outputs]
    data = simulate_structure(model, fine, {"F": force}).select(names)[::10].copy()
    for j in range(1, len(names)):
        data[:, j] += rng.standard_normal(len(data)) * np.sqrt(
            np.mean(data[:, j] ** 2) / 10 ** (out_snr / 10)
        )
    if in_snr is not None:
        data[:, 0] += rng.standard_normal(len(data)) * np.sqrt(
            np.mean(data[:, 0] ** 2) / 10 ** (in_snr / 10)
        )
    return Recording(fine[::10], data, names, ["N"] + ["m"] * len(outputs))


@pytest.fixture(scope="module")
def chain():
    return physid.load_model(CHAIN2)


def test_chain2_known_force_every_parameter_within_1_percent_and_its_interval(chain):
    res = make("equation-error", chain).fit(chain_record(chain, 1)).result_
    assert res.success and not res.input_noisy
    truth = chain.parameters
    for name, (lo, hi) in res.confidence_intervals().items():
        assert abs(res.parameters[name] / truth[name] - 1) < 0.01, name
        assert lo <= truth[name] <= hi, name
    assert min(res.fit_percent.values()) > 98.5  # 40 dB noise caps the fit at 99 %


def test_noise_free_record_gives_the_parameters_to_1e4(chain):
    res = make("equation-error", chain).fit(chain_record(chain, 2, out_snr=200)).result_
    for name, value in res.parameters.items():
        assert abs(value / chain.parameters[name] - 1) < 1e-4, name


def test_noise_level_is_estimated_from_the_spectrum_above_the_band():
    rng = np.random.default_rng(3)
    t = np.arange(20_000) * 1e-3
    x = np.sin(2 * np.pi * 2 * t) + 0.01 * rng.standard_normal(t.size)
    est = channel_noise(x, 1e-3, band=2 * np.pi * 5)
    assert est["variance"] == pytest.approx(1e-4, rel=0.05)
    assert est["snr_db"] == pytest.approx(10 * np.log10(0.5 / 1e-4), abs=0.3)


def test_noisy_force_is_said_and_equation_error_intervals_cover(chain):
    rec = chain_record(chain, 4, in_snr=30)
    res = make("equation-error", chain).fit(rec).result_
    assert res.input_noisy and "measured with noise" in res.message
    assert res.noise["F"]["snr_db"] == pytest.approx(30, abs=1)
    for name, (lo, hi) in res.confidence_intervals().items():
        assert lo <= chain.parameters[name] <= hi, name


def test_output_error_withholds_intervals_when_the_force_is_noisy(chain):
    rec = chain_record(chain, 5, in_snr=30, duration=8.0)
    res = make("output-error", chain).fit(rec).result_
    assert res.stderr is None and "errors in variables" in res.stderr_reason
    assert abs(res.parameters["k2"] / 3000 - 1) < 0.02


def test_output_error_on_one_displacement(chain):
    text = CHAIN2.read_text().split("[[outputs]]")[0] + '[[outputs]]\ndisplacement = "x2"\n'
    model = model_from_spec(parse_model_text(text))
    rec = chain_record(model, 6, duration=8.0, outputs=("x2",))
    with pytest.raises(EstimationError, match=r"displacement of every node.*output-error"):
        make("equation-error", model).fit(rec)
    start = {k: v * 1.1 for k, v in model.parameters.items()}
    res = make("output-error", model, initial=start).fit(rec).result_
    assert res.success
    for name, value in res.parameters.items():
        assert abs(value / model.parameters[name] - 1) < 0.01, name
        assert abs(value - model.parameters[name]) < 4 * res.stderr[name], name


def test_duffing_cubic_stiffness_within_2_percent_and_held_out_fit():
    model = model_from_spec(parse_model_text(DUFFING))
    t = np.arange(0, 4, 1e-3)
    omegas = 2 * np.pi * np.arange(0.5, 10.01, 0.5)
    recs = []
    for seed in (7, 8):
        rng = np.random.default_rng(seed)
        force = multisine(t, omegas, 1.0, phases=rng.uniform(0, 2 * np.pi, omegas.size))
        clean = simulate_structure(model, t, {"F": 10 * force / np.std(force)})
        data = clean.select(["F", "x"]).copy()
        data[:, 1] += rng.standard_normal(t.size) * np.std(data[:, 1]) * 0.01  # 40 dB
        recs.append((Recording(t, data, ["F", "x"], ["N", "m"]), clean))
    res = make("equation-error", model).fit(recs[0][0]).result_
    assert abs(res.parameters["k3"] / 1e5 - 1) < 0.02
    assert 1e5 * np.std(recs[0][1]["x"]) ** 2 / 400 > 0.2  # the cubic term is not small
    held, clean = recs[1]
    sim = res.predict(held)
    assert fit_percent(clean.select(["x"]), sim.select(["x"]))[0] > 99.0


def test_command_line_estimate_model_info_and_validate(chain, tmp_path, capsys):
    import json

    from physid.cli import main

    fit, held = tmp_path / "fit.csv", tmp_path / "held.csv"
    chain_record(chain, 21, duration=10.0).save(fit)
    chain_record(chain, 22, duration=10.0).save(held)
    assert main(["model", "info", str(CHAIN2)]) == 0
    assert "all 6 linear parameters (m1, m2, k1, k2, c1, c2) are identifiable" in (
        capsys.readouterr().out
    )
    result = tmp_path / "r.json"
    code = main(
        ["estimate", str(fit), "--model", str(CHAIN2), "--modal", "--json", "--save", str(result)]
    )
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["method"] == "equation-error"
    assert abs(out["parameters"]["k2"] / 3000 - 1) < 0.01
    assert out["modal"]["frequency_hz"][0] == pytest.approx(3.4535, rel=1e-3)
    assert main(["validate", str(result), str(held), "--json"]) == 0
    fits = json.loads(capsys.readouterr().out)["fit_percent"]
    assert set(fits) == {"x1", "x2"} and min(fits.values()) > 98.5
    code = main(["estimate", str(fit), "--model", str(CHAIN2), "--method", "rls"])
    assert code == 2
    assert "--method rls does not apply to structure model" in capsys.readouterr().err
