"""Fuzz TOML model files: any text either loads into a model specification (and, for linear
ODEs, a model; for chains, parsed and checked expressions and transforms) or raises a
`PhysidError` — never another exception.

``make fuzz`` runs these at 20 000 examples each (profile ``fuzz`` in tests/conftest.py).
"""

from __future__ import annotations

from hypothesis import given
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


def _toml_value():
    scalar = st.one_of(
        GRAMMAR.map(lambda s: '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'),
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
        max_leaves=12,
    )


VALUE = _toml_value()
_PARAM = st.tuples(
    st.sampled_from(["m1", "l1", "q1", "pi", "x y", "1a", "theta1", "b0", "E"]),
    st.one_of(
        st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6).map(
            lambda v: f"{{ value = {v!r} }}"
        ),
        VALUE,
    ),
)
_JOINT_KEY = st.sampled_from(
    ["dh", "transform", "mass", "rotor_inertia", "viscous", "coulomb", "name", "damping"]
)
_JOINT_VALUE = st.one_of(
    VALUE,
    st.just('{ a = "l1" }'),
    st.lists(st.lists(VALUE, min_size=4, max_size=4), min_size=4, max_size=4).map(
        lambda rows: "[" + ", ".join("[" + ", ".join(r) + "]" for r in rows) + "]"
    ),
)


@st.composite
def model_texts(draw):
    kind = draw(st.sampled_from(['"chain"', '"linear_ode"', '"spring"', "1"]))
    lines = [f'name = "{draw(st.sampled_from(["arm", "", "x"]))}"', f"kind = {kind}"]
    if draw(st.booleans()):
        lines.append(f"gravity = {draw(VALUE)}")
    lines.append("[parameters]")
    for name, value in draw(st.lists(_PARAM, max_size=4, unique_by=lambda p: p[0])):
        lines.append(f"{name} = {value}")
    if draw(st.booleans()):
        lines.append("[ode]")
        lines.append(f"a = {draw(VALUE)}")
        lines.append(f"b = {draw(VALUE)}")
    for _ in range(draw(st.integers(0, 2))):
        lines.append("[[joints]]")
        keys = draw(st.lists(_JOINT_KEY, max_size=4, unique=True))
        for key in keys:
            lines.append(f"{key} = {draw(_JOINT_VALUE)}")
    text = "\n".join(lines) + "\n"
    if draw(st.booleans()):  # break the TOML somewhere
        cut = draw(st.integers(0, len(text)))
        text = text[:cut] + draw(st.text(max_size=5)) + text[cut:]
    return text


def _load(text):
    spec = parse_model_text(text, source="fuzz.toml")
    if isinstance(spec, ChainSpec):
        check_nominal_values(spec)
        return symbolic_chain(spec)  # every expression and transform parsed and checked
    return model_from_spec(spec)


@given(st.one_of(model_texts(), st.text(max_size=300)))
def test_model_text_loads_or_raises_a_physid_error(text):
    try:
        _load(text)
    except PhysidError:
        pass
