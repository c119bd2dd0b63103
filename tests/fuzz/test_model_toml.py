"""Fuzz TOML model files: any text either loads into a model specification (and, for linear
ODEs, a model; for chains, parsed and checked expressions and transforms) or raises a
`PhysidError` — never another exception.

``make fuzz`` runs the first property at 20 000 examples (profile ``fuzz`` in tests/conftest.py)
and the derivation property at 1/20 of that. Where the time goes (profiled): not in
physid (parsing and checking a generated file takes about 1 ms) but in hypothesis drawing the
text. A generator that nests the whole expression grammar (up to 40 leaves) inside TOML
values (up to 12 leaves) inside 4×4 transforms takes about 60-100 ms per example to *draw*, and
almost every text then fails at the first structural check (no chain in 300 draws reaches the
expression checks). The generator below draws near-valid files cheaply (small expressions over
the declared names, 0-2 joints, the hostile grammar and values only as a minority branch) and
mutates them, so the checks after the structure are reached (the ``Events`` of
``--hypothesis-show-statistics`` give the shares); the property is unchanged. The symbolic
Lagrange derivation (0.05-0.2 s for these chains, under 1.5 s for a 2-link arm) is covered by
`test_chain_derivation_of_a_checked_spec_loads_or_raises_a_physid_error` on chains of 1-2 joints
with every name declared, most of which get through to the derivation.
"""

from __future__ import annotations

import numpy as np
from hypothesis import event, given, settings
from hypothesis import strategies as st

from physid.errors import PhysidError
from physid.models.library import model_from_spec  # the factory lives in library.py
from physid.models.spec import (
    ChainSpec,
    check_nominal_values,
    parse_model_text,
    symbolic_chain,
)

from .test_expressions import GRAMMAR

_NAMES = ["m1", "m2", "l1", "l2", "c1"]
_HOSTILE_NAMES = ["q1", "pi", "x y", "1a", "theta1", "b0", "E", "qd2", "tau1", "sqrt"]


@st.composite
def _mostly(draw, valid, hostile, n: int = 20):
    """``valid`` n times in n + 1, else ``hostile`` (each choice point hostile rarely, so that a
    file with 15 of them still gets past its structure often). Not ``st.one_of(*[valid] * n,
    hostile)``: hypothesis merges equal branches, which makes that 1 in 2."""
    return draw(hostile if draw(st.sampled_from([False] * n + [True])) else valid)


def _quote(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


# small expressions over the declared names (and a few undeclared / reserved ones): cheap to draw
_EXPR = st.recursive(
    _mostly(
        st.sampled_from([*_NAMES, "pi", "q1", "1", "0", "2", "0.5", "-1"]),
        st.one_of(
            st.sampled_from(["q2", "zz", "1e308", "qd1", "tau1"]),
            st.floats(allow_nan=True, allow_infinity=True, width=32).map(repr),
        ),
        n=8,
    ),
    lambda inner: st.one_of(
        st.tuples(inner, st.sampled_from(["+", "-", "*", "/", "**"]), inner).map(
            lambda t: f"({t[0]}{t[1]}{t[2]})"
        ),
        st.tuples(st.sampled_from(["sin", "cos", "sqrt", "exp", "abs", "foo"]), inner).map(
            lambda t: f"{t[0]}({t[1]})"
        ),
        inner.map(lambda s: f"-{s}"),
    ),
    max_leaves=6,
)
_ODD_CONSTANTS = st.sampled_from(["1e400", "nan", "inf", "-inf", "true", "[]", "{}", '""'])
#: an expression as TOML: mostly a quoted small expression or a number, rarely hostile grammar
_EXPR_VALUE = _mostly(
    st.one_of(_EXPR.map(_quote), st.sampled_from(["0", "1", "0.25", "-2", "3"])),
    st.one_of(_ODD_CONSTANTS, GRAMMAR.map(_quote)),
    n=10,
)


def _toml_value():
    """Any TOML value (the hostile branch): scalars, expressions, nested arrays and tables."""
    scalar = st.one_of(
        _EXPR_VALUE,
        st.integers(min_value=-(10**20), max_value=10**20).map(str),
        st.floats(allow_nan=True, allow_infinity=True).map(
            lambda x: (
                "nan"
                if x != x
                else ("inf" if x == float("inf") else "-inf" if x == float("-inf") else repr(x))
            )
        ),
        st.sampled_from(["true", "false", "[]", "{}", '""', "[1, 2]", '"m1"', '"l1"', "0"]),
    )
    return st.recursive(
        scalar,
        lambda inner: st.one_of(
            st.lists(inner, max_size=4).map(lambda xs: "[" + ", ".join(xs) + "]"),
            st.dictionaries(
                st.sampled_from(["a", "alpha", "d", "offset", "value", "x"]), inner, max_size=4
            ).map(lambda d: "{ " + ", ".join(f"{k} = {v}" for k, v in d.items()) + " }"),
        ),
        max_leaves=6,
    )


VALUE = _toml_value()
#: mostly the expected shape (an expression), sometimes any TOML value
_ANY = _mostly(_EXPR_VALUE, VALUE)

_PARAM = st.tuples(
    _mostly(st.sampled_from(_NAMES), st.sampled_from(_HOSTILE_NAMES)),
    _mostly(
        st.one_of(
            st.tuples(
                st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6),
                st.sampled_from(["", ', unit = "kg"', ', unit = "m"', ", identify = false"]),
            ).map(lambda t: f"{{ value = {t[0]!r}{t[1]} }}"),
            st.floats(allow_nan=False, allow_infinity=False, min_value=0.01, max_value=10).map(
                repr
            ),
        ),
        VALUE,
    ),
)
_DH = st.dictionaries(
    _mostly(st.sampled_from(["a", "alpha", "d", "offset"]), st.just("theta")), _ANY, max_size=4
).map(lambda d: "{ " + ", ".join(f"{k} = {v}" for k, v in d.items()) + " }")
_IDENTITY = [["1", "0", "0", "0"], ["0", "1", "0", "0"], ["0", "0", "1", "0"], ["0", "0", "0", "1"]]
#: True about 1 time in 21: a rare hostile choice
_RARE = st.sampled_from([False] * 20 + [True])
#: Every strategy is built once, here: building them inside the composites made hypothesis
#: re-validate them on every draw (40 000 validations for 300 examples).
_ENTRY = st.one_of(_ANY, st.sampled_from(['"cos(q1)"', '"-sin(q1)"', '"sin(q1)"', '"l1"']))
_GEOMETRY = _mostly(
    st.sampled_from(["dh", "dh", "transform"]), st.sampled_from(["both", "neither"])
)
_DH_VALUE = _mostly(_DH, VALUE)
_JOINT_KEYS = st.lists(
    _mostly(st.sampled_from(["rotor_inertia", "viscous", "coulomb", "name"]), st.just("x")),
    max_size=3,
    unique=True,
)
_KIND = _mostly(st.sampled_from(['"chain"', '"linear_ode"', None]), st.sampled_from(['"x"', "1"]))
_NAME = _mostly(st.just('"arm"'), st.sampled_from(['""', '" "', "1"]))
_GRAVITY = _mostly(st.sampled_from(["[0.0, 0.0, -9.81]", "[0, -9.81, 0]"]), VALUE)
_KINETIC = _mostly(st.sampled_from(['"paper"', '"exact"']), VALUE)
_PARAMS = st.lists(_PARAM, max_size=5, unique_by=lambda p: p[0])
_A = _mostly(
    st.lists(_ANY, min_size=1, max_size=3).map(lambda xs: "[" + ", ".join(xs) + "]"), VALUE
)
_B = _mostly(
    st.lists(_ANY, min_size=1, max_size=2).map(lambda xs: "[" + ", ".join(xs) + "]"), VALUE
)
_ODE_KEYS = st.lists(
    _mostly(st.sampled_from(["input", "output", "input_unit", "output_unit"]), st.just("order")),
    max_size=2,
    unique=True,
)
_ODE_VALUE = _mostly(st.sampled_from(['"N"', '"m"', '"kg"']), VALUE)
_POSITIVE = st.floats(min_value=0.01, max_value=10.0)
_N_JOINTS = _mostly(st.integers(1, 2), st.just(0))  # at most 2 joints


@st.composite
def _transform(draw):
    """A 4×4 matrix: the identity with a few entries replaced (a translation, a rotation by q1,
    anything), rarely with rows missing."""
    rows = [list(r) for r in _IDENTITY]
    for _ in range(draw(st.integers(0, 3))):
        rows[draw(st.integers(0, 3))][draw(st.integers(0, 3))] = draw(_ENTRY)
    if draw(_RARE):
        rows = rows[: draw(st.integers(0, 3))]
    return "[" + ", ".join("[" + ", ".join(r) + "]" for r in rows) + "]"


_TRANSFORM = _transform()


@st.composite
def _joint(draw):
    lines = ["[[joints]]"]
    geometry = draw(_GEOMETRY)
    if geometry in ("dh", "both"):
        lines.append(f"dh = {draw(_DH_VALUE)}")
    if geometry in ("transform", "both"):
        lines.append(f"transform = {draw(_TRANSFORM)}")
    if not draw(_RARE):
        lines.append(f"mass = {draw(_ANY)}")
    for key in draw(_JOINT_KEYS):
        lines.append(f"{key} = {draw(_ANY)}")
    return lines


_JOINT = _joint()
_LENGTH = st.one_of(st.sampled_from(['"l1"', '"l2"', '"2*l1"', '"l1 + l2"', "0.3"]), _EXPR_VALUE)
_MASS = st.one_of(st.sampled_from(['"m1"', '"m2"', '"m1 + m2"', '"m2*l2**2"', "1.5"]), _EXPR_VALUE)
_FRICTION = st.dictionaries(
    st.sampled_from(["rotor_inertia", "viscous", "coulomb"]), _EXPR_VALUE, max_size=3
)


@st.composite
def _chain_joint(draw):
    """A joint with a length and a mass that are mostly physical, any expression sometimes."""
    dh = {"a": draw(_LENGTH)}
    for key in draw(st.lists(st.sampled_from(["alpha", "d", "offset"]), max_size=3, unique=True)):
        dh[key] = draw(_EXPR_VALUE)
    lines = ["[[joints]]", "dh = { " + ", ".join(f"{k} = {v}" for k, v in dh.items()) + " }"]
    lines.append(f"mass = {draw(_MASS)}")
    lines.extend(f"{k} = {v}" for k, v in draw(_FRICTION).items())
    return lines


_CHAIN_JOINT = st.one_of(_chain_joint(), _JOINT)


@st.composite
def model_texts(draw, chains: bool = False):
    """A near-valid chain or linear-ODE model file, each choice rarely hostile, rarely broken.

    ``chains``: a chain of 1-2 joints with every name of the expressions declared, unbroken
    TOML (for the derivation property: most of these get through to the derivation).
    """
    kind = '"chain"' if chains else draw(_KIND)
    ode = kind == '"linear_ode"'
    lines = ["name = " + ('"arm"' if chains else draw(_NAME))]
    if kind is not None:
        lines.append(f"kind = {kind}")
    if (not ode) != draw(_RARE) and draw(st.booleans()):
        lines.append(f"gravity = {draw(_GRAVITY)}")
    if not ode and draw(st.integers(0, 9)) == 9:
        lines.append(f"kinetic_energy = {draw(_KINETIC)}")
    lines.append("[parameters]")
    if chains:
        for name in _NAMES:
            lines.append(f"{name} = {{ value = {draw(_POSITIVE)!r} }}")
    else:
        for name, value in draw(_PARAMS):
            lines.append(f"{name} = {value}")
    if not chains and ode != draw(_RARE):
        lines.append("[ode]")
        lines.append(f"a = {draw(_A)}")
        lines.append(f"b = {draw(_B)}")
        if draw(st.integers(0, 4)) == 4:
            lines.append(f"output_offset = {draw(_ANY)}")
        for key in draw(_ODE_KEYS):
            lines.append(f"{key} = {draw(_ODE_VALUE)}")
    if chains or (not ode) != draw(_RARE):
        for _ in range(draw(st.integers(1, 2) if chains else _N_JOINTS)):
            lines.extend(draw(_CHAIN_JOINT if chains else _JOINT))
    text = "\n".join(lines) + "\n"
    if not chains and draw(st.integers(0, 9)) == 9:  # break the TOML somewhere
        cut = draw(st.integers(0, len(text)))
        text = text[:cut] + draw(st.text(max_size=5)) + text[cut:]
    return text


MODEL_TEXTS = model_texts()
CHAIN_TEXTS = model_texts(chains=True)


def _load(text):
    spec = parse_model_text(text, source="fuzz.toml")
    if isinstance(spec, ChainSpec):
        check_nominal_values(spec)
        return symbolic_chain(spec)  # every expression and transform parsed and checked
    return model_from_spec(spec)


@given(st.one_of(MODEL_TEXTS, st.text(max_size=300)))
def test_model_text_loads_or_raises_a_physid_error(text):
    try:
        out = _load(text)
    except PhysidError as exc:
        event(f"refused ({type(exc).__name__})")
        return
    event("loaded: " + ("chain" if isinstance(out, dict) else type(out).__name__))


# The derivation (symbolic Lagrange, 0.05-0.2 s for these chains): at 1/20 of the profile's count.
@settings(max_examples=max(5, settings.default.max_examples // 20))
@given(CHAIN_TEXTS)
def test_chain_derivation_of_a_checked_spec_loads_or_raises_a_physid_error(text):
    try:
        spec = parse_model_text(text, source="fuzz.toml")
        assert isinstance(spec, ChainSpec)
        check_nominal_values(spec)
        symbolic_chain(spec)
    except PhysidError:
        event("refused before the derivation")
        return
    try:
        model = model_from_spec(spec, cache=False)
    except PhysidError:
        event("refused by the derivation")
        return
    event("derived")
    assert model.n_joints == len(spec.joints) <= 2
    assert tuple(model.parameter_names) == spec.parameter_names
    try:
        M = model.mass_matrix(np.zeros((1, model.n_joints)))
    except PhysidError:
        return
    assert M.shape == (1, model.n_joints, model.n_joints)
    finite = np.isfinite(M)
    assert np.array_equal(finite, finite.transpose(0, 2, 1))
    assert np.allclose(M[finite], M.transpose(0, 2, 1)[finite], rtol=1e-9, atol=0)
