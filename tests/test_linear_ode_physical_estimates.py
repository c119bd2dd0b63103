"""Linear-ODE models in physical terms give m, c, k with standard errors.

A model file with ``a = ["k/m", "c/m"]``, ``b = ["1/m"]`` and a force input: the algebraic and
RLS results carry m, c, k in ``derived`` with units and delta-method standard errors
(``derived_stderr``, from ``final_covariance``); without a force (``b = ["1"]``) the result and
the CLI say that only k/m and c/m are identifiable; ``physid model info`` shows the physical
parameters as estimated or as combinations, with units.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import signal

import physid
from physid.cli import main
from physid.errors import InputError
from physid.estimators._linear import derived_with_stderr
from physid.estimators.algebraic import AlgebraicEstimator
from physid.estimators.recursive import RecursiveLeastSquares
from physid.models import load_model
from physid.models.library import model_from_spec
from physid.models.linear_ode import expression_unit
from physid.models.spec import parse_model_text
from physid.signals import Multisine, Recording, add_white_noise, save_recording
from physid.simulate import simulate_msd

MASS, DAMPING, STIFFNESS = 2.5, 3.0, 900.0  # the truth [kg], [N·s/m], [N/m]
TRUTH = {"m": MASS, "c": DAMPING, "k": STIFFNESS}

FORCE_FILE = """
name = "rig"
kind = "linear_ode"
[parameters]
m = { value = 1.0, unit = "kg" }
c = { value = 1.0, unit = "N*s/m" }
k = { value = 100.0, unit = "N/m" }
[ode]
a = ["k/m", "c/m"]
b = ["1/m"]
input_unit = "N"
output_unit = "m"
"""
# no force measurement: u = F/m, b0 = 1 carries no scale
RATIO_FILE = FORCE_FILE.replace('b = ["1/m"]', 'b = ["1"]').replace(
    'input_unit = "N"', 'input_unit = "m/s^2"'
)


def _model(text=FORCE_FILE):
    return model_from_spec(parse_model_text(text, source="rig.toml"))


def _clean(duration=2.0):
    omega0 = np.sqrt(STIFFNESS / MASS)
    u = Multisine(omega0 * np.array([0.5, 1.0, 2.0]), np.array([20.0, 15.0, 10.0]) / MASS)
    return simulate_msd(
        mass=MASS, damping=DAMPING, stiffness=STIFFNESS, input=u, duration=duration, dt=1e-3
    )


def _force_record(clean, seed, snr_db=50.0):
    x, _ = add_white_noise(clean["x"], snr_db=snr_db, rng=seed)
    return Recording(clean.t, np.column_stack([clean["u"] * MASS, x]), ("u", "x"), ("N", "m"))


@pytest.fixture(scope="module")
def clean():
    return _clean()


@pytest.fixture(scope="module")
def files(tmp_path_factory, clean):
    root = tmp_path_factory.mktemp("phys")
    (root / "rig.toml").write_text(FORCE_FILE)
    (root / "ratios.toml").write_text(RATIO_FILE)
    force = save_recording(_force_record(clean, 3), root / "force.csv")
    x, _ = add_white_noise(clean["x"], snr_db=50.0, rng=3)
    accel = Recording(clean.t, np.column_stack([clean["u"], x]), ("u", "x"), ("m/s^2", "m"))
    return root, str(force), str(save_recording(accel, root / "accel.csv"))


# ------------------------------------------------------------------------------ units
def test_coefficient_units_follow_from_the_declared_parameter_units():
    model = _model()
    assert (model.units["a0"], model.units["a1"], model.units["b0"]) == ("1/s^2", "1/s", "1/kg")
    assert expression_unit("c/m", {"c": "N*s/m", "m": "kg"}) == "1/s"
    assert expression_unit("k/m + c", {"k": "N/m", "m": "kg", "c": "N*s/m"}) == ""  # unlike
    assert expression_unit("exp(k)/m", {"k": "N/m", "m": "kg"}) == ""
    assert expression_unit("k/m", {"k": "", "m": "kg"}) == ""  # k has no unit


# ------------------------------------------------------------------------------ estimators
@pytest.mark.parametrize("method", ["algebraic", "rls"])
def test_model_file_in_physical_terms_gives_m_c_k_with_stderr(method, clean):
    """m, c, k of the 2.5 kg / 3 N·s/m / 900 N/m rig at 50 dB (2 s at 1 kHz): within 0.5 %
    (m, k) and 1.5 % (c) of the truth and within 4 of their standard errors."""
    rec = _force_record(clean, 3)
    est = (
        AlgebraicEstimator(_model(), final="bias-compensated")
        if method == "algebraic"
        else RecursiveLeastSquares(_model())
    )
    res = est.fit(rec).result_
    assert res.success and res.names == ("a0", "a1", "b0")
    assert set(res.derived) == {"m", "c", "k"}
    assert res.units["m"] == "kg" and res.units["k"] == "N/m" and res.units["b0"] == "1/kg"
    se = res.derived_stderr
    for p, rel in (("m", 5e-3), ("c", 1.5e-2), ("k", 5e-3)):
        assert res.derived[p] == pytest.approx(TRUTH[p], rel=rel)
        assert 0 < se[p] < 0.01 * TRUTH[p]
        assert abs(res.derived[p] - TRUTH[p]) < 4 * se[p]
    assert res.physical["identifiable"] == ["m", "c", "k"] and res.message == ""
    # the final covariance is the accessor: the Python map gives the same standard errors
    phys = res.model.physical_from_coefficients(res.parameters, covariance=res.final_covariance)
    assert phys.stderr == pytest.approx(se, rel=1e-12)
    np.testing.assert_allclose(np.sqrt(np.diag(res.final_covariance)), list(res.stderr.values()))
    frame = res.to_pandas()
    assert frame.loc["m", "stderr"] == pytest.approx(se["m"]) and frame.loc["m", "unit"] == "kg"
    assert "± " in [line for line in res.summary().splitlines() if line.strip().startswith("m ")][0]


def test_msd_force_derived_quantities_have_stderr(clean):
    res = RecursiveLeastSquares(load_model("msd-force")).fit(_force_record(clean, 3)).result_
    se = res.derived_stderr
    assert set(se) == {"natural_frequency", "damping_ratio", "mass", "damping", "stiffness"}
    assert res.derived["mass"] == pytest.approx(MASS, rel=5e-3)
    assert abs(res.derived["mass"] - MASS) < 4 * se["mass"]
    assert res.units["mass"] == "kg" and res.units["damping"] == "N*s/m"
    assert not np.isnan(res.to_pandas().loc["stiffness", "stderr"])
    d = json.loads(json.dumps(res.to_dict(), allow_nan=False))
    assert d["derived_stderr"]["mass"] == pytest.approx(se["mass"])
    assert set(d["stderr"]) == set(d["names"])  # stderr stays the fitted parameters'
    # the covariance history is not the covariance of the final estimate: a clear refusal
    with pytest.raises(InputError, match=r"covariance history.*final_covariance"):
        res.model.physical_from_coefficients(res.parameters, covariance=res.covariance)


def test_derived_stderr_withheld_with_the_coefficients(clean):
    """At 20 dB the RLS default withholds its biased intervals: the derived ones go too."""
    res = RecursiveLeastSquares(_model()).fit(_force_record(clean, 1, snr_db=20.0)).result_
    assert res.stderr is None and "bias" in res.stderr_reason
    assert res.derived_stderr is None and res.final_covariance is None
    assert set(res.derived) == {"m", "c", "k"}
    assert np.isnan(res.to_pandas().loc["m", "stderr"])


# ------------------------------------------------------------------------------ delta method
def _fd_stderr(fun, x0, cov, rel_step=1e-5):
    """sqrt(diag(J Σ Jᵀ)) with J by central differences of ``fun`` at ``x0``."""
    x0 = np.asarray(x0, dtype=float)
    cols = []
    for i in range(x0.size):
        h = rel_step * abs(x0[i])
        up, down = x0.copy(), x0.copy()
        up[i] += h
        down[i] -= h
        cols.append((np.asarray(fun(up)) - np.asarray(fun(down))) / (2 * h))
    J = np.column_stack(cols)
    return np.sqrt(np.diag(J @ cov @ J.T))


@pytest.mark.parametrize(
    "text",
    [
        FORCE_FILE,
        # not rational: solved numerically, the Jacobian still symbolic
        FORCE_FILE.replace('a = ["k/m", "c/m"]', 'a = ["exp(k/300)/m", "c/m"]'),
    ],
)
def test_delta_method_matches_finite_differences(text):
    model = _model(text)
    truth = {"m": 2.5, "c": 3.0, "k": 900.0}
    coefs = {
        c: float(v) for c, v in model.parameter_values(truth).items() if c in ("a0", "a1", "b0")
    }
    x0 = np.array([coefs[c] for c in ("a0", "a1", "b0")])
    rng = np.random.default_rng(0)
    L = rng.normal(size=(3, 3)) * 1e-3 * x0
    cov = L @ L.T  # correlated
    out = model.physical_from_coefficients(coefs, covariance=cov)
    assert out.values == pytest.approx(truth, rel=1e-10)

    def fun(x):
        v = model.physical_from_coefficients(dict(zip(("a0", "a1", "b0"), x, strict=True))).values
        return [v["m"], v["c"], v["k"]]

    fd = _fd_stderr(fun, x0, cov)
    np.testing.assert_allclose([out.stderr[p] for p in ("m", "c", "k")], fd, rtol=1e-6)


def test_natural_frequency_and_damping_ratio_delta_method():
    model = load_model("msd-force")
    values = {"theta2": 360.0, "theta1": 1.2, "b0": 0.4}
    names = ("theta2", "theta1", "b0")
    rng = np.random.default_rng(1)
    L = rng.normal(size=(3, 3)) * 1e-3
    cov = L @ L.T
    derived, se, _, _ = derived_with_stderr(model, values, names, cov)
    assert derived["mass"] == pytest.approx(2.5) and derived["stiffness"] == pytest.approx(900.0)

    def fun(x):
        d, _, _, _ = derived_with_stderr(model, dict(zip(names, x, strict=True)), names)
        return [d[k] for k in derived]

    fd = _fd_stderr(fun, [values[n] for n in names], cov)
    np.testing.assert_allclose([se[k] for k in derived], fd, rtol=1e-6)


def test_mass_interval_coverage():
    """RLS on 200 records (2 s, 50 dB white output noise, seeds 0-199): the 95 % interval of
    the mass covers the truth in 95 % of them (measured 95.0 %; asserted 92-98 %, about two
    binomial standard deviations), and m̂ − m has the spread its standard error says."""
    clean = _clean()
    model = _model()
    z = []
    for seed in range(200):
        res = RecursiveLeastSquares(model).fit(_force_record(clean, seed)).result_
        z.append((res.derived["m"] - MASS) / res.derived_stderr["m"])
    z = np.array(z)
    coverage = float(np.mean(np.abs(z) < 1.96))
    assert 0.92 <= coverage <= 0.98, coverage
    assert 0.9 < np.std(z) < 1.15


# ------------------------------------------------------------------------------ CLI
def test_cli_estimate_prints_m_c_k(files, capsys):
    root, force, _ = files
    assert main(["estimate", force, "--model", str(root / "rig.toml"), "--method", "rls"]) == 0
    out = capsys.readouterr().out
    lines = {line.split("=")[0].strip(): line for line in out.splitlines() if "=" in line}
    assert "[1/kg]" in lines["b0"] and "[kg]" in lines["m"] and "±" in lines["m"]
    assert "[N/m]" in lines["k"] and "±" in lines["k"]
    argv = ["estimate", force, "--model", str(root / "rig.toml"), "--json"]
    assert main([*argv, "--final", "bias-compensated"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert set(d["derived"]) == {"m", "c", "k"} and d["units"]["m"] == "kg"
    assert d["derived_stderr"]["m"] > 0 and d["physical"]["identifiable"] == ["m", "c", "k"]
    assert d["derived"]["m"] == pytest.approx(MASS, rel=5e-3)


def test_cli_says_which_combinations_are_identifiable(files, capsys):
    root, _, accel = files
    argv = ["estimate", accel, "--model", str(root / "ratios.toml"), "--method", "rls"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "m, c, k are not identifiable" in out
    assert "only 2 combinations are identifiable, k/m, c/m (k/m = 360" in out
    assert main([*argv, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["derived"] == {} and d["physical"]["unidentifiable"] == ["m", "c", "k"]
    assert set(d["physical"]["combinations"]) == {"k/m", "c/m"}
    assert d["physical"]["combinations"]["k/m"] == pytest.approx(STIFFNESS / MASS, rel=1e-3)
    assert "identifiable, k/m, c/m" in d["message"] and d["success"] is True


def test_model_info_shows_physical_parameters(files, capsys):
    root, _, _ = files
    assert main(["model", "info", str(root / "rig.toml")]) == 0
    out = capsys.readouterr().out
    assert "a0 = 100 1/s^2  = k/m  (estimated)" in out
    assert "b0 = 1 1/kg  = 1/m  (estimated)" in out
    assert "m = 1 kg  (estimated)" in out and "(fixed)" not in out
    assert "physical parameters: m, c, k estimated from a0 = k/m, a1 = c/m, b0 = 1/m" in out
    assert main(["model", "info", str(root / "ratios.toml")]) == 0
    out = capsys.readouterr().out
    assert "m = 1 kg  (not identifiable alone)" in out and "b0 = 1 1  = 1  (fixed)" in out
    assert "only the combinations a0 = k/m, a1 = c/m are estimated" in out
    assert main(["model", "info", str(root / "ratios.toml"), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    entry = {p["name"]: p for p in info["parameters"]}
    assert entry["m"]["identify"] and not entry["m"]["identifiable"] and entry["m"]["unit"] == "kg"
    assert entry["a0"]["expression"] == "k/m" and entry["a0"]["unit"] == "1/s^2"
    assert info["physical"]["unidentifiable"] == ["m", "c", "k"]
    assert main(["model", "info", "msd-force"]) == 0
    assert "reports them as mass, damping, stiffness" in capsys.readouterr().out


def test_an_input_gain_without_a_declared_unit_takes_y_over_u_s_to_the_k():
    # the time exponent used to rise with k (b0 of an m/N model read s^4/kg)
    from physid.estimators._linear import coefficient_units
    from physid.models.linear_ode import LinearODEModel

    values = {"theta2": 1.0, "theta1": 1.0, "b0": 1.0, "b1": 1.0}
    m = LinearODEModel(
        "g", ("theta2", "theta1"), ("b0", "b1"), values, input_unit="N", output_unit="m"
    )
    units = coefficient_units(m, ["theta2", "theta1", "b0", "b1"])
    assert units == {"theta2": "1/s^2", "theta1": "1/s", "b0": "1/kg", "b1": "s/kg"}


def test_plain_msd_with_a_fitted_b0_gives_mass_stderr_by_the_delta_method():
    # mass, damping, stiffness of the plain msd with b0 fitted used to have NaN errors
    from physid.models import msd_model

    model = msd_model()
    values = {"theta2": 360.0, "theta1": 1.2, "b0": 0.4}
    cov = np.diag([0.01, 1e-4, 1e-6])  # ordered like fitted
    fitted = ["theta2", "theta1", "b0"]
    derived, se, _, _ = derived_with_stderr(model, values, fitted, cov)
    assert derived["mass"] == pytest.approx(2.5)
    # m = 1/b0: sd = sd(b0)/b0² = 1e-3/0.16; k = θ2/b0: sd² = (0.1/0.4)² + (360·1e-3/0.16)²
    assert se["mass"] == pytest.approx(1e-3 / 0.16, rel=1e-12)
    assert se["stiffness"] == pytest.approx(np.hypot(0.1 / 0.4, 360 * 1e-3 / 0.16), rel=1e-12)


def test_a_negative_input_gain_gives_no_mass():
    from physid.models import load_model

    model = load_model("msd-force")
    for b0 in (-2.0, 0.0):
        derived, _, _, _ = derived_with_stderr(
            model, {"theta2": 4.0, "theta1": 0.2, "b0": b0}, ["theta2", "theta1", "b0"]
        )
        assert "mass" not in derived and "stiffness" not in derived


# ------------------------------------------------------------------ an estimated output offset
def test_physical_parameters_from_a_result_with_an_estimated_offset(tmp_path):
    """A model in physical terms with an estimated offset: the result's parameters (offset
    included) and full covariance go to physical_from_coefficients as they are."""
    t = np.arange(6000) * 1e-3
    force = 20 * np.sin(10 * t) + 10 * np.sin(23 * t)
    x = signal.lsim(([1 / 2.5], [1.0, 3 / 2.5, 900 / 2.5]), force, t)[1]
    rec = Recording(t, np.c_[force, x + 0.01], ["u", "x"], units=["N", "m"])
    path = tmp_path / "phys.toml"
    path.write_text(
        'name = "mck"\nkind = "linear_ode"\n[parameters]\nm = { value = 2.0, unit = "kg" }\n'
        'c = { value = 2.0, unit = "N*s/m" }\nk = { value = 800.0, unit = "N/m" }\n'
        'offset = { value = 0.0, unit = "m" }\n[ode]\na = ["k/m", "c/m"]\nb = ["1/m"]\n'
        'input_unit = "N"\noutput_offset = "offset"\n',
        encoding="utf-8",
    )
    model = physid.load_model(path)
    res = RecursiveLeastSquares(model).fit(rec).result_
    assert "offset" in res.parameters
    phys = model.physical_from_coefficients(res.parameters, covariance=res.final_covariance)
    assert phys.values["m"] == pytest.approx(2.5, rel=1e-3)
    assert phys.values["k"] == pytest.approx(900.0, rel=1e-3)
    assert phys.stderr["m"] == pytest.approx(res.derived_stderr["m"], rel=1e-9)
