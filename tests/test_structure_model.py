"""Structure model files (kind = "structure"): parsing, bad input, matrices, identifiability,
simulation against scipy."""

from pathlib import Path

import numpy as np
import pytest

import physid
from physid.errors import ModelFileError
from physid.models.library import model_from_spec
from physid.models.spec import parse_model_text
from physid.simulate.structure import simulate_structure, structure_response

CHAIN2 = Path(__file__).resolve().parents[1] / "examples" / "models" / "chain2.toml"
TEXT = CHAIN2.read_text()


def _model(text):
    return model_from_spec(parse_model_text(text, source="m.toml"))


def test_chain2_matrices_are_the_hand_derived_ones():
    m = physid.load_model(CHAIN2)
    M, C, K = m.matrices()
    assert np.array_equal(M, [[2, 0], [0, 1]])
    assert np.array_equal(K, [[4500, -3000], [-3000, 3000]])
    assert np.array_equal(C, [[6, -2], [-2, 2]])
    assert m.linear_in_parameters and not m.nonlinear


def test_matrices_given_directly_equal_the_elements():
    text = (
        TEXT.split("[[masses]]")[0]
        + """
[matrices]
nodes = ["x1", "x2"]
M = [["m1", 0], [0, "m2"]]
C = [["c1 + c2", "-c2"], ["-c2", "c2"]]
K = [["k1 + k2", "-k2"], ["-k2", "k2"]]
[[forces]]
on = "x1"
channel = "F"
[[outputs]]
displacement = "x2"
"""
    )
    a, b = _model(text), physid.load_model(CHAIN2)
    for x, y in zip(a.matrices(), b.matrices(), strict=True):
        assert np.array_equal(x, y)


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        (
            'between = ["x1", "x2"]\nstiffness',
            'between = ["x1", "x1"]\nstiffness',
            r"line \d+ \(springs\[1\]\).*itself",
        ),
        ('mass = "m2"', "mass = 0", r"masses\[1\].*is 0"),
        ('displacement = "x2"', 'displacement = "x3"', r"outputs\[1\].*'x3' is not a node"),
        ('displacement = "x2"', 'acceleration = "x2"', r"anti_aliasing"),
        ('stiffness = "k1"', 'stiffness = "kk"', r"unknown symbol 'kk'"),
    ],
)
def test_bad_input_names_the_element_and_the_line(old, new, match):
    with pytest.raises(ModelFileError, match=match):
        _model(TEXT.replace(old, new, 1))


def test_an_output_no_input_reaches_is_refused():
    text = TEXT.replace(
        'between = ["x1", "x2"]\nstiffness = "k2"', 'between = ["ground", "x2"]\nstiffness = "k2"'
    )
    text = text.replace('between = ["x1", "x2"]\ndamping', 'between = ["ground", "x2"]\ndamping')
    with pytest.raises(ModelFileError, match=r"no input reaches node 'x2'"):
        _model(text)


def test_singular_mass_matrix_is_refused():
    text = (
        TEXT.split("[[masses]]")[0]
        + """
[matrices]
nodes = ["x1", "x2"]
M = [["m1", "m1"], ["m1", "m1"]]
K = [["k1", 0], [0, "k2"]]
[[forces]]
on = "x1"
[[outputs]]
displacement = "x1"
"""
    )
    with pytest.raises(ModelFileError, match=r"matrices.M.*singular"):
        _model(text)


@pytest.mark.parametrize("outputs", [("x1", "x2"), ("x2",), ("x1",)])
def test_all_six_identifiable_from_force_and_displacements(outputs):
    text = TEXT.split("[[outputs]]")[0] + "".join(
        f'[[outputs]]\ndisplacement = "{o}"\n' for o in outputs
    )
    ident = _model(text).identifiability()
    assert ident.identifiable == ("m1", "m2", "k1", "k2", "c1", "c2")
    assert ident.unidentifiable == () and ident.rank == 6


def test_a_redundant_parameter_is_named_unidentifiable():
    text = TEXT.replace(
        'm1 = { value = 2.0, unit = "kg" }',
        'm1 = { value = 2.0, unit = "kg" }\ng1 = { value = 1.0 }',
    )
    text = text.replace('mass = "m1"', 'mass = "m1*g1"')
    ident = _model(text).identifiability()
    assert set(ident.unidentifiable) == {"m1", "g1"}
    assert (
        "m1 +1" in ident.directions[0]
        and "g1 +1" in ident.directions[0]
        or "-1" in ident.directions[0]
    )


def test_simulation_matches_scipy_lsim_foh():
    from scipy.signal import StateSpace, lsim

    m = physid.load_model(CHAIN2)
    t = np.arange(0, 5, 1e-3)
    force = np.random.default_rng(0).standard_normal(t.size)
    _, y = structure_response(m, t, force[:, None])
    _, y_ref, _ = lsim(StateSpace(*m.state_space()), force, t, interp=True)
    assert np.max(np.abs(y - y_ref)) < 1e-10 * np.max(np.abs(y_ref))


def test_duffing_simulation_against_solve_ivp():
    from scipy.integrate import solve_ivp

    text = TEXT.replace('stiffness = "k1"', 'stiffness = "k1"\ncubic = "k3"').replace(
        "[parameters]", '[parameters]\nk3 = { value = 1.0e6, unit = "N/m**3" }'
    )
    m = _model(text)
    t = np.arange(0, 2, 1e-3)
    force = 20 * np.sin(2 * np.pi * 3 * t)
    rec = simulate_structure(m, t, {"F": force}, states=True)
    M, C, K = m.matrices()

    def rhs(tt, x):
        f = np.interp(tt, t, force)
        q, v = x[:2], x[2:]
        nl = np.array([1e6 * q[0] ** 3, 0.0])
        return np.concatenate([v, np.linalg.solve(M, [f, 0] - C @ v - K @ q - nl)])

    ref = solve_ivp(rhs, (0, t[-1]), np.zeros(4), t_eval=t, rtol=1e-11, atol=1e-14, max_step=1e-3)
    x2 = rec["x2"]
    assert np.max(np.abs(x2 - ref.y[1])) < 1e-6 * np.max(np.abs(ref.y[1]))
    assert 1e6 * np.max(np.abs(ref.y[0])) ** 2 > 0.1 * 1500  # the cubic term matters here
