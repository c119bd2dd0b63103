"""Rigid-body chains and trees: vectorised recursive Newton–Euler, its regressor and M(q).

A chain of n joints (revolute or prismatic), each joint frame placed at a constant transform
``X_i = (R_i, p_i)`` in its parent link's frame (the parent is the previous joint, or the base;
in a kinematic tree, ``parent[i]`` names it, parents before children),
moving about/along a unit ``axis_i`` in that frame. Link i is rigidly attached to joint frame i;
its 10 standard inertial parameters (`physid.models.inertial`) are given in a *link frame* that
may differ from the joint frame by a constant transform (a DH frame sits at the end of the link;
a URDF link frame is the joint frame) — the map between the two is linear (``A_i``, 10 × 10).

Drive terms per joint: armature ``Ia`` q̈, viscous ``Fv`` q̇, Coulomb ``Fc`` sign(q̇), asymmetric
``Fvp`` q̇·[q̇>0], ``Fvn`` q̇·[q̇<0], ``Fcp``·[q̇>0], ``−Fcn``·[q̇<0], and a constant ``OF``; a
`physid.models.transmission.Transmission` adds motor-side terms through its coupling matrix
(their parameters follow all the joints' ones).

The dynamics are linear in these parameters (τ = Y(q, q̇, q̈) β), so nothing is derived
symbolically: inverse dynamics is Newton–Euler over arrays of samples (numpy, or the generic C
kernel of `physid.models.codegen` when a compiler works), the regressor is Newton–Euler applied
to the wrench of each parameter, and M(q) is Newton–Euler at unit accelerations. Cold load of a
7-DOF arm is a few milliseconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import inertial

__all__ = ["RigidChain", "DRIVE_TERMS", "rnea", "regressor", "mass_matrix"]

#: Drive/friction terms: (name prefix, description, unit).
DRIVE_TERMS = (
    ("Ia", "armature (reflected rotor inertia)", "kg*m^2"),
    ("Fv", "viscous friction", "N*m*s/rad"),
    ("Fc", "Coulomb friction", "N*m"),
    ("Fvp", "viscous friction for positive velocity", "N*m*s/rad"),
    ("Fvn", "viscous friction for negative velocity", "N*m*s/rad"),
    ("Fcp", "Coulomb friction for positive velocity", "N*m"),
    ("Fcn", "Coulomb friction for negative velocity", "N*m"),
    ("OF", "torque offset", "N*m"),
)
DRIVE_NAMES = tuple(t[0] for t in DRIVE_TERMS)
STANDARD_UNITS = ("kg", "kg*m", "kg*m", "kg*m") + ("kg*m^2",) * 6

#: Samples per block in the vectorised kernels (bounds scratch memory: ~1 kB per sample).
BLOCK = 4096


@dataclass(frozen=True, eq=False)
class RigidChain:
    """Numeric description of a serial rigid-body chain (immutable; arrays read-only).

    Attributes
    ----------
    name : str
    joint_names : tuple of str
    joint_types : tuple of str
        ``"revolute"`` or ``"prismatic"`` per joint.
    rotation : ndarray (n, 3, 3)
        Rotation of joint frame i (at q_i = 0) in its parent link frame.
    translation : ndarray (n, 3) [m]
        Origin of joint frame i in its parent link frame.
    axis : ndarray (n, 3)
        Unit joint axis in joint frame i.
    standard : ndarray (n, 10)
        Nominal standard parameters of each link, in its link frame.
    link_to_joint : ndarray (n, 10, 10)
        Linear map from link-frame to joint-frame standard parameters (identity for URDF).
    drive : dict name -> ndarray (n,)
        Nominal drive terms present in the model (keys from `DRIVE_NAMES`, in that order).
    gravity : ndarray (3,) [m/s²]
        Gravity in the base frame.
    limits : dict
        ``position`` (n, 2), ``velocity`` (n,), ``effort`` (n,), ``acceleration`` (n,); NaN
        where unknown.
    source : str
        Where the description came from (file name), for messages.
    parent : tuple of int
        Parent joint of each joint (-1: the base), parents first; ``()``: a serial chain.
    transmission : Transmission or None
        Motors and their coupling (`physid.models.transmission`).
    notes : tuple of str
        What the reader changed or ignored (shown when the model is loaded).
    mimic : tuple of (int, int, float, float)
        Mimic joints ``(follower, leader, multiplier, offset)``: q_follower = multiplier ·
        q_leader + offset. The model's coordinates are the other joints' (`independent`); the
        dynamics functions take and return those (τ = Gᵀ τ_all, M = Gᵀ M_all G).
    """

    name: str
    joint_names: tuple
    joint_types: tuple
    rotation: np.ndarray
    translation: np.ndarray
    axis: np.ndarray
    standard: np.ndarray
    link_to_joint: np.ndarray
    drive: dict
    gravity: np.ndarray
    limits: dict = field(default_factory=dict)
    source: str = "<built-in>"
    description: str = ""
    identify: tuple = ()
    parent: tuple = ()
    transmission: object = None
    notes: tuple = ()
    mimic: tuple = ()

    def __post_init__(self):
        for name in ("rotation", "translation", "axis", "standard", "link_to_joint", "gravity"):
            arr = np.array(getattr(self, name), dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        parent = tuple(int(p) for p in self.parent)
        if parent == tuple(range(-1, len(self.joint_types) - 1)):
            parent = ()  # a serial chain, however it was written
        if parent and (
            len(parent) != len(self.joint_types)
            or any(not (-1 <= p < i) for i, p in enumerate(parent))
        ):
            raise ValueError(f"parent must list each joint's parent before it; got {parent}")
        object.__setattr__(self, "parent", parent)

    @property
    def parents(self) -> tuple:
        """Parent joint of each joint (-1: the base)."""
        return self.parent or tuple(range(-1, self.n_joints - 1))

    @property
    def is_serial(self) -> bool:
        """Whether each joint's parent is the previous one."""
        return not self.parent

    @property
    def independent(self) -> tuple:
        """Indices of the joints that are coordinates (all but the mimic followers)."""
        followers = {m[0] for m in self.mimic}
        return tuple(i for i in range(self.n_joints) if i not in followers)

    def mimic_map(self):
        """``(G, o)``: q_all = G q + o, G (n_all, n_independent), o (n_all,)."""
        ind = self.independent
        G = np.zeros((self.n_joints, len(ind)))
        G[ind, np.arange(len(ind))] = 1.0
        o = np.zeros(self.n_joints)
        for f, leader, mult, off in self.mimic:
            G[f, ind.index(leader)] = mult
            o[f] = off
        return G, o

    @property
    def motor_names(self) -> tuple:
        """Names of the motor-side parameters (empty without a transmission)."""
        return self.transmission.names() if self.transmission is not None else ()

    @property
    def n_joints(self) -> int:
        """Number of joints."""
        return len(self.joint_types)

    @property
    def drive_names(self) -> tuple:
        """Drive terms present (prefixes, in `DRIVE_NAMES` order)."""
        return tuple(k for k in DRIVE_NAMES if k in self.drive)

    @property
    def per_joint(self) -> int:
        """Columns per joint: 10 standard + the drive terms present."""
        return 10 + len(self.drive_names)

    def parameter_names(self) -> tuple:
        """``m1 mcx1 … ZZ1 Ia1 Fv1 … m2 …``: per joint, standard then drive terms."""
        out = []
        for j in range(self.n_joints):
            out += [f"{s}{j + 1}" for s in inertial.STANDARD_NAMES]
            out += [f"{d}{j + 1}" for d in self.drive_names]
        return tuple(out) + self.motor_names

    def parameter_units(self) -> tuple:
        """SI unit of each parameter (prismatic joints: N, N·s/m, kg)."""
        out = []
        units = {t[0]: t[2] for t in DRIVE_TERMS}
        for kind in self.joint_types:
            out += list(STANDARD_UNITS)
            for d in self.drive_names:
                u = units[d]
                if kind == "prismatic":
                    u = {"kg*m^2": "kg", "N*m*s/rad": "N*s/m", "N*m": "N"}[u]
                out.append(u)
        if self.transmission is not None:
            out += list(self.transmission.units())
        return tuple(out)

    def nominal_vector(self) -> np.ndarray:
        """Nominal parameter vector ordered like `parameter_names`."""
        out = []
        for j in range(self.n_joints):
            out += list(self.standard[j])
            out += [float(self.drive[d][j]) for d in self.drive_names]
        if self.transmission is not None:
            out += list(self.transmission.nominal())
        return np.array(out, dtype=float)

    def split(self, beta):
        """(n, 10) joint-frame inertial parameters and (n, n_drive) drive terms of a vector."""
        b = np.asarray(beta, dtype=float)[: self.n_joints * self.per_joint]
        b = b.reshape(self.n_joints, self.per_joint)
        link = b[:, :10]
        joint_frame = np.einsum("nij,nj->ni", self.link_to_joint, link)
        return joint_frame, b[:, 10:]

    def motor_values(self, beta) -> np.ndarray:
        """The motor-side parameters of a vector (after the joints' ones)."""
        return np.asarray(beta, dtype=float)[self.n_joints * self.per_joint :]

    def content(self) -> dict:
        """JSON-ready description (keys a cache of compiled code)."""
        return {
            "types": list(self.joint_types),
            "rotation": self.rotation.round(15).tolist(),
            "translation": self.translation.round(15).tolist(),
            "axis": self.axis.round(15).tolist(),
            "drive": list(self.drive_names),
            "gravity": self.gravity.tolist(),
            **({"parent": list(self.parent)} if self.parent else {}),
            **({"mimic": [list(m) for m in self.mimic]} if self.mimic else {}),
            **(
                {"transmission": self.transmission.content()}
                if self.transmission is not None
                else {}
            ),
        }


# ---------------------------------------------------------------------------------------------
# small batched linear algebra
# ---------------------------------------------------------------------------------------------


def _cross(a, b):
    """Row-wise cross product of (..., 3) arrays (faster than np.cross for small last axes)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], -1)


def _cross_cols(a, B):
    """a × each column of B: a (N, 3), B (N, 3, C) → (N, 3, C)."""
    a0, a1, a2 = a[:, 0, None], a[:, 1, None], a[:, 2, None]
    b0, b1, b2 = B[:, 0], B[:, 1], B[:, 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], 1)


def _joint_transforms(chain: RigidChain, q):
    """Rotation (N, 3, 3) and translation (N, 3) of each joint frame in its parent, at q (N, n)."""
    out = []
    N = q.shape[0]
    for i, kind in enumerate(chain.joint_types):
        R0, p0, a = chain.rotation[i], chain.translation[i], chain.axis[i]
        qi = q[:, i]
        if kind == "revolute":
            K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
            K2 = K @ K
            Rm = np.eye(3) + np.sin(qi)[:, None, None] * K + (1 - np.cos(qi))[:, None, None] * K2
            R = R0 @ Rm
            p = np.broadcast_to(p0, (N, 3))
        else:
            R = np.broadcast_to(R0, (N, 3, 3))
            p = p0 + qi[:, None] * (R0 @ a)
        out.append((R, p))
    return out


def _tr_mv(R, v):
    """Rᵀ v for R (N, 3, 3), v (N, 3)."""
    return np.einsum("nji,nj->ni", R, v)


def _mv(R, v):
    return np.einsum("nij,nj->ni", R, v)


def _kinematics(chain, q, qd, qdd, gravity: bool = True):
    """Angular velocity, angular acceleration and origin acceleration of each joint frame."""
    N = q.shape[0]
    X = _joint_transforms(chain, q)
    base = (
        np.zeros((N, 3)),
        np.zeros((N, 3)),
        np.broadcast_to(-chain.gravity if gravity else np.zeros(3), (N, 3)),
    )
    out = []
    for i, kind in enumerate(chain.joint_types):
        pi = chain.parents[i]
        w, dw, acc = base if pi < 0 else out[pi]
        R, p = X[i]
        a = chain.axis[i]
        acc_p = acc + _cross(dw, p) + _cross(w, _cross(w, p))
        w_in = _tr_mv(R, w)
        dw_in = _tr_mv(R, dw)
        acc = _tr_mv(R, acc_p)
        qdi = qd[:, i, None]
        qddi = qdd[:, i, None]
        if kind == "revolute":
            w = w_in + qdi * a
            dw = dw_in + qddi * a + _cross(w_in, qdi * a)
        else:
            w, dw = w_in, dw_in
            acc = acc + qddi * a + 2.0 * _cross(w_in, qdi * a)
        out.append((w, dw, acc))
    return X, out


def _drive_torque(chain, drive, qd, qdd, smoothing=0.0):
    """Drive terms' torque (N, n) for drive values (n, n_drive)."""
    tau = np.zeros_like(qd)
    for c, name in enumerate(chain.drive_names):
        tau += drive[:, c] * _drive_column(name, qd, qdd, smoothing)
    return tau


def _drive_column(name, qd, qdd, smoothing=0.0):
    """Regressor column of one drive term; ``smoothing`` > 0 [rad/s] replaces sign(q̇) by
    tanh(q̇ / smoothing) (simulation only)."""
    if name == "Ia":
        return qdd
    if name == "Fv":
        return qd
    if smoothing > 0 and name in ("Fc", "Fcp", "Fcn"):
        th = np.tanh(qd / smoothing)
        return {"Fc": th, "Fcp": 0.5 * (1 + th), "Fcn": -0.5 * (1 - th)}[name]
    if name == "Fc":
        return np.sign(qd)
    if name == "Fvp":
        return np.where(qd > 0, qd, 0.0)
    if name == "Fvn":
        return np.where(qd < 0, qd, 0.0)
    if name == "Fcp":
        return (qd > 0).astype(float)
    if name == "Fcn":
        return -(qd < 0).astype(float)
    return np.ones_like(qd)  # OF


def _rnea_block(chain, inertia, drive, q, qd, qdd, gravity=True, with_drive=True, smoothing=0.0):
    """Newton–Euler torques (N, n) for joint-frame inertial parameters (n, 10)."""
    N, n = q.shape
    X, kin = _kinematics(chain, q, qd, qdd, gravity)
    f_child = np.zeros((n, N, 3))  # wrenches of each joint's children, in its frame
    n_child = np.zeros((n, N, 3))
    tau = np.empty((N, n))
    for i in range(n - 1, -1, -1):
        w, dw, acc = kin[i]
        m, h = inertial_split(inertia[i])
        Io = inertial.inertia_matrix(inertia[i, 4:])
        f = m * acc + _cross(dw, h) + _cross(w, _cross(w, h)) + f_child[i]
        Iw = w @ Io  # symmetric
        nn = dw @ Io + _cross(w, Iw) + _cross(h, acc) + n_child[i]
        a = chain.axis[i]
        tau[:, i] = (nn if chain.joint_types[i] == "revolute" else f) @ a
        pi = chain.parents[i]
        if pi >= 0:  # the wrench this link takes from its parent, in the parent's frame
            R, p = X[i]
            fp = _mv(R, f)
            f_child[pi] += fp
            n_child[pi] += _mv(R, nn) + _cross(p, fp)
    if with_drive and drive.shape[1]:
        tau += _drive_torque(chain, drive, qd, qdd, smoothing)
    return tau


def inertial_split(p10):
    """(m, m·c) of a standard parameter vector."""
    return float(p10[0]), np.asarray(p10[1:4])


def rnea(
    chain: RigidChain,
    beta,
    q,
    qd,
    qdd,
    *,
    gravity: bool = True,
    drive: bool = True,
    smoothing: float = 0.0,
    motor_smoothing: float | None = None,
):
    """Inverse dynamics τ (N, n) [N·m or N] by Newton–Euler over all samples, in blocks.

    Parameters
    ----------
    chain : RigidChain
    beta : array_like (n_parameters,)
        Parameters ordered like ``chain.parameter_names()``.
    q, qd, qdd : ndarray (N, n)
        Joint positions [rad|m], velocities and accelerations.
    gravity, drive : bool
        Include gravity / the drive and friction terms.
    smoothing : float [rad/s]
        0: exact sign(q̇) in the Coulomb terms; > 0: tanh(q̇ / smoothing) (simulation).
    motor_smoothing : float [rad/s], optional
        The same for the motor-side Coulomb terms, on θ̇m (default ``smoothing``).

    Returns
    -------
    ndarray (N, n)
    """
    inertia, drv = chain.split(beta)
    motor = chain.motor_values(beta)
    qa, qda, qdda = _expand(chain, q, qd, qdd)
    N = q.shape[0]
    out = np.empty((N, chain.n_joints))
    for s in range(0, N, BLOCK):
        sl = slice(s, s + BLOCK)
        out[sl] = _rnea_block(
            chain,
            inertia,
            drv,
            qa[sl],
            qda[sl],
            qdda[sl],
            gravity=gravity,
            with_drive=drive,
            smoothing=smoothing,
        )
    if chain.mimic:  # virtual work: τ = Gᵀ τ_all
        out = out @ chain.mimic_map()[0]
    if drive and motor.size:  # motor-side terms through the coupling (rigid.transmission)
        eps = smoothing if motor_smoothing is None else motor_smoothing
        out += chain.transmission.torque(motor, qd, qdd, eps)
    return out


def _expand(chain, q, qd=None, qdd=None):
    """All joints' q, q̇, q̈ from the coordinates (mimic joints follow their leaders)."""
    if not chain.mimic:
        return q, qd, qdd
    G, o = chain.mimic_map()
    return (
        q @ G.T + o,
        None if qd is None else qd @ G.T,
        None if qdd is None else qdd @ G.T,
    )


def mass_matrix(chain: RigidChain, beta, q):
    """M(q) (N, n, n): Newton–Euler at q̇ = 0, unit accelerations, no gravity, + armature.

    Parameters
    ----------
    chain : RigidChain
    beta : array_like (n_parameters,)
    q : ndarray (N, n)

    Returns
    -------
    ndarray (N, n, n) [kg·m² | kg]
    """
    inertia, drv = chain.split(beta)
    q = _expand(chain, q)[0]
    N, n = q.shape
    M = np.empty((N, n, n))
    zeros = np.zeros((0, 0))
    step = max(1, BLOCK // n)
    eye = np.eye(n)
    for s in range(0, N, step):
        qb = q[s : s + step]
        nb = qb.shape[0]
        qr = np.repeat(qb, n, axis=0)
        acc = np.tile(eye, (nb, 1))
        cols = _rnea_block(
            chain,
            inertia,
            zeros.reshape(n, 0),
            qr,
            np.zeros_like(qr),
            acc,
            gravity=False,
            with_drive=False,
        )
        M[s : s + nb] = cols.reshape(nb, n, n).transpose(0, 2, 1)
    if "Ia" in chain.drive:
        c = chain.drive_names.index("Ia")
        M[:, np.arange(n), np.arange(n)] += drv[:, c]
    if chain.mimic:
        G = chain.mimic_map()[0]
        M = np.einsum("fi,nfg,gj->nij", G, M, G)  # Gᵀ M G
    if chain.motor_names:  # rotors: Kᵀ diag(Im) K
        M += chain.transmission.mass(chain.motor_values(beta))
    return 0.5 * (M + M.transpose(0, 2, 1))


def _wrench_columns(w, dw, acc):
    """Wrench (f, n) of a link per unit standard parameter: (N, 6, 10) in its joint frame."""
    N = w.shape[0]
    W = np.zeros((N, 6, 10))
    W[:, 0:3, 0] = acc
    # f = dw × h + w × (w × h) = ([dw]× + [w]×²) h
    for c in range(3):
        e = np.zeros(3)
        e[c] = 1.0
        W[:, 0:3, 1 + c] = _cross(dw, np.broadcast_to(e, (N, 3))) + _cross(
            w, _cross(w, np.broadcast_to(e, (N, 3)))
        )
        # n gets h × acc = −acc × h
        W[:, 3:6, 1 + c] = -_cross(acc, np.broadcast_to(e, (N, 3)))

    # n = I dw + w × (I w), I v = L(v) [XX XY XZ YY YZ ZZ]
    def L(v):
        Z = np.zeros((N, 3, 6))
        vx, vy, vz = v[:, 0], v[:, 1], v[:, 2]
        Z[:, 0, 0], Z[:, 0, 1], Z[:, 0, 2] = vx, vy, vz
        Z[:, 1, 1], Z[:, 1, 3], Z[:, 1, 4] = vx, vy, vz
        Z[:, 2, 2], Z[:, 2, 4], Z[:, 2, 5] = vx, vy, vz
        return Z

    W[:, 3:6, 4:10] = L(dw) + _cross_cols(w, L(w))
    return W


def regressor(chain: RigidChain, q, qd, qdd, out=None):
    """Y(q, q̇, q̈) (N, n, n_parameters) with τ = Y β, in blocks of samples.

    Each link's wrench per unit parameter is carried down the chain by Newton–Euler's backward
    pass and projected on each joint axis; link-frame parameters via ``link_to_joint``.

    Parameters
    ----------
    chain : RigidChain
    q, qd, qdd : ndarray (N, n)
    out : ndarray (N, n, n_parameters), optional
        Written in place (the only full-size allocation).

    Returns
    -------
    ndarray (N, n, n_parameters)
    """
    N, m = q.shape
    n = chain.n_joints
    P = chain.per_joint
    n_motor = len(chain.motor_names)
    if out is None:
        out = np.empty((N, m, n * P + n_motor))
    block = _regressor_block if chain.is_serial else _regressor_block_tree
    qa, qda, qdda = _expand(chain, q, qd, qdd)
    G = chain.mimic_map()[0] if chain.mimic else None
    for s in range(0, N, BLOCK):
        sl = slice(s, s + BLOCK)
        if G is None:
            block(chain, qa[sl], qda[sl], qdda[sl], out[sl, :, : n * P])
        else:  # Y = Gᵀ Y_all
            full = block(chain, qa[sl], qda[sl], qdda[sl], np.empty((qa[sl].shape[0], n, n * P)))
            out[sl, :, : n * P] = np.einsum("fi,nfp->nip", G, full)
        if n_motor:
            out[sl, :, n * P :] = chain.transmission.columns(qd[sl], qdd[sl])
    return out


def _regressor_block(chain, q, qd, qdd, out):
    N, n = q.shape
    P = chain.per_joint
    X, kin = _kinematics(chain, q, qd, qdd, True)
    out[...] = 0.0
    U = None  # wrenches (N, 6, 10 (n - i)) of links i..n-1 in frame i
    for i in range(n - 1, -1, -1):
        w, dw, acc = kin[i]
        W = _wrench_columns(w, dw, acc)
        U = W if U is None else np.concatenate([W, U], axis=2)
        a = chain.axis[i]
        rows = U[:, 3:6] if chain.joint_types[i] == "revolute" else U[:, 0:3]
        proj = np.einsum("nrc,r->nc", rows, a)  # (N, 10 (n - i))
        for k in range(i, n):
            out[:, i, k * P : k * P + 10] = proj[:, (k - i) * 10 : (k - i + 1) * 10]
        if i > 0:
            R, p = X[i]
            f = np.matmul(R, U[:, 0:3])
            nn = np.matmul(R, U[:, 3:6]) + _cross_cols(p, f)
            U = np.concatenate([f, nn], axis=1)
    _finish_regressor(chain, qd, qdd, out)
    return out


def _regressor_block_tree(chain, q, qd, qdd, out):
    """`_regressor_block` of a tree: each link's wrench columns carried up to the base."""
    N, n = q.shape
    P = chain.per_joint
    X, kin = _kinematics(chain, q, qd, qdd, True)
    out[...] = 0.0
    for k in range(n):
        U = _wrench_columns(*kin[k])  # (N, 6, 10) in frame k
        i = k
        while i >= 0:
            rows = U[:, 3:6] if chain.joint_types[i] == "revolute" else U[:, 0:3]
            out[:, i, k * P : k * P + 10] = np.einsum("nrc,r->nc", rows, chain.axis[i])
            if chain.parents[i] >= 0:
                R, p = X[i]
                f = np.matmul(R, U[:, 0:3])
                U = np.concatenate([f, np.matmul(R, U[:, 3:6]) + _cross_cols(p, f)], axis=1)
            i = chain.parents[i]
    _finish_regressor(chain, qd, qdd, out)
    return out


def _finish_regressor(chain, qd, qdd, out):
    """Link-frame parameters (Y_link = Y_joint A) and the drive columns, in place."""
    n = chain.n_joints
    P = chain.per_joint
    for k in range(n):
        A = chain.link_to_joint[k]
        if not np.array_equal(A, np.eye(10)):
            blk = out[:, :, k * P : k * P + 10]
            out[:, :, k * P : k * P + 10] = blk @ A
    for c, name in enumerate(chain.drive_names):
        col = _drive_column(name, qd, qdd)
        for j in range(n):
            out[:, j, j * P + 10 + c] = col[:, j]
    return out


def link_to_joint_map(R, p) -> np.ndarray:
    """10 × 10 matrix mapping standard parameters in a link frame to the joint frame, where the
    link frame sits at (R, p) in the joint frame (linear: pseudo-inertias transform as T J Tᵀ)."""
    A = np.empty((10, 10))
    for c in range(10):
        e = np.zeros(10)
        e[c] = 1.0
        A[:, c] = inertial.transform_standard(e, R, p)
    A[np.abs(A) < 1e-15] = 0.0
    return A
