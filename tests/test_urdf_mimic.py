"""Mimic joints in URDF files: a follower's coordinate comes from its leader (as pinocchio's
``mimic=True``), checked against pinocchio; a fixed joint's leftover ``<mimic>`` is ignored."""

import numpy as np
import pytest

from physid.errors import ModelFileError
from physid.models.rigid_model import RigidBodyModel
from physid.models.urdf import ModelWarning, parse_urdf

pin = pytest.importorskip("pinocchio")


def _link(name, mass, com, inertia):
    ixx, ixy, ixz, iyy, iyz, izz = inertia
    return (
        f'<link name="{name}"><inertial><origin xyz="{com}" rpy="0.1 0.2 0.3"/>'
        f'<mass value="{mass}"/><inertia ixx="{ixx}" ixy="{ixy}" ixz="{ixz}" iyy="{iyy}" '
        f'iyz="{iyz}" izz="{izz}"/></inertial></link>'
    )


def _joint(
    name, parent, child, kind="revolute", axis="0 0 1", xyz="0 0 0.1", rpy="0 0 0", extra=""
):
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
        f'<limit lower="-2" upper="2" effort="10" velocity="2"/>{extra}</joint>'
    )


def gripper_urdf(mimic='<mimic joint="fa_j" multiplier="-0.7" offset="0.2"/>', kind="revolute"):
    """A 2-joint arm with a two-finger gripper whose second finger mimics the first."""
    small = (0.001, 0, 0, 0.002, 0, 0.001)
    body = '<link name="base"/>' + _link(
        "l1", 2, "0.1 0 0.1", (0.02, 0.001, 0.002, 0.03, 0.001, 0.025)
    )
    body += _joint("j1", "base", "l1", axis="0 1 0")
    body += _link("l2", 1, "0.05 0.01 0.1", (0.01, 0.001, 0.002, 0.02, 0.001, 0.015))
    body += _joint("j2", "l1", "l2", axis="1 0 0", xyz="0 0.1 0.3", rpy="0.1 0.2 0.3")
    body += _link("fa", 0.3, "0.02 0 0.03", small) + _joint("fa_j", "l2", "fa", xyz="0 0.05 0.1")
    body += _link("fb", 0.3, "0.02 0 0.03", small)
    body += _joint("fb_j", "l2", "fb", kind=kind, xyz="0 -0.05 0.1", extra=mimic)
    return f'<?xml version="1.0"?><robot name="gripper">{body}</robot>'


def test_mimic_joint_matches_pinocchio():
    """τ, M(q) and Y β at random states against pinocchio's mimic model, to 1e-10."""
    text = gripper_urdf()
    model = RigidBodyModel(parse_urdf(text, "g.urdf"), cache=False)
    assert model.joint_names == ("j1", "j2", "fa_j")  # fb_j follows fa_j
    assert model.parameter_names[30:32] == ("m4", "mcx4")  # the follower's link is identified
    pm = pin.buildModelFromXML(text, mimic=True)
    data = pm.createData()
    assert pm.nv == 3
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.normal(size=(100, 3)) for _ in range(3))
    tau, M, Y = (
        model.inverse_dynamics(q, qd, qdd),
        model.mass_matrix(q),
        model.regressor(q, qd, qdd),
    )
    for s in range(100):
        tp = pin.rnea(pm, data, q[s], qd[s], qdd[s])
        Mp = pin.crba(pm, data, q[s])
        assert np.max(np.abs(tau[s] - tp)) < 1e-10 * max(1.0, np.max(np.abs(tp)))
        assert np.max(np.abs(M[s] - (np.triu(Mp) + np.triu(Mp, 1).T))) < 1e-12
    assert np.max(np.abs(Y @ model.parameter_vector() - tau)) < 1e-10
    # by hand: the follower's angle is −0.7 q + 0.2, so moving fa_j alone moves fb's link too
    bp = model.base_parameters()
    assert "m4" not in bp.independent and any("4" in e for e in bp.expressions)


def test_fixed_joint_mimic_is_ignored_with_a_note():
    with pytest.warns(ModelWarning, match=r"fixed joint 'fb_j' carries a <mimic> tag; .* ignored"):
        chain = parse_urdf(gripper_urdf(kind="fixed"), "g.urdf")
    assert chain.joint_names == ("j1", "j2", "fa_j") and chain.mimic == ()


@pytest.mark.parametrize(
    ("mimic", "regex"),
    [
        ('<mimic joint="nope"/>', r"mimics 'nope', which is not a joint of the robot"),
        ("<mimic/>", r'<mimic> needs joint="LEADER"'),
        ('<mimic joint="fa_j" multiplier="x"/>', r"multiplier='x' is not a number"),
    ],
)
def test_bad_mimic(mimic, regex):
    with pytest.raises(ModelFileError, match=regex):
        parse_urdf(gripper_urdf(mimic=mimic), "g.urdf")


def test_mimic_of_a_mimic_and_of_another_type_are_refused():
    text = gripper_urdf().replace("</robot>", "")
    text += '<link name="fc"/>' + _joint("fc_j", "l2", "fc", extra='<mimic joint="fb_j"/>')
    with pytest.raises(
        ModelFileError, match=r"mimics 'fb_j', itself a mimic joint; make it mimic 'fa_j'"
    ):
        parse_urdf(text + "</robot>", "g.urdf")
    text = gripper_urdf().replace("</robot>", "")
    text += '<link name="fd"/>' + _joint(
        "fd_j", "l2", "fd", kind="prismatic", extra='<mimic joint="fa_j"/>'
    )
    with pytest.raises(ModelFileError, match=r"\(prismatic\) mimics 'fa_j' \(revolute\)"):
        parse_urdf(text + "</robot>", "g.urdf")
