"""Rigid-body chains (URDF, sidecar, DH/MDH TOML) against pinocchio built from the same robot."""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import physid
from physid.models import inertial, rigid
from physid.models.peers import to_pinocchio
from physid.models.rigid_model import RigidBodyModel

DATA = Path(__file__).parent / "data"
ARM6 = Path(physid.__file__).parent / "models" / "data" / "arm6.urdf"
URDFS = {
    "planar2": DATA / "planar2.urdf",
    "arm3_prismatic": DATA / "arm3_prismatic.urdf",
    "arm6_fixed_joints": ARM6,
    "arm7": DATA / "arm7.urdf",
}


def _states(model, n, seed):
    rng = np.random.default_rng(seed)
    nj = model.n_joints
    q = rng.uniform(-np.pi, np.pi, (n, nj))
    for j, kind in enumerate(model.joint_types):
        if kind == "prismatic":
            q[:, j] = rng.uniform(0.0, 0.5, n)
    return q, rng.normal(size=(n, nj)), rng.normal(size=(n, nj))


def _pin_q(pm, q):
    """pinocchio's configuration (continuous joints are cos/sin pairs)."""
    out = []
    for j in range(1, pm.njoints):
        if pm.joints[j].nq == 2:
            out += [np.cos(q[j - 1]), np.sin(q[j - 1])]
        else:
            out.append(q[j - 1])
    return np.array(out)


def _rel(a, b):
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


@pytest.mark.parametrize("name", sorted(URDFS))
def test_urdf_matches_pinocchio_at_1000_states(name):
    path = URDFS[name]
    model = physid.load_model(path)
    pm = pin.buildModelFromUrdf(str(path))
    pd = pm.createData()
    q, qd, qdd = _states(model, 1000, seed=1)
    tau = model.inverse_dynamics(q, qd, qdd)
    M = model.mass_matrix(q)
    Y = model.regressor(q, qd, qdd)
    n = model.n_joints
    P = model.chain.per_joint
    tau_p = np.empty_like(tau)
    M_p = np.empty_like(M)
    Y_p = np.empty((1000, n, 10 * n))
    for s in range(1000):
        qq = _pin_q(pm, q[s])
        tau_p[s] = pin.rnea(pm, pd, qq, qd[s], qdd[s])
        Mp = pin.crba(pm, pd, qq)
        M_p[s] = np.triu(Mp) + np.triu(Mp, 1).T
        Y_p[s] = pin.computeJointTorqueRegressor(pm, pd, qq, qd[s], qdd[s])
    # the URDF's <dynamics> terms are zero here (pinocchio's rnea does not include them)
    assert _rel(tau, tau_p) < 1e-10
    assert _rel(M, M_p) < 1e-10
    Y_std = Y.reshape(1000, n, n, P)[..., :10]
    assert _rel(inertial.to_pinocchio_order(Y_std).reshape(1000, n, 10 * n), Y_p) < 1e-10
    assert _rel(Y @ model.beta(), tau) < 1e-10
    # the numpy fallback computes the same numbers as the C kernel
    k = slice(0, 50)
    beta = model.parameter_vector()
    assert _rel(rigid.rnea(model.chain, beta, q[k], qd[k], qdd[k]), tau[k]) < 1e-12
    assert _rel(rigid.mass_matrix(model.chain, beta, q[k]), M[k]) < 1e-12
    assert _rel(rigid.regressor(model.chain, q[k], qd[k], qdd[k]), Y[k]) < 1e-12


@pytest.mark.parametrize("name", sorted(URDFS))
def test_base_parameter_count_is_pinocchio_regressor_rank(name):
    path = URDFS[name]
    model = physid.load_model(path)
    base = model.base_parameters()
    pm = pin.buildModelFromUrdf(str(path))
    pd = pm.createData()
    q, qd, qdd = _states(model, 60, seed=3)
    Yp = np.vstack(
        [
            pin.computeJointTorqueRegressor(pm, pd, _pin_q(pm, q[s]), qd[s], qdd[s])
            for s in range(60)
        ]
    )
    n_drive = model.chain.per_joint - 10
    drive_cols = np.linalg.matrix_rank(
        model.regressor(q, qd, qdd).reshape(60 * model.n_joints, -1)
    ) - np.linalg.matrix_rank(Yp)
    assert base.n_base == np.linalg.matrix_rank(Yp) + drive_cols
    assert drive_cols <= n_drive * model.n_joints
    # exactness of the base form: τ = Y[:, :, independent] β_base at other states
    q, qd, qdd = _states(model, 40, seed=9)
    Y = model.regressor(q, qd, qdd)
    beta = model.parameter_vector()
    tau = Y @ beta
    tau_base = Y[:, :, list(base.independent_index)] @ base.values(beta)
    assert _rel(tau_base, tau) < 1e-9
    assert len(base.expressions) == len(base.base_names) == len(base.words) == base.n_base


def test_panda_like_arm_has_43_base_inertial_parameters():
    base = physid.load_model(DATA / "arm7.urdf").base_parameters()
    assert base.n_base == 43  # the known count for a Panda without friction
    assert "ZZ1R" in base.base_names
    i = base.base_names.index("ZZ1R")
    assert base.expressions[i] == "ZZ1 + YY2"
    assert "regrouped" in base.words[i]
    assert any(c.expression == "ZZ1 + YY2" for c in base.combinations)


def test_sidecar_adds_drive_terms_and_the_peer_carries_them():
    model = physid.load_model("arm6")
    assert model.regressor_names[:13] == tuple(
        "m1 mcx1 mcy1 mcz1 XX1 XY1 XZ1 YY1 YZ1 ZZ1 Ia1 Fv1 Fc1".split()
    )
    assert model.parameters["Fv2"] == 2.0 and model.parameters["Ia3"] == 0.2
    assert model.limits["effort"].tolist() == [150, 150, 150, 28, 28, 28]
    peer = to_pinocchio(model)
    q, qd, qdd = _states(model, 200, seed=4)
    tau = model.inverse_dynamics(q, qd, qdd)
    tau_p = np.array([peer.rnea(q[s], qd[s], qdd[s]) for s in range(200)])
    assert _rel(tau, tau_p) < 1e-10
    qdd2 = model.forward_dynamics(q, qd, tau)
    assert _rel(qdd2, qdd) < 1e-9
    assert _rel(np.array([peer.aba(q[s], qd[s], tau[s]) for s in range(20)]), qdd[:20]) < 1e-9


def test_paper_arm_peer_now_carries_viscous_friction():
    model = physid.load_model("manipulator")
    peer = to_pinocchio(model)
    q, qd, qdd = np.random.default_rng(0).normal(size=(3, 10, 4))
    tau = model.inverse_dynamics(q, qd, qdd)
    tau_p = np.array([peer.rnea(q[s], qd[s], qdd[s]) for s in range(10)])
    assert _rel(tau_p, tau) < 1e-10


# ------------------------------------------------------------------------ DH and MDH files
def _dh_rows():
    # a Puma-like 4-DOF arm: (a, alpha, d, theta) standard DH, one prismatic-free chain
    return [
        (0.0, np.pi / 2, 0.4, 0.0),
        (0.43, 0.0, 0.15, 0.1),
        (0.02, -np.pi / 2, 0.0, -0.2),
        (0.0, np.pi / 2, 0.43, 0.0),
    ]


def _links():
    rng = np.random.default_rng(11)
    out = []
    for _ in range(4):
        A = rng.normal(size=(3, 3))
        Q, _ = np.linalg.qr(A)
        mom = rng.uniform(0.01, 0.1, 3)
        out.append(
            inertial.standard_from_physical(
                rng.uniform(1, 8), rng.normal(size=3) * 0.1, Q @ np.diag(mom) @ Q.T
            )
        )
    return out


def _toml(form, rows, links, extra=""):
    text = [f'name = "arm_{form}"', "gravity = [0.0, 0.0, -9.81]"]
    for k, ((a, alpha, d, theta), p) in enumerate(zip(rows, links, strict=True)):
        text.append("[[joints]]")
        text.append(
            f"{form} = {{ a = {float(a)!r}, alpha = {float(alpha)!r}, d = {float(d)!r}, "
            f"theta = {float(theta)!r} }}"
        )
        text += [
            f"{name} = {float(v)!r}" for name, v in zip(inertial.STANDARD_NAMES, p, strict=True)
        ]
        text.append(f"armature = {0.1 * (k + 1)!r}")
        text.append(extra)
    return "\n".join(text) + "\n"


def _Rz(t):
    return np.array([[np.cos(t), -np.sin(t), 0], [np.sin(t), np.cos(t), 0], [0, 0, 1]])


def _Rx(t):
    return np.array([[1, 0, 0], [0, np.cos(t), -np.sin(t)], [0, np.sin(t), np.cos(t)]])


def _pin_from_dh(rows, links):
    """pinocchio model of a standard-DH arm, built independently with pinocchio's SE3 algebra."""
    pm = pin.Model()
    parent, placement = 0, pin.SE3.Identity()
    for k, ((a, alpha, d, theta), p) in enumerate(zip(rows, links, strict=True)):
        S = pin.SE3(_Rz(theta), np.zeros(3)) * pin.SE3(np.eye(3), np.array([0, 0, d]))
        S = S * pin.SE3(np.eye(3), np.array([a, 0, 0])) * pin.SE3(_Rx(alpha), np.zeros(3))
        jid = pm.addJoint(parent, pin.JointModelRZ(), placement, f"j{k}")
        I_link = pin.Inertia.FromDynamicParameters(inertial.to_pinocchio_order(p))
        pm.appendBodyToJoint(jid, S.act(I_link), pin.SE3.Identity())
        parent, placement = jid, S
    pm.armature = np.array([0.1 * (k + 1) for k in range(len(rows))])
    return pm


def test_dh_and_mdh_versions_of_the_same_arm_agree_with_pinocchio(tmp_path):
    rows, links = _dh_rows(), _links()
    (tmp_path / "dh.toml").write_text(_toml("dh", rows, links))
    # MDH: joint i takes (alpha, a) of DH joint i−1; link i's frame differs by Tx(a_i) Rx(α_i)
    mdh_rows, mdh_links = [], []
    for k, (a, alpha, d, theta) in enumerate(rows):
        a_prev, alpha_prev = (rows[k - 1][0], rows[k - 1][1]) if k else (0.0, 0.0)
        mdh_rows.append((a_prev, alpha_prev, d, theta))
        mdh_links.append(inertial.transform_standard(links[k], _Rx(alpha), [a, 0, 0]))
    (tmp_path / "mdh.toml").write_text(_toml("mdh", mdh_rows, mdh_links))
    dh = physid.load_model(tmp_path / "dh.toml")
    mdh = physid.load_model(tmp_path / "mdh.toml")
    assert isinstance(dh, RigidBodyModel) and isinstance(mdh, RigidBodyModel)
    pm = _pin_from_dh(rows, links)
    pd = pm.createData()
    q, qd, qdd = _states(dh, 1000, seed=5)
    tau_p = np.array([pin.rnea(pm, pd, q[s], qd[s], qdd[s]) for s in range(1000)])
    M_p = np.array([pin.crba(pm, pd, q[s]) for s in range(1000)])
    M_p = np.triu(M_p) + np.transpose(np.triu(M_p, 1), (0, 2, 1))
    for model in (dh, mdh):
        assert _rel(model.inverse_dynamics(q, qd, qdd), tau_p) < 1e-10
        assert _rel(model.mass_matrix(q), M_p) < 1e-10
        assert _rel(model.regressor(q, qd, qdd) @ model.beta(), tau_p) < 1e-10
    assert dh.base_parameters().n_base == mdh.base_parameters().n_base


def test_prismatic_dh_joint_adds_q_to_d(tmp_path):
    text = """
name = "slide"
gravity = [0.0, 0.0, -9.81]
[[joints]]
type = "prismatic"
dh = { a = 0.0, alpha = 0.0, d = 0.2, theta = 0.0 }
mass = 3.0
"""
    (tmp_path / "s.toml").write_text(text)
    model = physid.load_model(tmp_path / "s.toml")
    q = np.array([[0.1], [0.3]])
    tau = model.inverse_dynamics(q, np.zeros_like(q), np.ones_like(q))
    np.testing.assert_allclose(tau[:, 0], 3.0 * (1.0 + 9.81))
    assert model.joint_types == ("prismatic",) and model.units["m1"] == "kg"


def test_point_mass_rigid_file_reproduces_the_paper_arm(tmp_path):
    """The paper's arm written with rigid-body keys (point masses + armature) = the symbolic arm."""
    lengths = {"l1": 0.4, "l2": 0.8, "l3": 0.6, "l4": 0.2}
    masses = {"m1": 50.0, "m2": 25.0, "m3": 15.0, "m4": 5.0}
    text = ['name = "paper_rigid"', "gravity = [0.0, 0.0, 9.81]"]
    text.append("[parameters]")
    text += [f"{k} = {v}" for k, v in {**masses, **lengths}.items()]
    alphas = ["pi/2", 0, 0, 0]
    for k in range(4):
        a = f'"l{k + 1}"' if k else 0
        text += [
            "[[joints]]",
            'type = "revolute"',
            f"dh = {{ a = {a}, alpha = {alphas[k]!r}, d = 0 }}",
            f'mass = "m{k + 1}"',
            f'armature = "m{k + 1}*l{k + 1}**2/12"',
        ]
    (tmp_path / "p.toml").write_text("\n".join(text).replace("'pi/2'", '"pi/2"') + "\n")
    rig = physid.load_model(tmp_path / "p.toml")
    paper = physid.load_model("manipulator")
    q, qd, qdd = np.random.default_rng(2).normal(size=(3, 100, 4))
    assert _rel(rig.inverse_dynamics(q, qd, qdd), paper.inverse_dynamics(q, qd, qdd)) < 1e-12


def test_physical_keys_equal_standard_keys(tmp_path):
    phys = """
name = "one"
[[joints]]
type = "revolute"
transform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 1]]
axis = [0, 1, 0]
mass = 2.0
com = [0.3, 0.01, 0.0]
inertia = [0.01, 0.001, 0.0, 0.02, 0.0, 0.015]
viscous_positive = 0.3
viscous_negative = 0.5
coulomb_positive = 0.2
coulomb_negative = 0.4
torque_offset = 0.05
limits = { lower = -1.0, upper = 2.0, velocity = 3.0, effort = 40.0, acceleration = 20.0 }
"""
    (tmp_path / "p.toml").write_text(phys)
    model = physid.load_model(tmp_path / "p.toml")
    p = inertial.standard_from_physical(2.0, [0.3, 0.01, 0.0], [0.01, 0.001, 0.0, 0.02, 0.0, 0.015])
    np.testing.assert_allclose(model.chain.standard[0], p)
    assert model.regressor_names[10:] == ("Fvp1", "Fvn1", "Fcp1", "Fcn1", "OF1")
    assert model.limits["position"].tolist() == [[-1.0, 2.0]]
    assert model.limits["acceleration"].tolist() == [20.0]
    qd = np.array([[1.0], [-1.0]])
    z = np.zeros_like(qd)
    h = model.inverse_dynamics(z, qd, z) - model.inverse_dynamics(z, z, z)
    np.testing.assert_allclose(h[:, 0], [0.3 + 0.2, -0.5 - 0.4], atol=1e-12)


def test_closed_loop_of_a_rigid_chain_matches_pinocchio():
    model = physid.load_model(DATA / "planar2.urdf")
    from physid.simulate import simulate_closed_loop

    runs = {
        be: simulate_closed_loop(
            model,
            kp=[200, 80],
            kd=[20, 8],
            reference=[0.4, -0.3],
            duration=2.0,
            dt=0.01,
            backend=be,
        )
        for be in ("compiled", "generated", "pinocchio")
    }
    for be in ("generated", "pinocchio"):
        np.testing.assert_allclose(runs[be]["q1"], runs["compiled"]["q1"], atol=1e-7)
    assert runs["compiled"].metadata["kp"] == [200.0, 80.0]
    assert runs["compiled"].metadata["integrator"]["backend"] == "compiled"


def test_worked_example_of_the_docs():
    root = Path(__file__).parent.parent
    arm = physid.load_model(root / "examples" / "models" / "planar2.toml")
    np.testing.assert_allclose(arm.chain.standard[0][[1, 7, 9]], [0.506, 0.14232, 0.14032])
    base = arm.base_parameters()
    assert base.n_base == 9
    assert dict(zip(base.base_names, base.expressions, strict=True))["YY1R"] == (
        "YY1 + Ia1 + 0.2025*m2"
    )
    assert "m1" in base.no_effect


@pytest.mark.parametrize("smoothing", [0.01, 0.0])
def test_coulomb_smoothing_is_the_same_in_every_backend(smoothing):
    """arm6 has Coulomb friction: the C kernel, the numpy fallback and pinocchio's peer all
    simulate Fc·tanh(q̇ / v_s) (smoothing > 0) or the exact law by events (0, the default), so
    their runs agree."""
    from physid.simulate import simulate_closed_loop

    model = physid.load_model("arm6")
    fallback = physid.load_model("arm6")
    fallback._kernel_tried, fallback._kernel = True, None  # as on a machine without cc
    kw = dict(kp=[300] * 6, kd=[30] * 6, reference=[0.1] * 6, duration=0.2, dt=0.01)
    kw["coulomb_smoothing"] = smoothing
    runs = {
        "compiled": simulate_closed_loop(model, backend="compiled", **kw),
        "pinocchio": simulate_closed_loop(model, backend="pinocchio", **kw),
        "numpy": simulate_closed_loop(fallback, backend="generated", **kw),
    }
    for name in ("pinocchio", "numpy"):
        np.testing.assert_allclose(runs[name]["q2"], runs["compiled"]["q2"], atol=1e-7)
    assert runs["compiled"].metadata["coulomb_smoothing"] == smoothing
    assert ("coulomb" in runs["compiled"].metadata) == (smoothing == 0)
    # the model itself (identification) keeps the exact sign
    qd = np.array([[1e-4] * 6])
    z = np.zeros_like(qd)
    friction = model.inverse_dynamics(z, qd, z) - model.inverse_dynamics(z, z, z)
    np.testing.assert_allclose(friction[0, 0], 2.0 * 1e-4 + 3.0, rtol=1e-6)  # + tiny Coriolis
