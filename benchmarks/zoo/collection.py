"""Robots of a well-kept URDF collection (``example-robot-data``) in the zoo.

``pip install example-robot-data`` (BSD-3-Clause; tested with 6.0.0) installs the URDFs of the
Gepetto/LAAS collection under ``cmeel.prefix/share/example-robot-data/robots`` of its
distribution (the wheel has no Python module; the folder is found through
``importlib.metadata``). Three arms are used:

* Universal Robots UR5, ``ur_description/urdf/ur5_robot.urdf`` (6 revolute joints);
* Franka Emika Panda, ``panda_description/urdf/panda.urdf`` (7 arm joints; the two finger
  joints are made fixed, so the fingers ride on the hand as rigid mass);
* UFACTORY xArm7, ``xarm_description/urdf/xarm7.urdf`` (7 revolute joints).

Each is written again, cleaned, to a temporary folder: visual and collision geometry, gazebo,
transmission and ``<dynamics>`` elements removed (MuJoCo and physid need no meshes; the drive
terms are the simulator's, set below, never the URDF's), the joints outside the arm fixed.

Cases (registered in ``cases.BUILDERS``; the truth is pinocchio's inertials of the cleaned URDF
plus the simulator's armature, viscous and Coulomb friction; physid reads the cleaned URDF
through a sidecar that adds ``armature``, ``viscous`` and ``coulomb`` per joint):

(i) UR5 in MuJoCo (armature, damping, frictionloss: joints truly stick), PD without gravity
    compensation, slow 5-harmonic Fourier reference of 20 s period, logged at 250 Hz with
    positions quantised to 2^16 counts/turn, 2 % torque noise; 40 s, held out 20 s.
(j) Panda in MuJoCo, dry friction and rotor inertia, PD plus gravity compensation computed by
    pinocchio at the measured q, Fourier reference of 8 s period, 1 kHz, σ_q = 1e-4 rad, 5 %
    torque noise; 16 s, held out 10 s.
(k) xArm7 simulated by pinocchio (``cases.simulate_pinocchio``: RK4 on ``aba``) with viscous
    and Coulomb friction (Fc·tanh(q̇/0.01 rad/s)), point-to-point minimum-jerk moves with rests
    of 0.5–2 s, 1 kHz, σ_q = 1e-4 rad, 5 % torque noise; 20 s, held out 12 s of other moves.
"""

from __future__ import annotations

import importlib.metadata
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from . import cases as zc

PACKAGE = "example-robot-data"
SHARE = "cmeel.prefix/share/example-robot-data/robots"


@dataclass(frozen=True)
class Arm:
    """One arm of the collection and what the zoo's simulations of it use.

    Drive terms per joint: armature [kg·m²] (rotor inertia reflected to the joint), viscous
    [N·m·s/rad] (MuJoCo ``damping``), Coulomb [N·m] (MuJoCo ``frictionloss``); PD gains
    Kp [N·m/rad], Kd [N·m·s/rad]; q0 [rad] a pose away from singularities and joint limits."""

    key: str
    path: str  # inside the collection's robots folder
    joints: tuple  # the arm's joints, base to tip; every other movable joint is made fixed
    q0: tuple
    kp: tuple
    kd: tuple
    armature: tuple
    viscous: tuple
    coulomb: tuple


ARMS = {
    "ur5": Arm(
        "ur5",
        "ur_description/urdf/ur5_robot.urdf",
        (
            "shoulder_pan_joint",
            "shoulder_lift_joint",
            "elbow_joint",
            "wrist_1_joint",
            "wrist_2_joint",
            "wrist_3_joint",
        ),
        q0=(0.0, -1.2, 1.2, -1.5, -1.5, 0.0),
        kp=(800.0, 800.0, 400.0, 100.0, 100.0, 50.0),
        kd=(80.0, 80.0, 40.0, 10.0, 10.0, 5.0),
        armature=(0.35, 0.35, 0.20, 0.06, 0.06, 0.05),
        viscous=(1.5, 1.5, 1.0, 0.4, 0.4, 0.3),
        coulomb=(2.5, 2.5, 1.8, 0.8, 0.8, 0.6),
    ),
    "panda": Arm(
        "panda",
        "panda_description/urdf/panda.urdf",
        tuple(f"panda_joint{k}" for k in range(1, 8)),
        q0=(0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8),
        kp=(600.0, 600.0, 500.0, 500.0, 200.0, 150.0, 60.0),
        kd=(50.0, 50.0, 40.0, 40.0, 15.0, 12.0, 5.0),
        armature=(0.25, 0.25, 0.20, 0.20, 0.08, 0.08, 0.05),
        viscous=(1.0, 1.0, 0.8, 0.8, 0.4, 0.4, 0.3),
        coulomb=(1.5, 1.5, 1.2, 1.2, 0.6, 0.6, 0.4),
    ),
    "xarm7": Arm(
        "xarm7",
        "xarm_description/urdf/xarm7.urdf",
        tuple(f"joint{k}" for k in range(1, 8)),
        q0=(0.0, -0.3, 0.0, 1.2, 0.0, 1.2, 0.0),
        kp=(600.0, 600.0, 400.0, 400.0, 150.0, 150.0, 60.0),
        kd=(50.0, 50.0, 35.0, 35.0, 12.0, 12.0, 5.0),
        armature=(0.20, 0.20, 0.15, 0.15, 0.06, 0.06, 0.04),
        viscous=(1.2, 1.2, 0.9, 0.9, 0.4, 0.4, 0.3),
        coulomb=(2.0, 2.0, 1.5, 1.5, 0.7, 0.7, 0.5),
    ),
}


def collection_available() -> str:
    """'' when example-robot-data is installed, else why not (and how to install it)."""
    try:
        root = Path(str(importlib.metadata.distribution(PACKAGE).locate_file(SHARE)))
    except importlib.metadata.PackageNotFoundError:
        return f"{PACKAGE} not installed; pip install 'physid[zoo]' (or {PACKAGE}>=6)"
    if not root.is_dir():
        return f"{PACKAGE} installed but its robots folder {root} is missing"
    return ""


def robots_dir() -> Path:
    """The collection's robots folder (raises RuntimeError with the reason if absent)."""
    why = collection_available()
    if why:
        raise RuntimeError(why)
    return Path(str(importlib.metadata.distribution(PACKAGE).locate_file(SHARE)))


_DROP = ("visual", "collision")  # inside links
_DROP_TOP = (
    "gazebo",
    "transmission",
    "ros2_control",
)  # top-level elements the dynamics do not need


def _snap_right_angles(robot, tol):
    """Joint-origin ``rpy`` angles within ``tol`` rad of a multiple of π/2 set to it exactly
    (xarm7.urdf writes 1.5708 for π/2: 3.7e-6 rad off, its axes 1 and 2 are not quite at a
    right angle, which makes Ia2 and ZZ2 separable by 1e-6 of the torque only)."""
    for joint in robot.findall("joint"):
        origin = joint.find("origin")
        if origin is None or origin.get("rpy") is None:
            continue
        rpy = np.array([float(x) for x in origin.get("rpy").split()])
        k = np.round(rpy / (np.pi / 2))
        near = np.abs(rpy - k * np.pi / 2) < tol
        rpy[near] = k[near] * np.pi / 2
        origin.set("rpy", " ".join(repr(float(x)) for x in rpy))


def clean_urdf(arm: Arm, folder: Path, *, snap_right_angles=0.0) -> Path:
    """Write ``arm``'s URDF without geometry, gazebo/transmission/dynamics elements, its
    non-arm joints fixed, to ``folder/<key>.urdf``; returns the path (rewritten each call).
    ``snap_right_angles`` [rad] > 0: joint-origin angles that close to a multiple of π/2 are
    set to it (the file's suffix is then ``_snapped``)."""
    tree = ET.parse(robots_dir() / arm.path)
    robot = tree.getroot()
    if snap_right_angles > 0:
        _snap_right_angles(robot, snap_right_angles)
    for el in [e for e in robot if e.tag in _DROP_TOP]:
        robot.remove(el)
    for link in robot.findall("link"):
        for el in [e for e in link if e.tag in _DROP]:
            link.remove(el)
    found = []
    for joint in robot.findall("joint"):
        for el in [e for e in joint if e.tag in ("dynamics", "mimic", "safety_controller")]:
            joint.remove(el)
        if joint.get("type") == "fixed":
            continue
        if joint.get("name") in arm.joints:
            found.append(joint.get("name"))
        else:
            joint.set("type", "fixed")
            for el in [e for e in joint if e.tag in ("axis", "limit")]:
                joint.remove(el)
    if sorted(found) != sorted(arm.joints):
        raise ValueError(f"{arm.path}: arm joints {arm.joints}, found {found}")
    folder.mkdir(parents=True, exist_ok=True)
    out = folder / f"{arm.key}{'_snapped' if snap_right_angles > 0 else ''}.urdf"
    tree.write(out, encoding="utf-8", xml_declaration=True)
    return out


def pinocchio_model(urdf: Path, armature=None):
    """pinocchio's model of a cleaned URDF, with ``armature`` [kg·m²] per joint if given."""
    model = pin.buildModelFromUrdf(str(urdf))
    if armature is not None:
        model.armature[:] = armature
    return model


def mujoco_model(urdf: Path, dt, armature, damping, frictionloss):
    """MuJoCo's model of a cleaned URDF: drive terms per joint, no contacts, no joint limits
    (the references stay inside them; a limit constraint would be a force in no estimator's
    model), implicitfast at ``dt`` [s]."""
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(urdf))
    m.opt.timestep = dt
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    m.jnt_limited[:] = 0
    m.dof_armature[:] = armature
    m.dof_damping[:] = damping
    m.dof_frictionloss[:] = frictionloss
    return m


def mujoco_matches_pinocchio(urdf: Path, n=20, seed=3) -> float:
    """Largest |τ_MuJoCo − τ_pinocchio| [N·m] of the rigid-body inverse dynamics (no drive
    terms) of a cleaned URDF at ``n`` random states (q ∈ ±2 rad, q̇, q̈ standard normal)."""
    import mujoco

    nj = pinocchio_model(urdf).nv
    m = mujoco_model(urdf, 5e-4, np.zeros(nj), np.zeros(nj), np.zeros(nj))
    d = mujoco.MjData(m)
    pm = pinocchio_model(urdf)
    pd = pm.createData()
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(n):
        q, v, a = rng.uniform(-2, 2, nj), rng.normal(size=nj), rng.normal(size=nj)
        d.qpos[:], d.qvel[:], d.qacc[:] = q, v, a
        mujoco.mj_inverse(m, d)
        worst = max(worst, float(np.abs(d.qfrc_inverse - pin.rnea(pm, pd, q, v, a)).max()))
    return worst


def simulate_mujoco(urdf, arm: Arm, r, dt, *, gravity_compensation=False, settle=1.0):
    """``arm`` (cleaned URDF) in MuJoCo under τ = Kp (r − q) − Kd q̇ [+ g(q)], the torque
    applied through ``qfrc_applied`` and held over each step; g(q) by pinocchio's
    ``computeGeneralizedGravity`` at the simulated q. Starts at rest at r[0], holds it for
    ``settle`` s. r: (n_steps, n) [rad] on the step grid ``dt`` [s]. Returns q, q̇, τ (the
    commanded joint torque) at the steps."""
    import mujoco

    kp, kd = np.asarray(arm.kp), np.asarray(arm.kd)
    m = mujoco_model(urdf, dt, arm.armature, arm.viscous, arm.coulomb)
    d = mujoco.MjData(m)
    pm = pinocchio_model(urdf)
    pd = pm.createData()
    d.qpos[:] = r[0]
    Q, V, T = np.empty_like(r), np.empty_like(r), np.empty_like(r)
    for k in range(-int(round(settle / dt)), r.shape[0]):
        q, v = d.qpos.copy(), d.qvel.copy()
        tau = kp * (r[max(k, 0)] - q) - kd * v
        if gravity_compensation:
            tau = tau + pin.computeGeneralizedGravity(pm, pd, q)
        if k >= 0:
            Q[k], V[k], T[k] = q, v, tau
        d.qfrc_applied[:] = tau
        mujoco.mj_step(m, d)
    if not np.all(np.isfinite(Q)) or np.abs(Q - r).max() > 0.5:
        raise RuntimeError(
            f"{arm.key}: simulation diverged (max |r − q| {np.abs(Q - r).max():.3g})"
        )
    return Q, V, T


def _measure(t, q, tau, r, arm, rng, *, sigma_q, torque_noise, counts=None, source="", extra=None):
    """The measured record (`benchmarks.zoo.cases._record`) with the arm's PD gains."""
    return zc._record(
        t,
        q,
        tau,
        r,
        rng,
        sigma_q=sigma_q,
        torque_noise=torque_noise,
        counts=counts,
        source=source,
        gains=(arm.kp, arm.kd),
        extra=extra,
    )


def _run(sim, urdf, arm, r, every, rng, **measure):
    """Simulate on r (DT_SIM grid) with ``sim`` ('mujoco', 'mujoco+g' or 'pinocchio'), keep
    every ``every``-th step; (measured record, noise-free τ, noise-free record)."""
    if sim == "pinocchio":
        model = pinocchio_model(urdf, arm.armature)
        Q, _, T = zc.simulate_pinocchio(
            model,
            r,
            zc.DT_SIM,
            np.asarray(arm.kp),
            np.asarray(arm.kd),
            np.asarray(arm.viscous),
            np.asarray(arm.coulomb),
            zc.COULOMB_SMOOTHING,
        )
        if not np.all(np.isfinite(Q)) or np.abs(Q - r).max() > 0.5:
            raise RuntimeError(f"{arm.key}: simulation diverged")
    else:
        Q, _, T = simulate_mujoco(urdf, arm, r, zc.DT_SIM, gravity_compensation=sim == "mujoco+g")
    keep = slice(None, None, every)
    t = np.arange(r.shape[0])[keep] * zc.DT_SIM
    rec = _measure(t, Q[keep], T[keep], r[keep], arm, rng, **measure)
    clean = _measure(
        t,
        Q[keep],
        T[keep],
        r[keep],
        arm,
        rng,
        sigma_q=0.0,
        torque_noise=0.0,
        source=measure.get("source", ""),
        extra=measure.get("extra"),
    )
    return rec, T[keep], clean


def _case(
    key, title, arm, sim, references, every, *, seed, bandwidth_hz, note="", snap=0.0, **measure
):
    """A collection case: the cleaned URDF, its sidecar, the two records, the truth."""
    why = collection_available() or (zc.mujoco_available() if sim.startswith("mujoco") else "")
    if why:
        return zc.Case(key, title, Path(arm.path), "", skipped=why)
    urdf = clean_urdf(arm, zc._scratch() / "collection", snap_right_angles=snap)
    drive = {"armature": 0.0, "viscous": 0.0, "coulomb": 0.0}
    model = zc._sidecar(urdf, {j: drive for j in arm.joints})
    rng = np.random.default_rng(seed)
    train, _, clean = _run(sim, urdf, arm, references[0], every, rng, **measure)
    test, tau_true, _ = _run(sim, urdf, arm, references[1], every, rng, **measure)
    nj = len(arm.joints)
    lag = np.abs(
        clean.select([f"q{j + 1}" for j in range(nj)])
        - clean.select([f"r{j + 1}" for j in range(nj)])
    ).max()
    info = {"tracking_max_rad": float(lag)}
    note = f"{note}; PD tracking max |r − q| {lag:.2f} rad"
    if sim.startswith("mujoco"):
        mismatch = mujoco_matches_pinocchio(urdf)
        info["mujoco_vs_pinocchio"] = mismatch
        note = f"{note}; MuJoCo vs pinocchio inverse dynamics: max |Δτ| {mismatch:.1e} N·m"
    return zc.Case(
        key=key,
        title=title,
        urdf=urdf,
        physid_model=model,
        train=train,
        test=test,
        test_tau_true=tau_true,
        train_clean=clean,
        truth=zc.truth_of(pinocchio_model(urdf), arm.armature, arm.viscous, arm.coulomb),
        bandwidth_hz=bandwidth_hz,
        armature=True,
        note=note.strip("; "),
        info=info,
    )


def case_ur5(train_s=40.0, test_s=20.0) -> zc.Case:
    """(i) UR5 in MuJoCo, slow Fourier sweep (20 s period), 250 Hz, 2^16 counts/turn."""
    arm = ARMS["ur5"]
    q0, period = np.asarray(arm.q0), 20.0
    kw = {"period": period, "velocity": 0.6, "acceleration": 1.0, "position": 1.0, "ramp": 2.0}
    refs = [
        zc.fourier_reference(zc._grid(s), q0, np.random.default_rng(seed), **kw)
        for s, seed in ((train_s, 91), (test_s, 92))
    ]
    return _case(
        "i",
        f"UR5 (example-robot-data) MuJoCo, frictionloss+damping+armature, 0.05 Hz sweep, 250 Hz, "
        f"2^16 counts/turn ({train_s:g} s / {test_s:g} s)",
        arm,
        "mujoco",
        refs,
        8,
        seed=90,
        bandwidth_hz=5 / period,
        sigma_q=0.0,
        counts=2**16,
        torque_noise=0.02,
        source="MuJoCo implicitfast, 250 Hz, 2^16 counts/turn",
        note=f"encoder step {2 * np.pi / 2**16:.2e} rad; PD without gravity compensation",
    )


def case_panda_sim(train_s=16.0, test_s=10.0) -> zc.Case:
    """(j) Panda in MuJoCo, dry friction and rotor inertia, PD + gravity compensation."""
    arm = ARMS["panda"]
    q0, period = np.asarray(arm.q0), 8.0
    refs = [
        zc.fourier_reference(zc._grid(s), q0, np.random.default_rng(seed), period=period)
        for s, seed in ((train_s, 101), (test_s, 102))
    ]
    return _case(
        "j",
        f"Panda (example-robot-data) MuJoCo, frictionloss+damping+armature, PD + gravity "
        f"compensation, Fourier 1 kHz ({train_s:g} s / {test_s:g} s)",
        arm,
        "mujoco+g",
        refs,
        2,
        seed=100,
        bandwidth_hz=5 / period,
        sigma_q=zc.SIGMA_Q,
        torque_noise=zc.TORQUE_NOISE,
        source="MuJoCo implicitfast, PD + pinocchio gravity compensation",
        extra={"gravity_compensation": True},
        note="fingers fixed to the hand; τ = Kp(r − q) − Kd q̇ + g(q)",
    )


def case_xarm7(train_s=20.0, test_s=12.0, snap_right_angles=0.0) -> zc.Case:
    """(k) xArm7 by pinocchio, viscous + Coulomb (tanh) friction, point-to-point with rests
    (``snap_right_angles`` [rad]: see `clean_urdf`; 0 keeps the collection's 1.5708)."""
    arm = ARMS["xarm7"]
    q0 = np.asarray(arm.q0)
    refs = [
        zc.p2p_reference(zc._grid(s), q0, np.random.default_rng(seed), position=0.6)
        for s, seed in ((train_s, 111), (test_s, 112))
    ]
    return _case(
        "k",
        f"xArm7 (example-robot-data) pinocchio, viscous+Coulomb (tanh), point-to-point with "
        f"rests ({train_s:g} s / {test_s:g} s)"
        + (", right angles snapped" if snap_right_angles else ""),
        arm,
        "pinocchio",
        refs,
        2,
        seed=110,
        bandwidth_hz=2.0,  # the ≥ 1 s minimum-jerk moves, as in (b)
        sigma_q=zc.SIGMA_Q,
        torque_noise=zc.TORQUE_NOISE,
        source="pinocchio aba, RK4",
        snap=snap_right_angles,
        note=f"Coulomb smoothed: Fc·tanh(q̇/{zc.COULOMB_SMOOTHING:g} rad/s)"
        + ("" if snap_right_angles else "; the URDF's rpy 1.5708 (π/2 − 3.7e-6) kept"),
    )
