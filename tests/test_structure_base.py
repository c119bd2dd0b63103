"""Base motions in structure models: M q̈ + C q̇ + K q = B u + K_b x_b + C_b ẋ_b, checked against
the analytic transfer function, scipy.signal and a seeded identification."""

import re
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

import physid
from physid.analysis.modal import frequency_response
from physid.errors import InputError, ModelFileError
from physid.estimators import make
from physid.models.library import model_from_spec
from physid.models.spec import parse_model_text
from physid.signals.excitation import multisine
from physid.signals.recording import Recording
from physid.simulate.structure import simulate_structure

QUARTER_CAR = Path(__file__).resolve().parents[1] / "examples" / "models" / "quarter_car.toml"

ONE_MASS = """
kind = "structure"
name = "base1"
[parameters]
m = { value = 2.0, unit = "kg" }
c = { value = 3.0, unit = "N*s/m" }
k = { value = 800.0, unit = "N/m" }
[[masses]]
name = "x"
mass = "m"
[[base_motions]]
name = "xb"
channel = "xb"
[[springs]]
between = ["xb", "x"]
stiffness = "k"
[[dampers]]
between = ["x", "xb"]
damping = "c"
[[outputs]]
displacement = "x"
[[outputs]]
velocity = "x"
channel = "v"
"""

CHAIN = """
kind = "structure"
name = "chain2b"
[parameters]
m1 = { value = 2.0, unit = "kg", identify = false }
m2 = { value = 1.0, unit = "kg" }
k1 = { value = 1500.0, unit = "N/m" }
k2 = { value = 3000.0, unit = "N/m" }
c1 = { value = 4.0, unit = "N*s/m" }
c2 = { value = 2.0, unit = "N*s/m" }
[[masses]]
name = "x1"
mass = "m1"
[[masses]]
name = "x2"
mass = "m2"
[[base_motions]]
name = "xb"
channel = "xb"
[[springs]]
between = ["xb", "x1"]
stiffness = "k1"
[[springs]]
between = ["x1", "x2"]
stiffness = "k2"
[[dampers]]
between = ["xb", "x1"]
damping = "c1"
[[dampers]]
between = ["x1", "x2"]
damping = "c2"
[[outputs]]
displacement = "x1"
[[outputs]]
displacement = "x2"
"""


def _model(text):
    return model_from_spec(parse_model_text(text, source="b.toml"))


def test_one_mass_transfer_function_is_the_analytic_one_to_1e9():
    m = _model(ONE_MASS)
    assert m.input_names == ("xb",) and m.force_names == () and m.base_nodes == ("xb",)
    omega = np.logspace(-1, 3, 200)
    H = frequency_response(m, omega).response[:, :, 0]
    s = 1j * omega
    x_over_xb = (3 * s + 800) / (2 * s**2 + 3 * s + 800)
    np.testing.assert_allclose(H[:, 0], x_over_xb, rtol=1e-9, atol=0)
    np.testing.assert_allclose(H[:, 1], s * x_over_xb, rtol=1e-9, atol=0)


def test_base_columns_follow_the_springs_and_dampers_that_touch_the_base():
    # a base joined to both masses: K_b = [k1, k3], C_b = [c1, 0]; K, C hold −k on the diagonal
    text = CHAIN + '[[springs]]\nbetween = ["x2", "xb"]\nstiffness = "2*k2 + 7"\n'
    m = _model(text)
    Cb, Kb = m.base_matrices()
    np.testing.assert_array_equal(Kb, [[1500.0], [6007.0]])
    np.testing.assert_array_equal(Cb, [[4.0], [0.0]])
    M, C, K = m.matrices()
    np.testing.assert_array_equal(K, [[4500.0, -3000.0], [-3000.0, 9007.0]])
    np.testing.assert_array_equal(C, [[6.0, -2.0], [-2.0, 2.0]])
    # against (M s² + C s + K)⁻¹ (K_b + C_b s) written out
    omega = np.array([0.3, 7.0, 31.0, 55.0, 400.0])
    H = frequency_response(m, omega).response[:, :, 0]
    for w, h in zip(omega, H, strict=True):
        s = 1j * w
        direct = np.linalg.solve(M * s**2 + C * s + K, (Kb + Cb * s)[:, 0])
        np.testing.assert_allclose(h, direct, rtol=1e-9)


def test_simulation_agrees_with_scipy_lsim_for_displacement_and_velocity():
    m = _model(ONE_MASS)
    t = np.arange(4000) * 1e-3
    xb = 0.01 * np.sin(2 * np.pi * 3 * t) * np.minimum(t / 0.2, 1) + 0.002 * np.sin(50 * t)
    rec = simulate_structure(m, t, {"xb": xb}, states=True)
    num_x, num_v = [3.0, 800.0], [3.0, 800.0, 0.0]
    den = [2.0, 3.0, 800.0]
    x_ref = signal.lsim((num_x, den), xb, t)[1]
    v_ref = signal.lsim((num_v, den), xb, t)[1]
    scale = np.max(np.abs(x_ref))
    assert np.max(np.abs(rec["x"] - x_ref)) < 1e-9 * scale
    assert np.max(np.abs(rec["v"] - v_ref)) < 1e-9 * np.max(np.abs(v_ref))
    # the recorded q̇ is the true velocity, not the internal state q̇ − M⁻¹C_b x_b
    np.testing.assert_allclose(rec["qd_x"], rec["v"], rtol=0, atol=1e-12)


def _base_record(model, seed, snr=40.0):
    """A multisine base displacement, simulated at 10 kHz, sampled at 1 kHz, noise on every
    measured channel (base included)."""
    rng = np.random.default_rng(seed)
    fine = np.arange(200_000) * 1e-4
    omegas = 2 * np.pi * np.arange(0.25, 25.01, 0.25)
    xb = 0.01 * multisine(fine, omegas, 1.0, phases=rng.uniform(0, 2 * np.pi, omegas.size))
    names = [model.base_names[0], *model.output_names]
    data = simulate_structure(model, fine, {names[0]: xb}).select(names)[::10].copy()
    data += rng.standard_normal(data.shape) * np.sqrt(np.mean(data**2, axis=0) / 10 ** (snr / 10))
    return Recording(fine[::10], data, names, ["m"] * len(names))


def test_base_excited_chain_identified_by_equation_error_within_1_percent():
    m = _model(CHAIN)
    res = make("equation-error", m).fit(_base_record(m, 3)).result_
    assert res.success and not res.input_noisy  # base noise is regressor noise, compensated
    truth = m.parameters
    assert set(res.parameters) == {"m2", "k1", "k2", "c1", "c2"}
    for name, (lo, hi) in res.confidence_intervals().items():
        assert abs(res.parameters[name] / truth[name] - 1) < 0.01, name
        assert lo <= truth[name] <= hi, name


def test_quarter_car_by_output_error_within_1_percent_and_intervals_withheld():
    m = physid.load_model(QUARTER_CAR)
    res = make("output-error", m).fit(_base_record(m, 4)).result_
    truth = m.parameters
    for name, value in res.parameters.items():
        assert abs(value / truth[name] - 1) < 0.01, name
    assert res.stderr is None and "xr" in res.stderr_reason  # the base is a noisy input


def test_base_motion_alone_does_not_fix_the_scale():
    m = _model(CHAIN)
    free = m.identifiability(m.parameter_names)
    assert set(free.unidentifiable) == set(m.parameter_names)
    same = ", ".join(f"{p} (?P=s)1" for p in ("m2", "k1", "k2", "c1", "c2"))
    assert re.search(rf"m1 (?P<s>[+-])1, {same} \(in proportion", free.message)
    assert not m.identifiability().unidentifiable  # m1 known: the rest follows


BAD = [
    (
        CHAIN.replace(
            'between = ["xb", "x1"]\nstiffness', 'between = ["ground", "x1"]\nstiffness'
        ).replace('between = ["xb", "x1"]\ndamping', 'between = ["ground", "x1"]\ndamping'),
        r"b\.toml.*base_motions\[0\].*base 'xb' is joined to no mass",
    ),
    (
        CHAIN.replace('name = "xb"\nchannel', 'name = "x2"\nchannel'),
        r"b\.toml.*base_motions\[0\].*base 'x2' has the name of a mass",
    ),
    (
        CHAIN + '[[forces]]\non = "xb"\nchannel = "F"\n',
        r"b\.toml.*forces\[0\].*'xb' is a base",
    ),
    (
        CHAIN + '[[outputs]]\ndisplacement = "xb"\nchannel = "y"\n',
        r"b\.toml.*outputs\[2\].*'xb' is a base",
    ),
    (
        CHAIN + '[[outputs]]\nacceleration = "x1"\nchannel = "a1"\nanti_aliasing = "4-pole"\n',
        r"b\.toml.*outputs\[2\].*acceleration of 'x1'.*dampers\[0\]",
    ),
    (
        CHAIN.replace('stiffness = "k1"', 'stiffness = "k1"\ncubic = "k2"'),
        r"b\.toml.*springs\[0\].*cubic spring on base 'xb'",
    ),
    (
        CHAIN + '[[dampers]]\nbetween = ["ground", "xb"]\ndamping = "c1"\n',
        r"b\.toml.*dampers\[2\].*between 'ground' and 'xb' joins no mass",
    ),
    (
        CHAIN.replace('name = "xb"\nchannel = "xb"', 'name = "xb"\nchannel = "x1"'),
        r"channel 'x1' is already used",
    ),
]


@pytest.mark.parametrize(("text", "match"), BAD)
def test_bad_base_motions_are_refused_naming_the_element_and_file(text, match):
    with pytest.raises(ModelFileError, match=match):
        _model(text)


def test_missing_base_channel_names_the_base_and_the_file():
    m = _model(CHAIN)
    rec = _base_record(m, 5)
    no_base = Recording(rec.t, rec.select(["x1", "x2"]), ["x1", "x2"], ["m", "m"])
    with pytest.raises(InputError, match=r"lacks channel\(s\) \['xb'\].*b\.toml.*base 'xb'"):
        make("equation-error", m).fit(no_base)
    with pytest.raises(InputError, match=r"lacks channel\(s\) \['xb'\].*b\.toml.*base"):
        simulate_structure(m, rec.t, {"F": rec.t})


def test_cli_simulates_a_road_file_and_identifies_the_quarter_car(tmp_path, capsys):
    from physid.cli import main

    t = np.arange(20_000) * 1e-3
    omegas = 2 * np.pi * np.arange(0.25, 25.01, 0.25)
    rng = np.random.default_rng(0)
    xr = 0.01 * multisine(t, omegas, 1.0, phases=rng.uniform(0, 2 * np.pi, omegas.size))
    road, out = tmp_path / "road.csv", tmp_path / "qc.csv"
    np.savetxt(road, np.column_stack([t, xr]), delimiter=",", header="t,xr", comments="")
    assert (
        main(["simulate", "model", str(QUARTER_CAR), "--reference", str(road), "--out", str(out)])
        == 0
    )
    m = physid.load_model(QUARTER_CAR)
    rec = physid.load_recording(out)
    direct = simulate_structure(m, t, {"xr": xr})
    np.testing.assert_allclose(rec.select(["xw", "xs"]), direct.select(["xw", "xs"]), atol=1e-12)
    capsys.readouterr()
    assert (
        main(["estimate", str(out), "--model", str(QUARTER_CAR), "--method", "equation-error"]) == 0
    )
    text = capsys.readouterr().out
    for name in ("mw", "ks", "cs", "kt", "ct"):  # sampled at 1 kHz: the FOH shift, < 0.2 %
        value = float(re.search(rf"{name} = ([0-9.e+-]+)", text).group(1))
        assert abs(value / m.parameters[name] - 1) < 0.01, name
    chain2 = QUARTER_CAR.parent / "chain2.toml"
    assert (
        main(["simulate", "model", str(chain2), "--reference", str(road), "--out", str(out)]) != 0
    )
    assert "has no channel(s) ['F']" in capsys.readouterr().err
