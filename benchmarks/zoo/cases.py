"""The zoo's records: robots simulated by other simulators, and real logs.

Every case gives an identification record and a *different* held-out record (physid
`Recording`s with ``t``, ``q1..qn`` [rad], ``tau1..taun`` [N·m]; simulated ones also carry the
PD reference ``r1..rn`` and the gains in ``metadata["kp"]``/``["kd"]``, which IDIM-IV needs), the
URDF the recipe reads, the model physid reads, the trajectory bandwidth a practitioner would know,
and the truth where there is one.

Simulated cases (the motion and the torques come from pinocchio or MuJoCo, never from physid):

(a) ``arm6`` (physid's UR5-like URDF, ``src/physid/models/data/arm6.urdf``, with the reflected
    rotor inertias of its sidecar as pinocchio ``armature``) under the PD law
    ``τ = Kp (r − q) − Kd q̇`` (the law of physid's docs, so that IDIM-IV models the loop
    exactly), reference a windowed 5-harmonic Fourier series, fixed-step RK4 on
    ``pinocchio.aba`` at 2 kHz with the torque held over each step, logged at 1 kHz;
    σ_q = 1e-4 rad encoder noise, white torque noise of 5 % of each joint's rms; no friction.
(b) The same arm with viscous and Coulomb friction (Coulomb smoothed as Fc·tanh(q̇/0.01 rad/s),
    which creeps instead of sticking), trained on a Fourier segment followed by point-to-point
    minimum-jerk moves with rests of 0.5–2 s, held out on other moves and another Fourier segment.
(c) The same URDF loaded by MuJoCo (its own URDF parser and dynamics; checked against pinocchio's
    inverse dynamics to 1e-9), joint ``armature``, ``damping`` (viscous) and ``frictionloss``
    (Coulomb friction as a constraint: joints truly stick at rest), ``implicitfast`` integrator at
    2 kHz, PD applied through ``qfrc_applied``; σ_q = 1e-4 rad, 5 % torque noise. Only when
    ``import mujoco`` works (``pip install mujoco``).
(d) A slow sweep: the arm of (b), a 5-harmonic Fourier reference with a 0.05 Hz fundamental
    (20 s period), logged at 250 Hz with positions quantised by a 2^16 counts/turn encoder (no
    other position noise), 5 % torque noise.
(f) A linear drive like the EMPS benchmark (Janot, Gautier, Brunot, "Data set and reference
    models of EMPS", 2019): a 95 kg carriage on a horizontal prismatic axis, viscous 200 N·s/m,
    asymmetric Coulomb friction (+20 N for motion in +x, −17 N in −x: Coulomb 18.5 N and an
    offset 1.5 N), simulated by `drives.LinearDrive` (exact integration between the controller's
    samples, the carriage truly sticks at rest while the force lies in [−17, 20] N); PD position
    loop at 1 kHz on a 1 µm encoder (its velocity a backward difference), point-to-point
    minimum-jerk moves with rests of 0.3–1.2 s; the force is logged as the controller's voltage
    (16-bit over ±10 V, σ 0.01 V) times the drive gain 35.15 N/V, the product the benchmark
    writes as ``tau1`` (as users of EMPS do); 25 s, held out 15 s of other moves.
    Recipe and physid both get a constant (offset) column besides viscous and Coulomb.
(g) A 2-link arm in a vertical plane written here (`drives.TwoLink`: equations of motion by
    hand, checked against pinocchio's inverse dynamics to 1e-9 in ``tests/test_zoo_cases.py``),
    gears of ratio 100 with rotor inertia, Stribeck friction per joint
    (Fc + (Fs − Fc) exp(−(q̇/vs)²)) tanh(q̇/1e-3) + Fv q̇, PD loop at 5 kHz on 2^14 counts/turn
    motor encoders, RK4 at 10 kHz; logged at 5 kHz as motor angles ``qm1, qm2`` and motor
    currents ``im1, im2`` (12-bit over ±5 A, σ 5 mA, kt 0.05 N·m/A). physid reads that log
    through the ``[transmission]`` table of its sidecar (gear ratios, torque constants), as
    ``physid identify log.csv --model arm.toml`` would; the recipe gets q = θm/100 and
    τ = 100·kt·i. Fourier reference (10 s period, 5 harmonics), 20 s, held out 10 s.
    Its truth's Coulomb column is Fc: the Stribeck hump is in no estimator's model.
(h) The arm of (g) with elastic joints (`flexible.FlexibleTwoLink`, Spong's reduced model: a
    spring and damper between each gear and its link; joint modes 17.2 / 30.7 Hz), viscous and
    Coulomb friction on the motors, PD at 5 kHz on 2^20 counts/turn motor encoders, logged
    and read like (g). The truth is the low-frequency limit: the rigid arm with armature N²Jm.
(i)–(k) Arms of the example-robot-data collection (UR5, Panda, xArm7): see ``collection.py``.
(aq) Quick mode: case (a) with an 8 s identification record and a 6 s held-out one.

Real logs, read at run time from ``../shared/data/real-robots/`` next to the repository (or
the main checkout of a git worktree, or ``$PHYSID_REAL_ROBOTS``), never copied here; a case whose folder is absent is skipped with a note:

(e1) Franka Emika Panda, Gaz et al., "Dynamic Identification of the Franka Emika Panda Robot With
     Retrieval of Feasible Parameters Using Penalty-Based Optimization", IEEE RA-L 4(4), 2019;
     data from github.com/marcocognetti/FrankaEmikaPandaDynModel,
     ``matlab/data/Exciting_Traj/Trajectory_1/``, added in commit
     44f1ec8a615555eb3469ca9b0abd31ef863872b5 (unchanged at 24d85ce4e648e2e894c832bfeee9b16711eb1a1a),
     licence GPL-3.0. Converted CSV ``panda_gaz2019/exciting_traj_1.csv``, read with the
     reconstructed robot clock ``t_tick`` and resampled to a uniform grid; identification on the
     first half, held out on the second (which partly retraces the first: period 13.3 s).
(e2) KUKA LWR4+, FloBaRoID by Stefan Bethge, github.com/kjyv/FloBaRoID,
     ``data/KUKA/HW/measurements_{1,2,3}.npz`` as added in commit
     4e2e5a2992f2175aa4e494c0d827590435a969a8 (same blobs as the LFS pointers at head
     9c0680445e874947bac4056cd86ff9e26bdd7fcb), licence LGPL-3.0. Converted CSVs
     ``kuka_lwr4_flobaroid/measurements_{1,3}.csv`` (already low-passed by the source: positions
     3 Hz, torques 2 Hz), resampled to a uniform grid; identification on run 1, held out on run 3
     (another trajectory).

The real logs have no truth. physid reads their URDFs through a sidecar written to a temporary
folder that adds viscous and Coulomb friction per joint (the URDFs have no ``<dynamics>``), the
same friction columns the recipe uses.
"""

from __future__ import annotations

import importlib
import os
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

import physid

from .drives import LinearDrive, TwoLink
from .flexible import FlexibleTwoLink

ROOT = Path(__file__).resolve().parents[2]
ARM6_URDF = ROOT / "src" / "physid" / "models" / "data" / "arm6.urdf"

# arm6: PD gains (τ = Kp (r − q) − Kd q̇), rotor inertia reflected to the joint [kg·m²],
# viscous [N·m·s/rad] and Coulomb [N·m] friction (the values of physid's arm6 sidecar, which a
# robot of this class has; the simulators are told them, the estimators are not).
KP = np.array([400.0, 400.0, 200.0, 50.0, 50.0, 20.0])
KD = 0.1 * KP
ARMATURE = np.array([0.40, 0.40, 0.20, 0.05, 0.05, 0.05])
VISCOUS = np.array([2.0, 2.0, 1.2, 0.4, 0.4, 0.3])
COULOMB = np.array([3.0, 3.5, 2.0, 0.8, 0.8, 0.6])
Q0 = np.array([0.0, -1.2, 1.2, -1.5, -1.5, 0.0])  # rest pose: elbow bent, wrist away from singular
SIGMA_Q = 1e-4  # rad
TORQUE_NOISE = 0.05  # of each joint's rms
COULOMB_SMOOTHING = 0.01  # rad/s (case b, d)
DT_SIM = 5e-4  # s, simulator step (the controller's period too)


def real_robots_dir() -> Path:
    """Folder of the real logs: ``$PHYSID_REAL_ROBOTS``, else ``shared/data/real-robots`` next
    to the repository (for a git worktree: next to the main checkout too), the first that exists."""
    env = os.environ.get("PHYSID_REAL_ROBOTS")
    if env:
        return Path(env)
    tail = Path("shared") / "data" / "real-robots"
    candidates = [ROOT.parent / tail, ROOT / tail]
    try:  # a worktree: the main checkout is the parent of the common .git folder
        common = subprocess.run(
            ["git", "rev-parse", "--path-format=absolute", "--git-common-dir"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout.strip()
        if common:
            candidates.append(Path(common).parent.parent / tail)
    except (OSError, subprocess.SubprocessError):
        pass
    return next((c for c in candidates if c.is_dir()), candidates[0])


@dataclass
class Truth:
    """The simulated robot, in the recipe's layout: per joint the 10 standard parameters of
    the link in pinocchio's order (m, mc, I about the joint frame's origin), and the drive terms."""

    standard: np.ndarray  # (n_joints, 10)
    armature: np.ndarray
    viscous: np.ndarray
    coulomb: np.ndarray
    offset: np.ndarray | None = None  # Fc sign q̇ + offset: asymmetric Coulomb friction


@dataclass
class Case:
    key: str
    title: str
    urdf: Path  # what the recipe (pinocchio) reads
    physid_model: str  # what physid.load_model reads
    train: physid.Recording | None = None
    test: physid.Recording | None = None
    test_tau_true: np.ndarray | None = None  # noise-free torque of the held-out record
    train_clean: physid.Recording | None = None  # the identification record without noise
    truth: Truth | None = None
    bandwidth_hz: float = 1.0  # of the trajectory, as a practitioner knows it
    armature: bool = False  # the recipe adds a rotor-inertia column per joint
    offset: bool = False  # the recipe adds a constant column per joint (asymmetric Coulomb)
    physid_train: physid.Recording | None = None  # motor-side log physid reads (else train)
    physid_test: physid.Recording | None = None
    skipped: str = ""  # why the case could not be built
    note: str = ""
    info: dict = field(default_factory=dict)


# ----------------------------------------------------------------------------- references
def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x**3 * (10 - 15 * x + 6 * x**2)


def fourier_reference(
    t, q_start, rng, *, period, harmonics=5, position=0.8, velocity=1.0, acceleration=4.0, ramp=1.0
):
    """q_start + w(t)·(F(t) − F(0)), F a random Fourier series (Swevers form) scaled per joint
    to the position amplitude, velocity and acceleration given, w a 5th-order ramp over
    ``ramp`` s at both ends (the segment starts and ends at rest at q_start)."""
    nj = q_start.size
    w = 2 * np.pi / period
    a, b = rng.normal(size=(2, harmonics, nj))
    ls = np.arange(1, harmonics + 1)[:, None]
    tt = t[:, None, None]
    lw = ls[None] * w
    F = np.sum(a / lw * np.sin(lw * tt) - b / lw * np.cos(lw * tt), axis=1)
    Fd = np.sum(a * np.cos(lw * tt) + b * np.sin(lw * tt), axis=1)
    Fdd = np.sum(lw * (-a * np.sin(lw * tt) + b * np.cos(lw * tt)), axis=1)
    dF = F - F[0]
    scale = np.min(
        [
            position / np.abs(dF).max(0),
            velocity / np.abs(Fd).max(0),
            acceleration / np.abs(Fdd).max(0),
        ],
        axis=0,
    )
    win = _smoothstep(t / ramp) * _smoothstep((t[-1] - t) / ramp)
    return q_start + win[:, None] * dF * scale


def p2p_reference(t, q_start, rng, *, position=0.8, velocity=1.0, rest=(0.5, 2.0)):
    """Minimum-jerk moves of all joints to random targets within ±position of q_start, each
    followed by a rest of ``rest`` s; starts with a rest at q_start and ends at rest."""
    nj = q_start.size
    r = np.empty((t.size, nj))
    q = q_start.copy()
    t0 = 0.0
    hold = rng.uniform(*rest)
    segments = []
    while t0 + hold < t[-1]:
        segments.append((t0, t0 + hold, q.copy(), q.copy()))
        t0 += hold
        target = q_start + rng.uniform(-position, position, nj)
        move = max(1.0, 1.875 * np.abs(target - q).max() / velocity)
        segments.append((t0, t0 + move, q.copy(), target.copy()))
        q = target
        t0 += move
        hold = rng.uniform(*rest)
    segments.append((t0, np.inf, q.copy(), q.copy()))
    for s0, s1, qa, qb in segments:
        m = (t >= s0) & (t < s1)
        if np.isfinite(s1):
            s = _smoothstep((t[m] - s0) / (s1 - s0))[:, None]
        else:
            s = np.zeros((m.sum(), 1))
        r[m] = qa + s * (qb - qa)
    return r


# ----------------------------------------------------------------------------- simulators
def pinocchio_arm(armature=ARMATURE):
    model = pin.buildModelFromUrdf(str(ARM6_URDF))
    model.armature[:] = armature
    return model


def truth_of(model, armature, viscous, coulomb) -> Truth:
    std = np.array([model.inertias[j + 1].toDynamicParameters() for j in range(model.nv)])
    return Truth(
        std, np.asarray(armature, float), np.asarray(viscous, float), np.asarray(coulomb, float)
    )


def simulate_pinocchio(model, r, dt, kp, kd, viscous, coulomb, smoothing, settle=1.0):
    """Closed loop τ = Kp (r − q) − Kd q̇ held over each step, RK4 on pinocchio.aba with
    friction τ_f = Fv q̇ + Fc tanh(q̇ / smoothing). r: (n_steps, n) on the step grid.
    Starts at rest at r[0] and holds r[0] for ``settle`` s first (gravity sag settles).
    Returns q, q̇, τ (n_steps, n) at the steps."""
    data = model.createData()
    fv, fc = np.asarray(viscous, float), np.asarray(coulomb, float)
    has_fc = bool(np.any(fc))

    def acc(q, v, tau):
        f = tau - fv * v
        if has_fc:
            f = f - fc * np.tanh(v / smoothing)
        return pin.aba(model, data, q, v, f)

    n_settle = int(round(settle / dt))
    n = r.shape[0]
    q = r[0].copy()
    v = np.zeros_like(q)
    Q, V, T = np.empty_like(r), np.empty_like(r), np.empty_like(r)
    for k in range(-n_settle, n):
        rk = r[max(k, 0)]
        tau = kp * (rk - q) - kd * v
        if k >= 0:
            Q[k], V[k], T[k] = q, v, tau
        a1 = acc(q, v, tau)
        q2, v2 = q + 0.5 * dt * v, v + 0.5 * dt * a1
        a2 = acc(q2, v2, tau)
        q3, v3 = q + 0.5 * dt * v2, v + 0.5 * dt * a2
        a3 = acc(q3, v3, tau)
        q4, v4 = q + dt * v3, v + dt * a3
        a4 = acc(q4, v4, tau)
        q = q + dt / 6 * (v + 2 * v2 + 2 * v3 + v4)
        v = v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    return Q, V, T


def mujoco_available() -> str:
    """'' when mujoco imports, else why not."""
    try:
        import mujoco  # noqa: F401
    except Exception as exc:  # ImportError, or a broken binary wheel
        return f"mujoco not importable ({type(exc).__name__}: {exc}); pip install mujoco"
    return ""


def simulate_mujoco(r, dt, kp, kd, armature, damping, frictionloss, settle=1.0):
    """arm6.urdf in MuJoCo: armature, damping, frictionloss per joint, no contacts,
    implicitfast at dt, PD law through qfrc_applied. Returns q, q̇, τ at the steps."""
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(ARM6_URDF))
    m.opt.timestep = dt
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    m.dof_armature[:] = armature
    m.dof_damping[:] = damping
    m.dof_frictionloss[:] = frictionloss
    d = mujoco.MjData(m)
    d.qpos[:] = r[0]
    n_settle = int(round(settle / dt))
    Q, V, T = np.empty_like(r), np.empty_like(r), np.empty_like(r)
    for k in range(-n_settle, r.shape[0]):
        q, v = d.qpos.copy(), d.qvel.copy()
        tau = kp * (r[max(k, 0)] - q) - kd * v
        if k >= 0:
            Q[k], V[k], T[k] = q, v, tau
        d.qfrc_applied[:] = tau
        mujoco.mj_step(m, d)
    return Q, V, T


def mujoco_matches_pinocchio(n=20, seed=3) -> float:
    """Largest |τ_MuJoCo − τ_pinocchio| of the rigid-body inverse dynamics at random states."""
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(ARM6_URDF))
    d = mujoco.MjData(m)
    pm = pin.buildModelFromUrdf(str(ARM6_URDF))
    pd = pm.createData()
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(n):
        q, v, a = rng.uniform(-2, 2, 6), rng.normal(size=6), rng.normal(size=6)
        d.qpos[:], d.qvel[:], d.qacc[:] = q, v, a
        mujoco.mj_inverse(m, d)
        worst = max(worst, float(np.abs(d.qfrc_inverse - pin.rnea(pm, pd, q, v, a)).max()))
    return worst


# ----------------------------------------------------------------------------- records
def _record(
    t,
    q,
    tau,
    r,
    rng,
    *,
    sigma_q=SIGMA_Q,
    torque_noise=TORQUE_NOISE,
    counts=None,
    source="",
    gains=(KP, KD),
    extra=None,
):
    """The measured record: q + white noise σ_q (then quantised to ``counts`` per turn if
    given), τ + white noise of ``torque_noise`` × each joint's rms; the PD ``gains`` (kp, kd),
    ``source`` and ``extra`` in its metadata."""
    qm = q + sigma_q * rng.standard_normal(q.shape) if sigma_q else q.copy()
    if counts:
        step = 2 * np.pi / counts
        qm = np.round(qm / step) * step
    rms = np.sqrt(np.mean(tau**2, axis=0))
    taum = tau + torque_noise * rms * rng.standard_normal(tau.shape)
    kp, kd = gains
    meta = {"kp": list(np.asarray(kp, float)), "kd": list(np.asarray(kd, float)), "source": source}
    meta.update(extra or {})
    units = {"q": "rad", "tau": "N·m", "r": "rad"}
    return physid.Recording.from_columns(t, {"q": qm, "tau": taum, "r": r}, units, meta)


def _simulate(kind, r, every, rng, *, friction, counts=None, sigma_q=SIGMA_Q, source=""):
    """Run a simulator on the reference r (on the DT_SIM grid), keep every ``every``-th step,
    add measurement noise. Returns the measured Recording, the noise-free τ and the noise-free
    Recording."""
    fv = VISCOUS if friction else np.zeros(6)
    fc = COULOMB if friction else np.zeros(6)
    if kind == "pinocchio":
        Q, _, T = simulate_pinocchio(pinocchio_arm(), r, DT_SIM, KP, KD, fv, fc, COULOMB_SMOOTHING)
    else:
        Q, _, T = simulate_mujoco(r, DT_SIM, KP, KD, ARMATURE, fv, fc)
    keep = slice(None, None, every)
    t = np.arange(r.shape[0])[keep] * DT_SIM
    rec = _record(t, Q[keep], T[keep], r[keep], rng, counts=counts, sigma_q=sigma_q, source=source)
    clean = _record(t, Q[keep], T[keep], r[keep], rng, sigma_q=0.0, torque_noise=0.0, source=source)
    return rec, T[keep], clean


def _grid(duration):
    return np.arange(int(round(duration / DT_SIM))) * DT_SIM


def case_a(quick=False) -> Case:
    """(a) pinocchio, Fourier reference, no friction."""
    dur, test_dur, period = (8.0, 6.0, 8.0) if quick else (16.0, 10.0, 8.0)
    rng = np.random.default_rng(11)
    t = _grid(dur)
    r = fourier_reference(t, Q0, rng, period=period)
    train, _, clean = _simulate("pinocchio", r, 2, rng, friction=False, source="pinocchio aba, RK4")
    th = _grid(test_dur)
    rh = fourier_reference(th, Q0, np.random.default_rng(12), period=period)
    test, tau_true, _ = _simulate(
        "pinocchio", rh, 2, rng, friction=False, source="pinocchio aba, RK4"
    )
    return Case(
        key="aq" if quick else "a",
        title=f"arm6 pinocchio PD Fourier 1 kHz, no friction ({dur:g} s / {test_dur:g} s)",
        urdf=ARM6_URDF,
        physid_model="arm6",
        train=train,
        test=test,
        test_tau_true=tau_true,
        train_clean=clean,
        truth=truth_of(pinocchio_arm(), ARMATURE, np.zeros(6), np.zeros(6)),
        bandwidth_hz=5 / period,
        armature=True,
    )


def case_b() -> Case:
    """(b) pinocchio, viscous + smoothed Coulomb friction, Fourier + point-to-point with rests."""
    rng = np.random.default_rng(21)

    def reference(seed, fourier_s, p2p_s, fourier_first):
        g = np.random.default_rng(seed)
        tf, tp = _grid(fourier_s), _grid(p2p_s)
        rf = fourier_reference(tf, Q0, g, period=8.0)
        rp = p2p_reference(tp, Q0, g)
        return np.vstack([rf, rp] if fourier_first else [rp, rf])

    r = reference(22, 8.0, 14.0, True)
    train, _, clean = _simulate("pinocchio", r, 2, rng, friction=True, source="pinocchio aba, RK4")
    rh = reference(23, 8.0, 8.0, False)
    test, tau_true, _ = _simulate(
        "pinocchio", rh, 2, rng, friction=True, source="pinocchio aba, RK4"
    )
    return Case(
        key="b",
        title="arm6 pinocchio, viscous+Coulomb (tanh), Fourier + point-to-point with rests",
        urdf=ARM6_URDF,
        physid_model="arm6",
        train=train,
        test=test,
        test_tau_true=tau_true,
        train_clean=clean,
        truth=truth_of(pinocchio_arm(), ARMATURE, VISCOUS, COULOMB),
        bandwidth_hz=2.0,  # the 1-2 s minimum-jerk moves, not the Fourier segment's 0.625 Hz
        armature=True,
        note=f"Coulomb smoothed: Fc·tanh(q̇/{COULOMB_SMOOTHING:g} rad/s)",
    )


def case_c() -> Case:
    """(c) MuJoCo: armature, damping, frictionloss (sticking), Fourier reference."""
    why = mujoco_available()
    title = "arm6 MuJoCo, armature+damping+frictionloss (sticks), Fourier"
    if why:
        return Case("c", title, ARM6_URDF, "arm6", skipped=why)
    mismatch = mujoco_matches_pinocchio()
    rng = np.random.default_rng(31)
    period = 10.0
    r = fourier_reference(_grid(20.0), Q0, np.random.default_rng(32), period=period, velocity=0.8)
    train, _, clean = _simulate("mujoco", r, 2, rng, friction=True, source="MuJoCo implicitfast")
    rh = fourier_reference(_grid(10.0), Q0, np.random.default_rng(33), period=period, velocity=0.8)
    test, tau_true, _ = _simulate("mujoco", rh, 2, rng, friction=True, source="MuJoCo implicitfast")
    return Case(
        key="c",
        title=title,
        urdf=ARM6_URDF,
        physid_model="arm6",
        train=train,
        test=test,
        test_tau_true=tau_true,
        train_clean=clean,
        truth=truth_of(pinocchio_arm(), ARMATURE, VISCOUS, COULOMB),
        bandwidth_hz=5 / period,
        armature=True,
        note=f"MuJoCo vs pinocchio inverse dynamics: max |Δτ| {mismatch:.1e} N·m",
        info={"mujoco_vs_pinocchio": mismatch},
    )


def case_d() -> Case:
    """(d) Slow sweep: 0.05 Hz fundamental, 250 Hz log, 2^16 counts/turn, friction."""
    rng = np.random.default_rng(41)
    period = 20.0
    kw = {"period": period, "velocity": 0.6, "acceleration": 1.0, "position": 1.0, "ramp": 2.0}
    r = fourier_reference(_grid(period), Q0, np.random.default_rng(42), **kw)
    train, _, clean = _simulate(
        "pinocchio",
        r,
        8,
        rng,
        friction=True,
        counts=2**16,
        sigma_q=0.0,
        source="pinocchio aba, RK4, 250 Hz, 2^16 counts/turn",
    )
    rh = fourier_reference(_grid(period), Q0, np.random.default_rng(43), **kw)
    test, tau_true, _ = _simulate(
        "pinocchio",
        rh,
        8,
        rng,
        friction=True,
        counts=2**16,
        sigma_q=0.0,
        source="pinocchio aba, RK4, 250 Hz, 2^16 counts/turn",
    )
    return Case(
        key="d",
        title="arm6 pinocchio slow sweep 0.05 Hz, 250 Hz, 2^16 counts/turn, friction",
        urdf=ARM6_URDF,
        physid_model="arm6",
        train=train,
        test=test,
        test_tau_true=tau_true,
        train_clean=clean,
        truth=truth_of(pinocchio_arm(), ARMATURE, VISCOUS, COULOMB),
        bandwidth_hz=5 / period,
        armature=True,
        note=f"encoder step {2 * np.pi / 2**16:.2e} rad",
    )


_SIDECARS = {}


def friction_sidecar(urdf: Path, joint_names) -> str:
    """A sidecar TOML (in a temporary folder) that adds viscous and Coulomb friction columns."""
    key = str(urdf)
    if key not in _SIDECARS:
        folder = Path(tempfile.mkdtemp(prefix="physid-zoo-"))
        lines = [f'name = "{urdf.stem}_friction"', f'extends = "{urdf.as_posix()}"', ""]
        for j in joint_names:
            lines += [f"[joints.{j}]", "viscous = 0.0", "coulomb = 0.0", ""]
        path = folder / f"{urdf.stem}_friction.toml"
        path.write_text("\n".join(lines), encoding="utf-8")
        _SIDECARS[key] = str(path)
    return _SIDECARS[key]


def _joint_names(urdf: Path):
    m = pin.buildModelFromUrdf(str(urdf))
    return list(m.names)[1:]


def case_panda() -> Case:
    folder = real_robots_dir() / "panda_gaz2019"
    title = "Franka Panda, real (Gaz 2019), 1st half -> 2nd half"
    urdf = folder / "panda_arm.urdf"
    csv = folder / "exciting_traj_1.csv"
    if not csv.exists():
        return Case("e1", title, urdf, "", skipped=f"real data not found at {folder}")
    rec = physid.load_recording(str(csv), channels={"t": "t_tick"}, resample=True)
    rec = _only_q_tau(rec)
    half = rec.t[0] + 0.5 * (rec.t[-1] - rec.t[0])
    return Case(
        key="e1",
        title=title,
        urdf=urdf,
        physid_model=friction_sidecar(urdf, _joint_names(urdf)),
        train=rec.slice_time(None, half),
        test=rec.slice_time(half, None),
        bandwidth_hz=1.0,
        note="t_tick, resampled; held-out half partly retraces the first",
    )


def _only_q_tau(rec):
    """Keep t, q1..qn, tau1..taun (drop the robot's own velocity estimate)."""
    names = [n for n in rec.names if n.startswith(("q", "tau")) and not n.startswith("qd")]
    return physid.Recording(
        rec.t, rec.select(names), names, [rec.unit(n) for n in names], dict(rec.metadata)
    )


def case_kuka() -> Case:
    folder = real_robots_dir() / "kuka_lwr4_flobaroid"
    title = "KUKA LWR4+, real (FloBaRoID), run 1 -> run 3"
    urdf = folder / "kuka_lwr4.urdf"
    files = [folder / f"measurements_{k}.csv" for k in (1, 3)]
    if not all(f.exists() for f in files):
        return Case("e2", title, urdf, "", skipped=f"real data not found at {folder}")
    train, test = (_only_q_tau(physid.load_recording(str(f), resample=True)) for f in files)
    return Case(
        key="e2",
        title=title,
        urdf=urdf,
        physid_model=friction_sidecar(urdf, _joint_names(urdf)),
        train=train,
        test=test,
        bandwidth_hz=0.8,
        note="logged already low-passed (q 3 Hz, τ 2 Hz); resampled to a uniform grid",
    )


# ----------------------------------------------------------------------------- drives
_FOLDER: list = []


def _scratch() -> Path:
    """One temporary folder per process for the URDFs and sidecars the new cases write."""
    if not _FOLDER:
        _FOLDER.append(Path(tempfile.mkdtemp(prefix="physid-zoo-")))
    return _FOLDER[0]


def _sidecar(urdf: Path, joints: dict, tail: str = "") -> str:
    """A sidecar TOML next to ``urdf`` that sets ``joints`` = {name: {key: value}}."""
    lines = [f'name = "{urdf.stem}_model"', f'extends = "{urdf.as_posix()}"', ""]
    for name, keys in joints.items():
        lines += [f"[joints.{name}]"] + [f"{k} = {v}" for k, v in keys.items()] + [""]
    path = urdf.with_name(f"{urdf.stem}_model.toml")
    path.write_text("\n".join(lines) + tail, encoding="utf-8")
    return str(path)


DRIVE = LinearDrive()
DRIVE_KP, DRIVE_KD = 9.0e4, 4.0e3  # N/m, N·s/m: ~5 Hz position bandwidth for 95 kg
DRIVE_GAIN = 35.15  # N/V
DRIVE_ENCODER = 1e-6  # m
DRIVE_SIGMA_U, DRIVE_ADC_U = 0.01, 20.0 / 2**16  # V


def _drive_record(seed, duration, rng):
    """(measured, noise-free) recordings of the linear drive on a point-to-point reference."""
    h = 1e-3
    t = np.arange(int(round(duration / h))) * h
    r = p2p_reference(
        t,
        np.array([0.1]),
        np.random.default_rng(seed),
        position=0.08,
        velocity=0.25,
        rest=(0.3, 1.2),
    )[:, 0]
    x, _, xq, u = DRIVE.simulate(r, h, DRIVE_KP, DRIVE_KD, DRIVE_ENCODER, DRIVE_GAIN)
    u_log = np.round((u + DRIVE_SIGMA_U * rng.standard_normal(u.shape)) / DRIVE_ADC_U)
    meta = {"kp": [DRIVE_KP], "kd": [DRIVE_KD], "source": "linear drive, exact stick-slip"}
    units = {"q": "m", "tau": "N", "r": "m"}

    def rec(q, force):
        cols = {"q": q[:, None], "tau": force[:, None], "r": r[:, None]}
        return physid.Recording.from_columns(t, cols, units, meta)

    return rec(xq, DRIVE_GAIN * DRIVE_ADC_U * u_log), rec(x, DRIVE_GAIN * u), DRIVE_GAIN * u


def case_linear_drive() -> Case:
    """(f) EMPS-like linear drive: prismatic, asymmetric Coulomb, sticking, force = gain × V."""
    rng = np.random.default_rng(61)
    urdf = DRIVE.urdf(_scratch() / "linear_drive.urdf")
    model = _sidecar(urdf, {"axis": {"viscous": 0.0, "coulomb": 0.0, "torque_offset": 0.0}})
    train, clean, _ = _drive_record(62, 25.0, rng)
    test, test_clean, force = _drive_record(63, 15.0, rng)
    x = np.asarray(test_clean.select(["q1"]))[:, 0]
    truth = Truth(
        np.array([pin.buildModelFromUrdf(str(urdf)).inertias[1].toDynamicParameters()]),
        np.zeros(1),
        np.array([DRIVE.viscous]),
        np.array([DRIVE.coulomb]),
        np.array([DRIVE.offset]),
    )
    return Case(
        key="f",
        title="linear drive (EMPS-like), prismatic, asymmetric Coulomb, sticks, 1 kHz, force = "
        "35.15 N/V × voltage",
        urdf=urdf,
        physid_model=model,
        train=train,
        test=test,
        test_tau_true=force[:, None],
        train_clean=clean,
        truth=truth,
        bandwidth_hz=2.0,  # the ≥ 1 s minimum-jerk moves, as in (b)
        offset=True,
        info={"test_moving": np.r_[False, np.diff(x) != 0]},  # the carriage truly moves
        note=f"encoder {DRIVE_ENCODER:g} m; Fc+ {DRIVE.coulomb_pos:g} N, Fc− "
        f"{DRIVE.coulomb_neg:g} N (Coulomb {DRIVE.coulomb:g} N, offset {DRIVE.offset:g} N)",
    )


ARM2 = TwoLink()
ARM2_KP, ARM2_KD = np.array([300.0, 100.0]), np.array([30.0, 8.0])
ARM2_COUNTS = 2**14  # per motor turn
ARM2_SIGMA_I, ARM2_ADC_I = 0.005, 10.0 / 2**12  # A
ARM2_Q0 = np.array([0.3, 0.6])


def _arm2_records(seed, duration, rng):
    """(motor-side log, joint-side log, noise-free joint-side record, τ) of the 2-link arm."""
    h = 2e-4
    t = np.arange(int(round(duration / h))) * h
    r = fourier_reference(t, ARM2_Q0, np.random.default_rng(seed), period=10.0)
    q, _, theta, cur = ARM2.simulate(r, h, ARM2_KP, ARM2_KD, ARM2_COUNTS)
    return _motor_logs(ARM2, t, r, q, theta, cur, rng, "2-link arm, RK4")


def _motor_logs(arm, t, r, q, theta, cur, rng, source):
    """The logs of a geared 2-link arm ``arm`` (`drives.TwoLink`) from its simulated link angles
    ``q``, motor angles ``theta`` and currents ``cur``: (motor-side log ``qm``, ``im`` with the
    current through a 12-bit ADC and σ 5 mA, joint-side log q = θ/N, τ = N kt i, noise-free
    joint-side record, noise-free τ)."""
    i_log = np.round((cur + ARM2_SIGMA_I * rng.standard_normal(cur.shape)) / ARM2_ADC_I)
    i_log = i_log * ARM2_ADC_I
    kn = arm.ratio * arm.kt
    meta = {"kp": ARM2_KP.tolist(), "kd": ARM2_KD.tolist(), "source": source}
    motor = physid.Recording.from_columns(
        t, {"qm": theta, "im": i_log, "r": r}, {"qm": "rad", "im": "A", "r": "rad"}, meta
    )
    units = {"q": "rad", "tau": "N·m", "r": "rad"}
    joint = physid.Recording.from_columns(
        t, {"q": theta / arm.ratio, "tau": kn * i_log, "r": r}, units, meta
    )
    clean = physid.Recording.from_columns(t, {"q": q, "tau": kn * cur, "r": r}, units, meta)
    return motor, joint, clean, kn * cur


def _motor_side_model(arm, urdf) -> str:
    """A sidecar of ``urdf`` for a geared 2-link arm ``arm``: armature, viscous and Coulomb
    columns per joint and a ``[transmission]`` (gear ratios, torque constants), through which
    physid reads the motor-side log."""
    n, kt = arm.ratio, arm.kt
    tail = f"\n[transmission]\ngear_ratios = [{n}, {n}]\ntorque_constants = [{kt}, {kt}]\n"
    drive = {"armature": 0.0, "viscous": 0.0, "coulomb": 0.0}
    return _sidecar(urdf, {"shoulder": drive, "elbow": drive}, tail)


def case_two_link_motor(train_s=20.0, test_s=10.0) -> Case:
    """(g) 2-link arm logged as motor angles and currents through gears, Stribeck friction
    (``train_s``, ``test_s``: the records' durations [s]; shorter ones for tests)."""
    rng = np.random.default_rng(71)
    urdf = ARM2.urdf(_scratch() / "two_link.urdf")
    model = _motor_side_model(ARM2, urdf)
    ptrain, train, clean, _ = _arm2_records(72, train_s, rng)
    ptest, test, _, tau = _arm2_records(73, test_s, rng)
    note = (
        "Stribeck friction (static "
        + "/".join(f"{x:g}" for x in ARM2.fs)
        + " N·m, Coulomb "
        + "/".join(f"{x:g}" for x in ARM2.fc)
        + " N·m) modelled by every estimator as Coulomb + viscous; physid reads qm, im"
    )
    title = "2-link arm, motor currents through gears (100:1), Stribeck, 5 kHz"
    return _motor_side_case(
        "g", title, ARM2, urdf, model, (ptrain, train, clean), (ptest, test, tau), note
    )


def _motor_side_case(key, title, arm, urdf, model, train, test, note) -> Case:
    """A 2-link arm's case logged on the motor side: ``train`` = (motor log, joint-side record,
    noise-free joint-side record), ``test`` = (motor log, joint-side record, τ without noise);
    the truth is the rigid arm's (armature N²Jm, Fv, Fc)."""
    pm = pin.buildModelFromUrdf(str(urdf))
    return Case(
        key=key,
        title=title,
        urdf=urdf,
        physid_model=model,
        train=train[1],
        test=test[1],
        test_tau_true=test[2],
        train_clean=train[2],
        truth=truth_of(pm, arm.armature, np.asarray(arm.fv), np.asarray(arm.fc)),
        bandwidth_hz=0.5,  # 5 harmonics of a 10 s period
        armature=True,
        physid_train=train[0],
        physid_test=test[0],
        note=note,
    )


FLEX_COUNTS = 2**20  # per motor turn


def _flex_records(arm, seed, duration, rng, ripple=0.0):
    """(motor-side log, joint-side log, noise-free joint-side record, τ = N kt i) of the
    elastic arm; the joint side is the motor's (q = θ/N), as an encoder on the motor reads it."""
    h = 2e-4
    t = np.arange(int(round(duration / h))) * h
    r = fourier_reference(t, ARM2_Q0, np.random.default_rng(seed), period=10.0)
    w = 2 * np.pi * arm.modes(ARM2_Q0)["free"][-1]  # rad/s, the fastest mode
    substeps = max(2, int(np.ceil(h * w / 0.4)))  # RK4 at ω dt < 0.4 (stiffer variants)
    dist = ripple * np.random.default_rng(seed + 1000).standard_normal(r.shape) if ripple else None
    sim = arm.simulate(r, h, ARM2_KP, ARM2_KD, FLEX_COUNTS, substeps, disturbance=dist)
    _, phi, _, _, theta, cur = sim
    return _motor_logs(arm.arm, t, r, phi, theta, cur, rng, "elastic 2-link arm, RK4")


def case_flexible_arm(train_s=20.0, test_s=10.0, stiffness_scale=1.0, ripple=0.0) -> Case:
    """(h) the arm of (g) with elastic joints (`flexible.FlexibleTwoLink`), logged on the motor
    side; ``stiffness_scale`` multiplies K (and D by its square root: the same damping ratio);
    ``ripple`` [A]: σ of a white current the drives add to the command (0: none)."""
    base = FlexibleTwoLink()
    s = float(stiffness_scale)
    arm = FlexibleTwoLink(
        stiffness=tuple(s * k for k in base.stiffness),
        damping=tuple(np.sqrt(s) * d for d in base.damping),
    )
    rng = np.random.default_rng(81)
    urdf = arm.arm.urdf(_scratch() / "two_link_elastic.urdf")
    model = _motor_side_model(arm.arm, urdf)
    ptrain, train, clean, _ = _flex_records(arm, 82, train_s, rng, ripple)
    ptest, test, _, tau = _flex_records(arm, 83, test_s, rng, ripple)
    modes = arm.modes(ARM2_Q0)
    note = (
        "joint modes "
        + "/".join(f"{x:.3g}" for x in modes["free"])
        + " Hz (motors locked "
        + "/".join(f"{x:.3g}" for x in modes["locked"])
        + " Hz); rigid truth: armature N²Jm, Fv, Fc on the motor; physid reads qm, im"
    )
    title = "2-link arm with elastic joints, motor side (100:1), 5 kHz"
    return _motor_side_case(
        "h", title, arm.arm, urdf, model, (ptrain, train, clean), (ptest, test, tau), note
    )


def _collection(name):
    """A case of ``collection.py`` (example-robot-data arms), imported when built."""
    return lambda: getattr(importlib.import_module(f"{__package__}.collection"), name)()


BUILDERS = {
    "a": case_a,
    "b": case_b,
    "c": case_c,
    "d": case_d,
    "e1": case_panda,
    "e2": case_kuka,
    "f": case_linear_drive,
    "g": case_two_link_motor,
    "h": case_flexible_arm,
    "i": _collection("case_ur5"),
    "j": _collection("case_panda_sim"),
    "k": _collection("case_xarm7"),
}


def build(keys=None, quick=False):
    """The cases (quick: case (a) shortened only)."""
    if quick:
        return [case_a(quick=True)]
    return [BUILDERS[k]() for k in (keys or BUILDERS)]
