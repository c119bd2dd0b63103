"""The zoo's arms of the example-robot-data collection (benchmarks/zoo/collection.py).

* the cleaned URDFs keep exactly the arm's joints (Panda: fingers fixed) and no geometry;
* MuJoCo's inverse dynamics of each cleaned URDF equals pinocchio's ``rnea`` (1e-9 N·m);
* physid's model of each cleaned URDF equals pinocchio's ``rnea`` at random states (1e-9 N·m,
  no armature) and, through the sidecar the cases use, has the recipe's base-parameter count;
* MuJoCo's drive terms are the truth's: with damping and armature, ``mj_inverse`` adds exactly
  Ia q̈ + Fv q̇ to ``rnea``; a closed-loop MuJoCo run is explained by the truth (rigid body +
  Ia q̈ + Fv q̇ + Fc sign q̇, plus implicitfast's dt·Fv·q̈) at each joint where it slides
  faster than 0.2 rad/s, to 1e-9 N·m;
* gravity compensation holds the Panda at its reference.

example-robot-data and mujoco are in the ``zoo`` extra, which ``make test`` installs: without
them these tests fail with the reason (they are not skipped).
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin  # the peers extra, which make test installs
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.zoo import cases, collection  # noqa: E402
from benchmarks.zoo.recipe import Recipe  # noqa: E402

import physid  # noqa: E402

ARMS = sorted(collection.ARMS)


def test_collection_and_mujoco_are_installed():
    assert collection.collection_available() == ""
    assert cases.mujoco_available() == ""


@pytest.fixture(scope="module")
def urdfs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("collection")
    return {k: collection.clean_urdf(collection.ARMS[k], folder) for k in ARMS}


def _states(nj, n, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(-2, 2, (n, nj)), rng.normal(size=(n, nj)), rng.normal(size=(n, nj))


@pytest.mark.parametrize("key", ARMS)
def test_cleaned_urdf_keeps_only_the_arm_joints_and_no_geometry(urdfs, key):
    arm = collection.ARMS[key]
    text = urdfs[key].read_text(encoding="utf-8")
    for tag in ("<visual", "<collision", "<mesh", "<gazebo", "<transmission", "<dynamics"):
        assert tag not in text
    model = pin.buildModelFromUrdf(str(urdfs[key]))
    assert tuple(model.names)[1:] == arm.joints
    assert model.nq == model.nv == len(arm.joints) == len(arm.q0) == len(arm.armature)
    assert physid.load_model(str(urdfs[key])).joint_names == arm.joints


def test_panda_fingers_ride_on_the_hand(urdfs):
    # the fixed fingers' mass is lumped into the last link: the URDF's total mass is kept
    full = pin.buildModelFromUrdf(str(collection.robots_dir() / collection.ARMS["panda"].path))
    cleaned = pin.buildModelFromUrdf(str(urdfs["panda"]))
    assert full.nv == 9 and cleaned.nv == 7
    total = sum(i.mass for i in full.inertias)
    assert sum(i.mass for i in cleaned.inertias) == pytest.approx(total, rel=1e-12)


@pytest.mark.parametrize("key", ARMS)
def test_mujoco_inverse_dynamics_matches_pinocchio(urdfs, key):
    assert collection.mujoco_matches_pinocchio(urdfs[key], n=10) < 1e-9


@pytest.mark.parametrize("key", ARMS)
def test_physid_inverse_dynamics_matches_pinocchio_rnea(urdfs, key):
    model = physid.load_model(str(urdfs[key]))
    pm = pin.buildModelFromUrdf(str(urdfs[key]))
    data = pm.createData()
    q, qd, qdd = _states(pm.nv, 15, 7)
    mine = np.asarray(model.inverse_dynamics(q, qd, qdd))
    ref = np.array([pin.rnea(pm, data, q[k], qd[k], qdd[k]) for k in range(15)])
    assert np.abs(mine - ref).max() < 1e-9


def _with_drive_columns(urdf, arm):
    drive = {"armature": 0.0, "viscous": 0.0, "coulomb": 0.0}
    return physid.load_model(cases._sidecar(urdf, {j: drive for j in arm.joints}))


@pytest.mark.parametrize("key", ARMS)
def test_physid_sidecar_model_has_the_recipes_base_parameter_count(urdfs, key, tmp_path):
    arm = collection.ARMS[key]
    model = _with_drive_columns(urdfs[key], arm)
    # the recipe counts pinocchio's numerical rank; on the xArm7's rounded right angle that
    # counts a column no recording resolves (next test), so it is compared on the exact robot
    exact = collection.clean_urdf(arm, tmp_path, snap_right_angles=1e-4)
    recipe = Recipe(exact, armature=True)
    assert model.base_parameters().n_base == recipe.n_base
    assert model.joint_names == arm.joints


def test_mujoco_drive_terms_are_armature_and_viscous(urdfs):
    import mujoco

    arm = collection.ARMS["ur5"]
    nj = len(arm.joints)
    m = collection.mujoco_model(urdfs["ur5"], 5e-4, arm.armature, arm.viscous, np.zeros(nj))
    d = mujoco.MjData(m)
    pm = pin.buildModelFromUrdf(str(urdfs["ur5"]))
    data = pm.createData()
    q, qd, qdd = _states(nj, 5, 8)
    for k in range(5):
        d.qpos[:], d.qvel[:], d.qacc[:] = q[k], qd[k], qdd[k]
        mujoco.mj_inverse(m, d)
        rigid = pin.rnea(pm, data, q[k], qd[k], qdd[k])
        expected = rigid + np.asarray(arm.armature) * qdd[k] + np.asarray(arm.viscous) * qd[k]
        np.testing.assert_allclose(d.qfrc_inverse, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("key", ["ur5", "panda"])
def test_truth_explains_the_mujoco_torques_where_a_joint_slides(urdfs, key):
    # MuJoCo steps v[k+1] = v[k] + dt·a[k], so a is exact from the velocities; implicitfast
    # treats damping implicitly: (M + dt·Fv) a = τ − c − Fv v − f, hence the dt·Fv·a term.
    # frictionloss is a soft constraint, equal to Fc sign q̇ only away from rest (here
    # |q̇| > 0.2 rad/s); it acts on its own joint only, so each joint is compared where it slides.
    arm = collection.ARMS[key]
    r = cases.fourier_reference(
        cases._grid(2.0), np.asarray(arm.q0), np.random.default_rng(1), period=2.0, ramp=0.4
    )
    Q, V, T = collection.simulate_mujoco(
        urdfs[key], arm, r, cases.DT_SIM, gravity_compensation=key == "panda", settle=0.2
    )
    A = np.diff(V, axis=0) / cases.DT_SIM
    Q, V, T = Q[:-1], V[:-1], T[:-1]
    truth = cases.truth_of(
        pin.buildModelFromUrdf(str(urdfs[key])), arm.armature, arm.viscous, arm.coulomb
    )
    beta = np.r_[truth.standard.ravel(), truth.armature, truth.viscous, truth.coulomb]
    Y = Recipe(urdfs[key], armature=True).regressor(Q, V, A)
    pred = Y @ beta + cases.DT_SIM * np.asarray(arm.viscous) * A
    slide = np.abs(V) > 0.2
    assert slide.sum() > 1000
    assert np.abs(pred[slide] - T[slide]).max() < 1e-9
    # without the drive terms the rigid body alone misses by far more
    rigid = Y @ np.r_[truth.standard.ravel(), np.zeros(3 * len(arm.joints))]
    assert np.abs(rigid[slide] - T[slide]).max() > 0.5


def test_gravity_compensation_holds_the_panda_at_rest(urdfs):
    # without dry friction, which could hold the arm against a gravity torque up to 1.5 N·m off
    arm = dataclasses.replace(collection.ARMS["panda"], coulomb=(0.0,) * 7)
    q0 = np.asarray(arm.q0)
    r = np.tile(q0, (400, 1))
    Q, V, T = collection.simulate_mujoco(
        urdfs["panda"], arm, r, cases.DT_SIM, gravity_compensation=True, settle=0.0
    )
    assert np.abs(Q - q0).max() < 1e-9 and np.abs(V).max() < 1e-9
    pm = pin.buildModelFromUrdf(str(urdfs["panda"]))
    g = pin.computeGeneralizedGravity(pm, pm.createData(), q0)
    np.testing.assert_allclose(T, np.tile(g, (400, 1)), atol=1e-6)
    assert np.abs(g).max() > 5.0  # the arm would sag without it


def test_short_collection_cases_build_with_a_truth():
    case = collection.case_panda_sim(train_s=3.0, test_s=2.0)
    assert case.skipped == ""
    assert case.train.n_samples == 3000 and case.test.n_samples == 2000
    assert case.truth.standard.shape == (7, 10)
    assert case.info["mujoco_vs_pinocchio"] < 1e-9
    assert physid.load_model(case.physid_model).joint_names == collection.ARMS["panda"].joints
    assert case.train.metadata["gravity_compensation"] is True
    assert {"i", "j", "k"} <= set(cases.BUILDERS)


def test_xarm7_rounded_right_angle_is_regrouped_as_on_the_exact_robot(tmp_path):
    # xarm7.urdf writes rpy 1.5708 for π/2 (3.7e-6 rad off): Ia2 and ZZ2 then differ by 4.5e-6
    # of their norm; pinocchio's rank counts one base parameter more than the exact robot has,
    # physid regroups the two (RANK_RTOL) as on the exact robot
    from physid.models.base import RANK_RTOL

    arm = collection.ARMS["xarm7"]
    shipped = collection.clean_urdf(arm, tmp_path)
    snapped = collection.clean_urdf(arm, tmp_path, snap_right_angles=1e-4)
    assert "1.5708 " in shipped.read_text(encoding="utf-8")
    assert "1.5707963267948966" in snapped.read_text(encoding="utf-8")
    assert Recipe(shipped, armature=True).n_base == Recipe(snapped, armature=True).n_base + 1 == 63
    model = _with_drive_columns(shipped, arm)
    base = model.base_parameters()
    assert base.n_base == _with_drive_columns(snapped, arm).base_parameters().n_base == 62
    # the regrouping holds to the rounding: the kept columns reproduce the whole regressor to
    # about 1e-6 of its largest column, far below RANK_RTOL and far above round-off
    q, qd, qdd = _states(7, 40, 11)
    Y = np.asarray(model.regressor(q, qd, qdd)).reshape(-1, len(model.regressor_names))
    K, ind = np.asarray(base.base_matrix), np.asarray(base.independent_index)
    err = np.linalg.norm(Y - Y[:, ind] @ K, axis=0).max() / np.linalg.norm(Y, axis=0).max()
    assert 1e-9 < err < 0.1 * RANK_RTOL


def test_cases_are_skipped_with_the_reason_without_the_collection(monkeypatch):
    def missing(name):
        raise collection.importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(collection.importlib.metadata, "distribution", missing)
    assert "pip install" in collection.collection_available()
    case = collection.case_ur5(train_s=1.0, test_s=1.0)
    assert case.skipped.startswith("example-robot-data not installed") and case.train is None
    with pytest.raises(RuntimeError, match="example-robot-data not installed"):
        collection.robots_dir()
