"""TOML model files: the shipped manipulator, explicit transforms, linear ODEs, error messages."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import physid
from physid.errors import ModelFileError
from physid.models import load_model, load_model_file
from physid.models.library import model_from_spec
from physid.models.spec import check_nominal_values, parse_model_text, symbolic_chain

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "models" / "manipulator.toml"
PACKAGED = ROOT / "src" / "physid" / "models" / "data" / "manipulator.toml"


def write(tmp_path, text, name="model.toml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def states(n=20, nj=4, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-3, 3, (n, nj)), rng.normal(size=(n, nj)), rng.normal(size=(n, nj))


def test_example_file_is_the_packaged_file():
    assert EXAMPLE.read_text(encoding="utf-8") == PACKAGED.read_text(encoding="utf-8")


def test_toml_manipulator_equals_builtin():
    from_file = load_model(EXAMPLE)
    builtin = load_model("manipulator")
    assert from_file.parameter_names == ("m1", "m2", "m3", "m4", "l1", "l2", "l3", "l4")
    assert from_file.parameters == {
        "m1": 50.0,
        "m2": 25.0,
        "m3": 15.0,
        "m4": 5.0,
        "l1": 0.4,
        "l2": 0.8,
        "l3": 0.6,
        "l4": 0.2,
    }
    assert from_file.units["m1"] == "kg" and from_file.units["l4"] == "m"
    assert from_file.gravity == (0.0, 0.0, 9.81)
    q, qd, qdd = states()
    np.testing.assert_array_equal(
        from_file.inverse_dynamics(q, qd, qdd), builtin.inverse_dynamics(q, qd, qdd)
    )
    paper = load_model_file(EXAMPLE, kinetic="paper")
    assert paper.kinetic == "paper"


PAPER_TRANSFORMS = """
name = "manipulator_explicit"
gravity = [0, 0, 9.81]
[parameters]
m1 = { value = 50.0, unit = "kg" }
m2 = { value = 25.0, unit = "kg" }
m3 = { value = 15.0, unit = "kg" }
m4 = { value = 5.0, unit = "kg" }
l1 = { value = 0.4, unit = "m" }
l2 = { value = 0.8, unit = "m" }
l3 = { value = 0.6, unit = "m" }
l4 = { value = 0.2, unit = "m" }

# the paper's T1..T4, typed as printed (Cedro & Janecki, section 2)
[[joints]]
transform = [
  ["cos(q1)", 0, "sin(q1)", 0],
  ["sin(q1)", 0, "-cos(q1)", 0],
  [0, 1, 0, 0],
  [0, 0, 0, 1],
]
mass = "m1"
rotor_inertia = "m1*l1**2/12"
[[joints]]
transform = [
  ["cos(q2)", "-sin(q2)", 0, "l2*cos(q2)"],
  ["sin(q2)", "cos(q2)", 0, "l2*sin(q2)"],
  [0, 0, 1, 0],
  [0, 0, 0, 1],
]
mass = "m2"
rotor_inertia = "m2*l2^2/12"
[[joints]]
transform = [
  ["cos(q3)", "-sin(q3)", 0, "l3*cos(q3)"],
  ["sin(q3)", "cos(q3)", 0, "l3*sin(q3)"],
  [0, 0, 1, 0],
  [0, 0, 0, 1],
]
mass = "m3"
rotor_inertia = "m3*l3**2/12"
[[joints]]
transform = [
  ["cos(q4)", "-sin(q4)", 0, "l4*cos(q4)"],
  ["sin(q4)", "cos(q4)", 0, "l4*sin(q4)"],
  [0, 0, 1, 0],
  [0, 0, 0, 1],
]
mass = "m4"
rotor_inertia = "m4*l4**2/12"
"""


@pytest.mark.parametrize("kinetic", ["exact", "paper"])
def test_explicit_paper_transforms_equal_the_dh_model(tmp_path, kinetic):
    explicit = load_model(write(tmp_path, PAPER_TRANSFORMS), kinetic=kinetic)
    dh = load_model("manipulator", kinetic=kinetic)
    q, qd, qdd = states(seed=1)
    np.testing.assert_allclose(
        explicit.inverse_dynamics(q, qd, qdd),
        dh.inverse_dynamics(q, qd, qdd),
        rtol=1e-11,
        atol=1e-9,
    )
    np.testing.assert_allclose(explicit.mass_matrix(q), dh.mass_matrix(q), rtol=1e-11, atol=1e-11)


def test_linear_ode_file(tmp_path):
    path = write(
        tmp_path,
        """
name = "msd_file"
kind = "linear_ode"
[parameters]
theta1 = { value = 0.5, unit = "1/s" }
theta2 = { value = 100.0, unit = "1/s^2" }
b0 = { value = 2.0, identify = false }
[ode]
a = ["theta2", "theta1"]
b = ["b0"]
""",
    )
    model = load_model(path)
    assert model.a_names == ("theta2", "theta1") and model.b_names == ("b0",)
    assert model.unknown == ("theta1", "theta2")
    a, b = model.coefficients()
    np.testing.assert_allclose(a, [100.0, 0.5, 1.0])
    np.testing.assert_allclose(b, [2.0])


GOOD_HEAD = """name = "arm"
gravity = [0, 0, -9.81]
[parameters]
m1 = { value = 1.0, unit = "kg" }
l1 = { value = 0.5, unit = "m" }
"""


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        # TOML syntax error: tomllib reports the line
        (GOOD_HEAD + '[[joints]]\ndh = { a = l1 }\nmass = "m1"\n', r"not valid TOML: .*line 7"),
        # unknown symbol, with its line and the fix
        (
            GOOD_HEAD + '[[joints]]\ndh = { a = "l2" }\nmass = "m1"\n',
            r"line 7 .*unknown symbol\(s\) \['l2'\].*declare each under \[parameters\]",
        ),
        # expression that does not parse
        (
            GOOD_HEAD + '[[joints]]\ndh = { a = "l1 *" }\nmass = "m1"\n',
            r"line 7 .*cannot parse the expression 'l1 \*'",
        ),
        # unknown function
        (
            GOOD_HEAD + '[[joints]]\ndh = { a = "foo(l1)" }\nmass = "m1"\n',
            r"unknown function\(s\) \['foo'\]",
        ),
        # transform not 4×4
        (
            GOOD_HEAD + '[[joints]]\ntransform = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\nmass = "m1"\n',
            r"line 7 .*transform must be a 4×4 homogeneous matrix.*got 3 rows",
        ),
        # rotation part not orthonormal
        (
            GOOD_HEAD + '[[joints]]\ntransform = [["cos(q1)", "sin(q1)", 0, "l1"], '
            '["sin(q1)", "cos(q1)", 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\nmass = "m1"\n',
            r"line 7 .*rotation part .* is not orthonormal",
        ),
        # a transform that uses another joint's variable
        (
            GOOD_HEAD + '[[joints]]\ntransform = [["cos(q2)", "-sin(q2)", 0, 0], '
            '["sin(q2)", "cos(q2)", 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\nmass = "m1"\n',
            r"line 7 \(joints\[1\]\) transform\[0\]\[0\]: symbol\(s\) \['q2'\] may not appear in "
            r"'cos\(q2\)': only q1 of this joint may appear in its transform",
        ),
        # errors in mass / rotor_inertia / viscous / coulomb name their own line, not dh's
        (
            GOOD_HEAD + '[[joints]]\ndh = { a = "l1" }\nmass = "m1"\nviscous = "bb"\n',
            r"line 9 \(joints\[1\]\.viscous\): unknown symbol\(s\) \['bb'\] in 'bb'; declare each "
            r'under \[parameters\] \(e\.g\. bb = \{ value = 1\.0, unit = "N\*m\*s/rad" \}\)',
        ),
        (
            GOOD_HEAD + '[[joints]]\ndh = { a = "l1" }\n\nmass = "m1*zz"\n',
            # a factor of an expression: no unit suggested (zz's unit is not the mass's)
            r"line 9 \(joints\[1\]\.mass\): unknown symbol\(s\) \['zz'\] in 'm1\*zz'; .*"
            r"\(e\.g\. zz = \{ value = 1\.0 \}\)",
        ),
        (
            GOOD_HEAD + '[[joints]]\ndh = { a = "l1" }\nmass = "m1"\ncoulomb = "fc"\n',
            r'line 9 \(joints\[1\]\.coulomb\): .*\[\'fc\'\].*unit = "N\*m"',
        ),
        (
            GOOD_HEAD + '[[joints]]\ndh = { a = "l1" }\nmass = "m1"\nrotor_inertia = "J1"\n',
            r'line 9 \(joints\[1\]\.rotor_inertia\): .*\[\'J1\'\].*unit = "kg\*m\^2"',
        ),
        (
            GOOD_HEAD + '[[joints]]\ndh = { a = "l1" }\nmass = "m1*q1"\n',
            r"line 8 \(joints\[1\]\.mass\): symbol\(s\) \['q1'\] may not appear in 'm1\*q1': the "
            r"mass of a joint is a constant",
        ),
        (
            GOOD_HEAD + '[[joints]]\ndh = { a = "l1", alpha = "qd2" }\nmass = "m1"\n',
            r"line 7 .*dh\.alpha: symbol\(s\) \['qd2'\] may not appear .*joint variables may not",
        ),
        (
            GOOD_HEAD + '[[joints]]\ndh = { a = "l1", alpha = "al" }\nmass = "m1"\n',
            r'\[\'al\'\] in \'al\'; declare .*unit = "rad"',
        ),
        # [parameters.X] sub-tables: the error names the sub-table (or its value line)
        (
            'name = "arm"\n[parameters.m1]\nvalue = 1.0\n[parameters.l1]\nunit = "m"\n'
            '[[joints]]\ndh = { a = 1 }\nmass = "m1"\n',
            r"line 4 \(parameter 'l1'\): parameter 'l1' has no value",
        ),
        (
            'name = "arm"\n[parameters.m1]\nvalue = 1.0\n[parameters.l1]\nunit = "m"\n'
            'value = inf\n[[joints]]\ndh = { a = 1 }\nmass = "m1"\n',
            r"line 6 \(parameter 'l1'\): the value of 'l1' must be a finite number .*got inf",
        ),
        # infinite values are rejected like NaN
        (
            GOOD_HEAD.replace("0.5", "inf") + '[[joints]]\ndh = { a = "l1" }\nmass = "m1"\n',
            r"line 5 \(parameter 'l1'\): the value of 'l1' must be a finite number .*got inf",
        ),
        (
            GOOD_HEAD.replace("0.5", "-inf") + '[[joints]]\ndh = { a = "l1" }\nmass = "m1"\n',
            r"must be a finite number .*got -inf",
        ),
        # bottom row wrong
        (
            GOOD_HEAD
            + "[[joints]]\ntransform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]\n"
            'mass = "m1"\n',
            r"bottom row .* must be \[0, 0, 0, 1\]",
        ),
        # parameter with no value
        (
            'name = "arm"\n[parameters]\nm1 = { unit = "kg" }\n'
            '[[joints]]\ndh = { a = 1 }\nmass = "m1"\n',
            r"line 3 .*parameter 'm1' has no value; add value =",
        ),
        # reserved parameter name
        (
            'name = "arm"\n[parameters]\nq1 = { value = 1.0 }\n'
            '[[joints]]\ndh = { a = 1 }\nmass = "q1"\n',
            r"parameter name 'q1' is reserved",
        ),
        # both dh and transform
        (
            GOOD_HEAD
            + "[[joints]]\ndh = { a = 1 }\ntransform = [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n"
            'mass = "m1"\n',
            r"give exactly one of dh .* got both",
        ),
        # missing mass
        (GOOD_HEAD + "[[joints]]\ndh = { a = 1 }\n", r"joint 1 has no mass"),
        # unknown key in a joint
        (
            GOOD_HEAD + '[[joints]]\ndh = { a = 1 }\nmass = "m1"\ndamping = 0.1\n',
            r"line 9 .*unknown key\(s\) \['damping'\]",
        ),
        # unknown DH key
        (
            GOOD_HEAD + '[[joints]]\ndh = { a = 1, theta = 0.2 }\nmass = "m1"\n',
            r"unknown DH key\(s\) \['theta'\]",
        ),
        # bad kinetic energy / gravity / kind
        (
            GOOD_HEAD.replace("gravity", 'kinetic_energy = "approx"\ngravity')
            + "[[joints]]\ndh = {}\nmass = 1\n",
            r"kinetic_energy must be \"exact\" or \"paper\"",
        ),
        (
            'name = "arm"\ngravity = [0, -9.81]\n[[joints]]\ndh = {}\nmass = 1\n',
            r"line 2 .*gravity must be three numbers",
        ),
        ('name = "x"\nkind = "spring"\n', r"line 2 .*kind must be one of"),
        ('kind = "chain"\n', r"needs a name"),
        # linear ODE with an undeclared coefficient
        (
            'name = "o"\nkind = "linear_ode"\n[parameters]\na0 = { value = 1.0 }\n'
            '[ode]\na = ["a0", "a1"]\n'
            'b = ["a0"]\n',
            r"line 6 .*unknown symbol 'a1' in ode.a",
        ),
    ],
)
def test_model_file_errors_name_line_and_fix(tmp_path, text, pattern):
    path = write(tmp_path, text)
    with pytest.raises(ModelFileError, match=pattern):
        load_model(path, cache=False)


def test_missing_file_and_unknown_name():
    with pytest.raises(ModelFileError, match="neither a built-in model"):
        load_model("manipulater")
    with pytest.raises(ModelFileError, match="does not exist"):
        load_model_file("/nonexistent/arm.toml")


_CHAIN = """name = "arm"
kind = "chain"
[parameters]
m1 = {{ value = 1.0 }}
l1 = {{ value = 1.0 }}
[[joints]]
{geometry}
mass = "m1"
rotor_inertia = "{inertia}"
"""


def test_a_transform_entry_near_the_float_limit_is_refused_not_an_overflow_warning():
    # fuzz: R Rᵀ overflowed (RuntimeWarning) for an entry of 1e308
    text = _CHAIN.format(
        geometry='transform = [["1e308", 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]',
        inertia="0",
    )
    spec = parse_model_text(text)
    check_nominal_values(spec)
    with pytest.raises(ModelFileError, match=r"not orthonormal .*max \|R Rᵀ − I\| = inf"):
        symbolic_chain(spec)


def test_abs_of_exp_derives_as_a_real_expression():
    # fuzz: sympy writes abs(exp(m1)) as exp(re(m1)); the derivation's printers refused `re`
    text = _CHAIN.format(geometry='dh = { a = "l1", alpha = "m1" }', inertia="abs(exp(m1))")
    model = model_from_spec(parse_model_text(text), cache=False)
    # one joint: M = m1 l1² + rotor inertia = 1 + e at the nominal values, any q
    assert model.mass_matrix(np.array([[0.3]]))[0, 0, 0] == pytest.approx(1.0 + np.e, rel=1e-12)


def test_rigid_toml_identify_false_reaches_model_unknown(tmp_path):
    text = (
        'name = "axis"\ngravity = [0.0, 0.0, -9.81]\n\n[parameters]\n'
        'm1 = { value = 12.0, unit = "kg", identify = false }\n'
        'Fv1 = { value = 8.0, unit = "N*s/m" }\n\n'
        '[[joints]]\nname = "carriage"\ntype = "prismatic"\naxis = [1, 0, 0]\n'
        "transform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n"
        'mass = "m1"\nviscous = "Fv1"\n'
    )
    path = tmp_path / "axis.toml"
    path.write_text(text)
    model = physid.load_model(path)
    assert "m1" not in model.unknown
    assert set(model.parameter_names) - set(model.unknown) == {"m1"}
    # a symbol that is no model parameter cannot be held: refused, not dropped
    path.write_text(text.replace("m1 = {", "mass1 = {").replace('mass = "m1"', 'mass = "mass1"'))
    with pytest.raises(physid.errors.ModelFileError, match=r"identify = false on \['mass1'\]"):
        physid.load_model(path)
