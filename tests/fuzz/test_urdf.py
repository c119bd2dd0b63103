"""Fuzz the URDF reader and rigid-body TOML chains: any input loads or raises PhysidError.

The example count comes from the hypothesis profile (tests/conftest.py: a modest one for
``make test``, ≥ 20 000 for ``make fuzz``).
"""

import warnings

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import physid
from physid.errors import PhysidError
from physid.models.rigid_model import RigidBodyModel
from physid.models.spec import parse_model_text
from physid.models.urdf import parse_urdf

NUM = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64).map(repr),
    st.integers(-5, 5).map(str),
    st.sampled_from(["", "x", "1e309", "-0", "1 2", "0.1 0.2 0.3", "nan", "1,2,3", "  "]),
)
VEC = st.one_of(
    st.lists(st.floats(-2, 2, allow_nan=False), min_size=3, max_size=3).map(
        lambda v: " ".join(repr(x) for x in v)
    ),
    NUM,
)
TYPES = st.sampled_from(
    ["revolute", "continuous", "prismatic", "fixed", "planar", "floating", "hinge", ""]
)


@st.composite
def urdf_documents(draw):
    n_links = draw(st.integers(0, 6))
    names = [draw(st.sampled_from(["base", "a", "b", "c", "d", "e", "f"])) for _ in range(n_links)]
    parts = []
    for name in names:
        if draw(st.booleans()):
            parts.append(f'<link name="{name}"/>')
            continue
        ine = (
            f'<inertial><origin xyz="{draw(VEC)}" rpy="{draw(VEC)}"/><mass value="{draw(NUM)}"/>'
            f'<inertia ixx="{draw(NUM)}" ixy="{draw(NUM)}" ixz="{draw(NUM)}" iyy="{draw(NUM)}" '
            f'iyz="{draw(NUM)}" izz="{draw(NUM)}"/></inertial>'
        )
        parts.append(f'<link name="{name}">{ine}</link>')
    for k in range(draw(st.integers(0, 6))):
        parent = draw(st.sampled_from([*names, "ghost"])) if names else "ghost"
        child = draw(st.sampled_from([*names, "ghost"])) if names else "ghost"
        extra = draw(
            st.sampled_from(
                ["", '<mimic joint="j0"/>', f'<limit lower="{draw(NUM)}" upper="1" effort="2"/>']
            )
        )
        parts.append(
            f'<joint name="j{k}" type="{draw(TYPES)}"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{draw(VEC)}" rpy="{draw(VEC)}"/>'
            f'<axis xyz="{draw(VEC)}"/>{extra}</joint>'
        )
    text = '<?xml version="1.0"?><robot name="fuzz">' + "".join(parts) + "</robot>"
    if draw(st.booleans()):  # damage the text
        cut = draw(st.integers(0, len(text)))
        text = text[:cut] + draw(st.text(max_size=8)) + text[cut:]
    return text


def _build(chain):
    return RigidBodyModel(chain)


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(urdf_documents())
def test_urdf_loads_or_raises_physid_error(text):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            model = _build(parse_urdf(text, "fuzz.urdf"))
        except PhysidError:
            return
    q = np.zeros((1, model.n_joints))
    assert np.all(np.isfinite(model.mass_matrix(q)))


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.text(max_size=200))
def test_any_text_as_urdf(text):
    try:
        parse_urdf(text, "fuzz.urdf")
    except PhysidError:
        pass


VALUE = st.one_of(
    st.floats(-10, 10, allow_nan=False),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-3, 3),
    st.sampled_from(['"m1"', '"pi/2"', '"sqrt(-1)"', '"1/0"', '"q1"', '"x"', "true", '""']),
)


@st.composite
def rigid_toml(draw):
    lines = ['name = "fz"', "[parameters]", "m1 = 2.0"]
    for _ in range(draw(st.integers(1, 3))):
        lines.append("[[joints]]")
        lines.append(f'type = "{draw(st.sampled_from(["revolute", "prismatic", "fixed", "x"]))}"')
        form = draw(st.sampled_from(["dh", "mdh", "transform", "none"]))
        if form in ("dh", "mdh"):
            lines.append(
                f"{form} = {{ a = {draw(VALUE)}, alpha = {draw(VALUE)}, d = {draw(VALUE)} }}"
            )
        elif form == "transform":
            lines.append(
                "transform = [[1,0,0,0],[0,1,0,0],[0,0,1,"
                f"{draw(VALUE)}],[0,0,0,{draw(st.sampled_from([1, 0]))}]]"
            )
            lines.append(f"axis = [{draw(VALUE)}, 0, 1]")
        keys = draw(
            st.lists(
                st.sampled_from(
                    ["mass", "m", "XX", "ZZ", "armature", "viscous", "coulomb_positive"]
                ),
                max_size=4,
                unique=True,
            )
        )
        lines += [f"{k} = {draw(VALUE)}" for k in keys]
        if draw(st.booleans()):
            lines.append(f"com = [{draw(VALUE)}, 0, 0]")
            lines.append(f"inertia = [{draw(VALUE)}, 0, 0, 0.1, 0, 0.1]")
    return "\n".join(lines) + "\n"


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rigid_toml())
def test_rigid_toml_chain_loads_or_raises_physid_error(text):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            spec = parse_model_text(text, "fuzz.toml")
            if not isinstance(spec, physid.models.RigidChain):
                return  # a point-mass chain (symbolic path), not what this fuzz targets
            _build(spec)
        except PhysidError:
            return
