"""`physid validate` on structures: fit [%] and the residual tests of every output."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import physid
from physid.analysis.validation.structure import summary_lines, validate_structure
from physid.estimators import make
from physid.estimators.equation_error import StructureResult
from physid.signals.excitation import multisine
from physid.simulate.structure import simulate_structure

CHAIN2 = Path(__file__).resolve().parents[1] / "examples" / "models" / "chain2.toml"


@pytest.fixture(scope="module")
def chain():
    return physid.load_model(CHAIN2)


def _held_out(chain, seed, snr=None):
    """A multisine force test simulated on the 1 kHz samples themselves (the force linear
    between samples, as validate simulates it)."""
    rng = np.random.default_rng(seed)
    t = np.arange(8000) * 1e-3
    omegas = 2 * np.pi * np.arange(0.25, 25.01, 0.25)
    force = 10 * multisine(t, omegas, 1.0, phases=rng.uniform(0, 2 * np.pi, omegas.size))
    rec = simulate_structure(chain, t, {"F": force})
    if snr is None:
        return rec
    data = rec.select(["F", "x1", "x2"]).copy()
    data[:, 1:] += (
        rng.standard_normal((t.size, 2)) * np.std(data[:, 1:], axis=0) * 10 ** (-snr / 20)
    )
    return type(rec)(t, data, ["F", "x1", "x2"], ["N", "m", "m"])


def _truth(chain, **changes):
    params = {**chain.parameters, **changes}
    return StructureResult(
        method="equation-error",
        names=tuple(params),
        parameters=params,
        stderr=None,
        stderr_reason=None,
        units={},
        success=True,
        message="",
        model=chain,
    )


def test_noise_free_record_with_the_true_parameters_is_consistent(chain):
    coarse = _held_out(chain, 1)
    fine_t = np.arange(79_991) * 1e-4  # the same force, linear between the 1 kHz samples
    fine = simulate_structure(chain, fine_t, {"F": np.interp(fine_t, coarse.t, coarse["F"])})
    data = fine.select(["F", "x1", "x2"])[::10]
    rec = type(coarse)(coarse.t, data, ["F", "x1", "x2"], ["N", "m", "m"])
    assert np.max(np.abs(data[:, 1:] - coarse.select(["x1", "x2"]))) > 0  # not the same numbers
    report = validate_structure(_truth(chain), rec)
    assert report["consistent"] and report["verdict"].startswith("consistent")
    assert min(report["fit_percent"].values()) > 99.999
    assert set(report["residual"]) == {"x1", "x2"}
    assert report["residual"]["x1"]["band"] == pytest.approx(2.5758293 / np.sqrt(8000))


def test_wrong_stiffness_misses_dynamics_even_with_its_covariance(chain):
    rec = _held_out(chain, 2, snr=40)
    fit = make("equation-error", chain).fit(_held_out(chain, 3, snr=40)).result_
    good = validate_structure(fit, rec)
    assert good["consistent"], good["verdict"]
    wrong = replace(fit, parameters={**fit.parameters, "k2": 1.2 * fit.parameters["k2"]})
    report = validate_structure(wrong, rec)
    assert not report["consistent"]
    assert report["verdict"].startswith("the model misses dynamics")
    assert not report["residual"]["x1"]["independent"]
    evidence = report["residual"]["x1"]["evidence"]
    assert evidence["parameter_error_mahalanobis2"] > 100 * evidence["parameter_error_limit"]
    text = "\n".join(summary_lines(report))
    assert "verdict: the model misses dynamics" in text and "x2: " in text


def test_command_line_validate_prints_the_residual_tests(chain, tmp_path, capsys):
    from physid.cli import main

    fit, held = tmp_path / "fit.csv", tmp_path / "held.csv"
    _held_out(chain, 4, snr=40).save(fit)
    _held_out(chain, 5, snr=40).save(held)
    result = tmp_path / "r.json"
    assert main(["estimate", str(fit), "--model", str(CHAIN2), "--save", str(result)]) == 0
    capsys.readouterr()
    assert main(["validate", str(result), str(held), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["consistent"] is True
    assert set(out["residual"]) == {"x1", "x2"}
    assert len(out["residual"]["x2"]["cross_correlation"][0]) == 51
    data = json.loads(result.read_text())
    data["parameters"]["k2"] *= 1.2
    result.write_text(json.dumps(data))
    assert main(["validate", str(result), str(held)]) == 1
    text = capsys.readouterr().out
    assert "x1: " in text and "verdict: the model misses dynamics" in text


@pytest.mark.parametrize("method", ["rls", "algebraic"])
def test_single_output_estimators_refuse_a_structure_naming_the_ones_that_apply(chain, method):
    from physid.errors import InputError

    with pytest.raises(InputError, match=r"Structure models .* make\('equation-error'"):
        make(method, chain).fit(_held_out(chain, 6))


def test_untestable_residual_with_a_covariance_is_reported_not_a_traceback(chain):
    # a held-out record with no force and no motion: every residual is constant, so no test can
    # run; the parameter-error explanation (which needs a covariance) must leave it unexplained
    held = _held_out(chain, 6)
    zero = type(held)(held.t, np.zeros((held.t.size, 3)), ["F", "x1", "x2"], ["N", "m", "m"])
    truth = replace(_truth(chain), covariance=np.eye(len(chain.parameters)) * 1e-6)
    report = validate_structure(truth, zero)
    assert not report["consistent"]
    assert report["verdict"].startswith("not testable: the residual of x1, x2")
    assert "no whiteness test is possible" in report["verdict"]
