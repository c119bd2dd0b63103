"""Branching robots (kinematic trees): dynamics against pinocchio, base parameters, sub-trees."""

import contextlib
import io
import warnings

import numpy as np
import pytest

from physid.cli import main
from physid.errors import InputError
from physid.models import inertial, rigid
from physid.models.rigid_model import RigidBodyModel
from physid.models.subtree import subtree_model, subtree_recording
from physid.models.urdf import ModelWarning, parse_urdf
from physid.signals import Recording

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
        f'<limit lower="-2" upper="2" effort="100" velocity="2"/>{extra}</joint>'
    )


def tree_urdf(mimic_on_fixed=False) -> str:
    """A torso (revolute) carrying two 3-joint arms with a fixed tool each and a prismatic head."""
    body = '<link name="base"/>' + _link("torso", 5, "0 0 0.2", (0.3, 0.01, 0.02, 0.25, 0.01, 0.2))
    body += _joint("torso_joint", "base", "torso")
    for side, y in (("left", 0.2), ("right", -0.2)):
        prev = "torso"
        for k, axis in enumerate(("0 1 0", "1 0 0", "0 0.6 0.8")):
            name = f"{side}_l{k}"
            body += _link(
                name,
                1.0 + k,
                f"0.05 0.01 {0.1 + 0.02 * k}",
                (0.02, 0.001, 0.002, 0.03, 0.001, 0.025),
            )
            body += _joint(
                f"{side}_j{k}",
                prev,
                name,
                axis=axis,
                xyz=f"0.02 {y if k == 0 else 0.01} 0.3",
                rpy="0.1 -0.2 0.3",
            )
            prev = name
        extra = '<mimic joint="torso_joint"/>' if mimic_on_fixed else ""
        body += _link(f"{side}_tool", 0.5, "0 0 0.05", (0.001, 0, 0, 0.001, 0, 0.001))
        body += _joint(
            f"{side}_fix", prev, f"{side}_tool", kind="fixed", xyz="0 0 0.1", extra=extra
        )
    body += _link("head", 2.0, "0.1 0 0", (0.01, 0, 0, 0.01, 0, 0.01))
    body += _joint("head_joint", "torso", "head", kind="prismatic", axis="1 0 0", xyz="0 0 0.5")
    return f'<?xml version="1.0"?><robot name="tree">{body}</robot>'


def _model(cache=False):
    return RigidBodyModel(parse_urdf(tree_urdf(), "tree.urdf"), cache=cache)


def _states(n_samples, n, seed):
    rng = np.random.default_rng(seed)
    return (
        rng.uniform(-1.5, 1.5, (n_samples, n)),
        rng.normal(size=(n_samples, n)),
        rng.normal(size=(n_samples, n)),
    )


def test_tree_order_and_parents():
    """Depth first, children in document order; each joint's parent recorded."""
    chain = parse_urdf(tree_urdf(), "tree.urdf")
    assert chain.joint_names == (
        "torso_joint",
        "left_j0",
        "left_j1",
        "left_j2",
        "right_j0",
        "right_j1",
        "right_j2",
        "head_joint",
    )
    assert chain.parents == (-1, 0, 1, 2, 0, 4, 5, 0)
    assert not chain.is_serial


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


@pytest.mark.parametrize("kernel", ["c", "numpy"])
def test_tree_dynamics_match_pinocchio(kernel, monkeypatch):
    """τ, M(q) and the regressor at 200 random states, C kernel and numpy path, to 1e-10."""
    model = _model()
    if kernel == "numpy":
        monkeypatch.setattr(model, "_core_kernel", lambda: None)
    else:
        assert model._core_kernel() is not None
    pm = pin.buildModelFromXML(tree_urdf())
    data = pm.createData()
    names = list(model.joint_names)
    perm = [names.index(pm.names[i]) for i in range(1, pm.njoints)]  # pinocchio's order in ours
    n = model.n_joints
    q, qd, qdd = _states(200, n, 1)
    tau, M, Y = (
        model.inverse_dynamics(q, qd, qdd),
        model.mass_matrix(q),
        model.regressor(q, qd, qdd),
    )
    Yb = inertial.to_pinocchio_order(Y.reshape(200, n, n, 10)).reshape(200, n, n * 10)
    tau_p, M_p, Y_p = np.empty_like(tau), np.empty_like(M), np.empty_like(Y)
    ours = np.concatenate([np.arange(10 * k, 10 * k + 10) for k in perm])  # columns by body
    for s in range(200):
        a = [q[s, perm], qd[s, perm], qdd[s, perm]]
        tau_p[s][perm] = pin.rnea(pm, data, *a)
        Mp = pin.crba(pm, data, a[0])
        M_p[s][np.ix_(perm, perm)] = np.triu(Mp) + np.triu(Mp, 1).T
        Y_p[s][np.ix_(perm, ours)] = pin.computeJointTorqueRegressor(pm, data, *a)
    assert _rel(tau, tau_p) < 1e-10
    assert _rel(M, M_p) < 1e-10
    assert _rel(Yb, Y_p) < 1e-10
    assert _rel(Y @ model.parameter_vector(), tau) < 1e-10
    # the left arm's links do not act on the right arm's joints
    assert np.all(Y[:, 4:7, 10:40] == 0)


def test_tree_numpy_equals_c_kernel_and_peer():
    model = _model()
    q, qd, qdd = _states(30, model.n_joints, 2)
    beta = model.parameter_vector()
    assert (
        _rel(rigid.rnea(model.chain, beta, q, qd, qdd), model.inverse_dynamics(q, qd, qdd)) < 1e-12
    )
    assert _rel(rigid.regressor(model.chain, q, qd, qdd), model.regressor(q, qd, qdd)) < 1e-12
    from physid.models.peers import to_pinocchio

    peer = to_pinocchio(model)
    tau = np.array([peer.rnea(q[s], qd[s], qdd[s]) for s in range(30)])
    assert _rel(tau, model.inverse_dynamics(q, qd, qdd)) < 1e-10


def test_tree_base_parameters_match_pinocchio_rank():
    """The base set's size is the rank of pinocchio's stacked regressor; τ = W β_base exactly."""
    model = _model()
    bp = model.base_parameters()
    pm = pin.buildModelFromXML(tree_urdf())
    data = pm.createData()
    q, qd, qdd = _states(80, model.n_joints, 3)
    Yp = np.vstack(
        [pin.computeJointTorqueRegressor(pm, data, q[s], qd[s], qdd[s]) for s in range(80)]
    )
    assert bp.n_base == np.linalg.matrix_rank(Yp)
    q, qd, qdd = _states(40, model.n_joints, 4)
    Y = model.regressor(q, qd, qdd)
    cols = [model.parameter_names.index(s) for s in bp.independent]
    beta_base = bp.base_matrix @ model.parameter_vector()
    assert _rel(Y[:, :, cols] @ beta_base, Y @ model.parameter_vector()) < 1e-9


def test_subtree_model_equals_full_model_rows():
    """The left arm alone, the rest held: its torques are the full model's at the held state."""
    model = _model()
    held = {
        "torso_joint": 0.4,
        "right_j0": 0.3,
        "right_j1": -0.2,
        "right_j2": 0.1,
        "head_joint": 0.05,
    }
    sub = subtree_model(model, ["left_j0", "left_j1", "left_j2"], held)
    assert sub.joint_names == ("left_j0", "left_j1", "left_j2")
    q, qd, qdd = _states(50, 3, 5)
    full_q = np.zeros((50, 8))
    full_qd, full_qdd = np.zeros_like(full_q), np.zeros_like(full_q)
    for j, name in enumerate(model.joint_names):
        full_q[:, j] = held.get(name, 0.0)
    full_q[:, 1:4], full_qd[:, 1:4], full_qdd[:, 1:4] = q, qd, qdd
    tau = model.inverse_dynamics(full_q, full_qd, full_qdd)[:, 1:4]
    assert _rel(sub.inverse_dynamics(q, qd, qdd), tau) < 1e-12
    # a torso and an arm with a held tool: the descendants ride on their parent
    sub2 = subtree_model(model, ["torso_joint", "left_j0"], {"left_j1": 0.2, "left_j2": -0.3})
    full_q[:] = 0.0
    full_q[:, 2], full_q[:, 3] = 0.2, -0.3
    full_q[:, :2], full_qd[:], full_qdd[:] = q[:, :2], 0.0, 0.0
    full_qd[:, :2], full_qdd[:, :2] = qd[:, :2], qdd[:, :2]
    tau = model.inverse_dynamics(full_q, full_qd, full_qdd)[:, :2]
    assert _rel(sub2.inverse_dynamics(q[:, :2], qd[:, :2], qdd[:, :2]), tau) < 1e-12


def test_subtree_errors():
    model = _model()
    with pytest.raises(InputError, match=r"not a connected sub-tree .*\['left_j0', 'right_j0'\]"):
        subtree_model(model, ["left_j0", "right_j0"], {})
    with pytest.raises(InputError, match=r"^joints names \['left_j9'\].* its joints:") as raised:
        subtree_model(model, ["left_j9"], {})
    # the command line names its flag
    assert raised.value.render({"joints": "--joints"}).startswith("--joints names ['left_j9']")
    t = np.arange(100) * 0.01
    cols = {f"q{j + 1}": np.zeros(100) for j in range(8)} | {
        f"tau{j + 1}": np.zeros(100) for j in range(8)
    }
    cols["q1"] = 0.1 * t  # the torso moves
    rec = Recording.from_columns(t, cols)
    with pytest.raises(InputError, match=r"joint 'torso_joint' \(q1\) is held still .* moves"):
        subtree_recording(model, ["left_j0", "left_j1", "left_j2"], [rec])


def test_identify_one_arm_of_a_tree_from_the_cli(tmp_path):
    """`physid identify --joints left_j0,left_j1,left_j2`: noise-free log of the whole robot, the
    torso and the right arm held; the fit explains the left arm's torques."""
    (tmp_path / "tree.urdf").write_text(tree_urdf())
    model = _model()
    t = np.arange(0, 20, 0.005)
    w = 2 * np.pi / 10
    q = np.zeros((t.size, 8))
    qd, qdd = np.zeros_like(q), np.zeros_like(q)
    q[:, 0], q[:, 4], q[:, 7] = 0.3, -0.4, 0.02  # held
    rng = np.random.default_rng(7)
    for j in (1, 2, 3):
        for h in (1, 2, 3):
            a, b = rng.normal(scale=0.5 / h, size=2)
            s, c = np.sin(h * w * t), np.cos(h * w * t)
            q[:, j] += a * s + b * c
            qd[:, j] += h * w * (a * c - b * s)
            qdd[:, j] -= (h * w) ** 2 * (a * s + b * c)
    tau = model.inverse_dynamics(q, qd, qdd)
    header = ["t"] + [f"q{j + 1}" for j in range(8)] + [f"tau{j + 1}" for j in range(8)]
    np.savetxt(
        tmp_path / "log.csv",
        np.column_stack([t, q, tau]),
        delimiter=",",
        header=",".join(header),
        comments="",
    )
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(
            [
                "identify",
                str(tmp_path / "log.csv"),
                "--model",
                str(tmp_path / "tree.urdf"),
                "--method",
                "idim-ols",
                "--joints",
                "left_j0,left_j1,left_j2",
            ]
        )
    assert status == 0, err.getvalue()[-2000:]
    # only the torso carries the left arm; the right arm and the head do not act on it
    assert "left_j2; held still at the log's torso_joint = 0.3\n" in err.getvalue()
    rel = float(out.getvalue().split("relative torque error ")[1].split()[0])
    assert rel < 1e-3


def test_fixed_joint_mimic_is_ignored_with_a_note():
    with pytest.warns(ModelWarning, match=r"fixed joint '(left|right)_fix' carries a <mimic> tag"):
        chain = parse_urdf(tree_urdf(mimic_on_fixed=True), "tree.urdf")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ref = parse_urdf(tree_urdf(), "tree.urdf")
    assert np.array_equal(chain.standard, ref.standard)
