"""Linear-ODE models in physical terms: coefficient expressions, the map back to m, c, k,
identifiable combinations, the force-input MSD, output offsets and unit checks."""

from __future__ import annotations

import numpy as np
import pytest

import physid
from physid.errors import InputError, ModelFileError
from physid.models import load_model
from physid.models.linear_ode import LinearODEModel, msd_model
from physid.models.spec import parse_model_text, read_recording_map
from physid.signals import Recording

_FORCE_FILE = """
name = "axis"
kind = "linear_ode"
[parameters]
m = { value = 2.0, unit = "kg" }
c = { value = 0.4, unit = "N*s/m" }
k = { value = 50.0, unit = "N/m" }
offset = { value = 0.0, unit = "m" }
[ode]
a = ["k/m", "c/m"]
b = ["1/m"]
output_offset = "offset"
input_unit = "N"
output_unit = "m"
[recording]
t = "time"
x = "pos"
u = "gain*volt"
"""


def _model(text=_FORCE_FILE):
    from physid.models.library import model_from_spec

    return model_from_spec(parse_model_text(text, source="axis.toml"))


def test_expression_coefficients_get_names_and_nominal_values():
    model = _model()
    assert model.a_names == ("a0", "a1") and model.b_names == ("b0",)
    assert model.expressions == {"a0": "k/m", "a1": "c/m", "b0": "1/m"}
    assert model.physical_names == ("m", "c", "k")
    p = model.parameters
    assert (p["a0"], p["a1"], p["b0"]) == (25.0, 0.2, 0.5)
    assert model.unknown == ("a0", "a1", "b0")
    assert model.output_offset == "offset" and model.offset_unknown
    assert model.recording_map == {"t": "time", "x": "pos", "u": "gain*volt"}
    assert model.input_unit == "N" and model.output_unit == "m"
    # physical values give the coefficients: the simulator can be driven in m, c, k
    a, b = model.coefficients({"m": 4.0})
    np.testing.assert_allclose(a, [12.5, 0.1, 1.0])
    np.testing.assert_allclose(b, [0.25])


def test_physical_parameters_recovered_exactly_with_delta_method_stderr():
    model = _model()
    out = model.physical_from_coefficients({"a0": 133.3, "a1": 0.0167, "b0": 1 / 3})
    assert out.values == pytest.approx({"m": 3.0, "c": 0.0501, "k": 399.9}, rel=1e-12)
    assert out.identifiable == ("m", "c", "k") and not out.unidentifiable
    cov = np.diag([1e-2, 1e-6, 1e-6])
    se = model.physical_from_coefficients(
        {"a0": 133.3, "a1": 0.0167, "b0": 1 / 3}, covariance=cov
    ).stderr
    # m = 1/b0: σ_m = σ_b0 / b0²; k = a0/b0: σ_k² = (σ_a0/b0)² + (a0 σ_b0 / b0²)²
    assert se["m"] == pytest.approx(1e-3 * 9, rel=1e-9)
    assert se["k"] == pytest.approx(np.hypot(0.1 * 3, 133.3 * 1e-3 * 9), rel=1e-9)
    with pytest.raises(InputError, match=r"covariance must be \(3, 3\)"):
        model.physical_from_coefficients({"a0": 1.0, "a1": 1.0, "b0": 1.0}, covariance=np.eye(2))
    with pytest.raises(InputError, match=r"unknown name\(s\) \['theta1'\]"):
        model.physical_from_coefficients({"theta1": 1.0})


def test_without_a_force_only_the_ratios_are_identifiable():
    text = _FORCE_FILE.replace('b = ["1/m"]', 'b = ["1"]').replace('input_unit = "N"', "")
    model = _model(text)
    assert model.unknown == ("a0", "a1")  # b0 = 1 is a constant: never estimated
    out = model.physical_from_coefficients({"a0": 133.3, "a1": 0.0167})
    assert out.values == {} and out.unidentifiable == ("m", "c", "k")
    assert out.combinations == {"k/m": 133.3, "c/m": 0.0167}
    assert "not identifiable" in out.message and 'b = ["1/m"]' in out.message


def test_known_mass_makes_c_and_k_identifiable_from_the_ratios():
    text = _FORCE_FILE.replace('b = ["1/m"]', 'b = ["1"]').replace(
        'm = { value = 2.0, unit = "kg" }', 'm = { value = 3.0, unit = "kg", identify = false }'
    )
    out = _model(text).physical_from_coefficients({"a0": 133.3, "a1": 0.0167})
    assert out.values == pytest.approx({"c": 0.0501, "k": 399.9}, rel=1e-12)


def test_non_rational_expression_is_solved_numerically():
    text = _FORCE_FILE.replace('a = ["k/m", "c/m"]', 'a = ["exp(k)/m", "c/m"]').replace(
        'k = { value = 50.0, unit = "N/m" }', "k = { value = 3.0 }"
    )
    model = _model(text)
    truth = {"m": 2.5, "c": 0.3, "k": 3.2}
    coefs = {"a0": np.exp(3.2) / 2.5, "a1": 0.3 / 2.5, "b0": 1 / 2.5}
    assert model.physical_from_coefficients(coefs).values == pytest.approx(truth, rel=1e-8)


def test_force_msd_end_to_end_recovers_mass_damping_stiffness():
    from physid.estimators.recursive import RecursiveLeastSquares
    from physid.simulate import msd_paper_scenario

    rec = msd_paper_scenario(ratio=1.0)
    force = Recording(rec.t, np.column_stack([3.0 * rec["u"], rec["x"]]), ("u", "x"), ("N", "m"))
    model = load_model("msd-force")
    fit = RecursiveLeastSquares(model).fit(force).result_
    coefs = {k: fit.parameters[k] for k in ("theta2", "theta1", "b0")}
    phys = model.physical_from_coefficients(coefs)
    assert phys.values["m"] == pytest.approx(3.0, rel=1e-4)
    assert phys.values["k"] == pytest.approx(400.0, rel=1e-4)


def test_units_that_contradict_the_model_are_refused():
    force = Recording([0.0, 1.0], [[1.0, 0.0], [2.0, 0.1]], ["u", "x"], ["N", "m"])
    with pytest.raises(InputError, match=r"'u' is in N \(a force\), but model 'msd' takes its "):
        msd_model().check_units(force)
    msd_model(input="force").check_units(force)
    accel = Recording([0.0, 1.0], [[1.0, 0.0], [2.0, 0.1]], ["u", "x"], ["m/s^2", "mm"])
    msd_model().check_units(accel)  # mm is a length: fine (converted at load anyway)
    with pytest.raises(InputError, match=r"takes its input u in N"):
        msd_model(input="force").check_units(accel)
    unitless = Recording([0.0, 1.0], [[1.0, 0.0], [2.0, 0.1]], ["u", "x"])
    msd_model().check_units(unitless)  # no unit: nothing to check


@pytest.mark.parametrize(
    ("change", "pattern"),
    [
        (('a = ["k/m", "c/m"]', 'a = ["k/mm", "c/m"]'), r"unknown symbol 'mm' in ode\.a"),
        (('a = ["k/m", "c/m"]', 'a = ["k/m", "__import__(1)"]'), r"not allowed|unknown"),
        (('output_offset = "offset"', 'output_offset = "bias"'), r"output_offset must name"),
        (('input_unit = "N"', 'input_unit = "furlong"'), r"unknown unit 'furlong'"),
        (('[recording]\nt = "time"', "[recording]\nt = 3"), r"recording\.t must be a string"),
        (
            ('output_unit = "m"', 'output_unit = "m"\nfoo = 1'),
            r"unknown key\(s\) \['foo'\] in \[ode\]",
        ),
    ],
)
def test_model_file_errors(change, pattern):
    with pytest.raises(ModelFileError, match=pattern):
        _model(_FORCE_FILE.replace(*change))


def test_recording_map_of_a_model_file(tmp_path):
    path = tmp_path / "axis.toml"
    path.write_text(_FORCE_FILE)
    assert read_recording_map(path) == {"t": "time", "x": "pos", "u": "gain*volt"}
    assert physid.load_model(path).recording_map == read_recording_map(path)


def test_plain_models_are_unchanged():
    model = msd_model()
    assert model.expressions == {} and model.physical_names == () and model.output_offset is None
    assert model.physical_from_coefficients({"theta1": 1.0}).values == {}
    three = LinearODEModel("third", ("a0", "a1", "a2"), ("b0",), dict(a0=6, a1=11, a2=6, b0=2))
    assert three.unknown == ("a0", "a1", "a2", "b0")


def test_estimators_refuse_a_force_for_the_normalised_msd():
    from physid.estimators.algebraic import AlgebraicEstimator
    from physid.estimators.recursive import RecursiveLeastSquares
    from physid.simulate import msd_paper_scenario

    rec = msd_paper_scenario(ratio=1.0)
    force = Recording(rec.t, np.column_stack([3.0 * rec["u"], rec["x"]]), ("u", "x"), ("N", "m"))
    for est in (AlgebraicEstimator(msd_model()), RecursiveLeastSquares(msd_model())):
        with pytest.raises(InputError, match=r"'u' is in N \(a force\), but model 'msd'"):
            est.fit(force)
