"""A connected sub-tree of a rigid-body model, the other joints held still (``--joints``).

Identifying one arm of a robot that branches (a torso and two arms, a mobile manipulator) while
the rest of the robot holds still: the joints not chosen are frozen at the positions the log
gives them, which makes them fixed joints. The ancestors of the sub-tree's root then only place
it (their transforms at the held positions are folded into its placement, so gravity acts in the
right direction); the descendants that are not chosen ride on their chosen parent (their link
inertias are moved into its frame and added, as a URDF's fixed joints are); the other branches
do not act on the chosen joints at all and are dropped.

The sub-model's joints are numbered 1..m in the full model's order (parameters ``m1`` … of the
first chosen joint, and so on); its joint names are the full model's.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import InputError, arg
from . import inertial

__all__ = ["subtree_model", "subtree_recording", "HOLD_TOLERANCE"]

#: How far [rad | m] a held joint may move in a log (peak to peak) and still count as held.
HOLD_TOLERANCE = 1e-3


def _joint_transform(chain, i: int, qi: float) -> np.ndarray:
    """4 × 4 placement of joint frame i in its parent's frame at position ``qi``."""
    from .rigid import _joint_transforms

    R, p = _joint_transforms(chain, np.full((1, chain.n_joints), qi))[i]
    T = np.eye(4)
    T[:3, :3] = R[0]
    T[:3, 3] = p[0]
    return T


def _chosen(chain, joints) -> list:
    """Indices of the chosen joint names, checked to exist and to form a connected sub-tree."""
    names = list(chain.joint_names)
    unknown = [j for j in joints if j not in names]
    if unknown:
        raise InputError(
            f"{arg('joints')} names {unknown}, which model {chain.name!r} does not have; its joints: "
            f"{names}."
        )
    if len(set(joints)) != len(joints):
        raise InputError(f"{arg('joints')} names a joint twice: {list(joints)}.")
    idx = sorted(names.index(j) for j in joints)
    parents = chain.parents
    roots = [i for i in idx if parents[i] not in idx]
    if len(roots) > 1:
        raise InputError(
            f"{arg('joints')} {','.join(joints)} is not a connected sub-tree of {chain.source}: "
            f"{[names[r] for r in roots]} each start a separate piece (their parents "
            f"{[names[parents[r]] if parents[r] >= 0 else 'the base' for r in roots]} are not "
            "chosen). Add the joints that connect them, or identify each piece on its own."
        )
    return idx


def subtree_model(model, joints, held: dict):
    """The rigid-body model of the chosen joints with every other joint held still.

    Parameters
    ----------
    model : RigidBodyModel
        The full model (a chain or a tree).
    joints : sequence of str
        The chosen joints' names: a connected sub-tree.
    held : dict str -> float [rad | m]
        Positions of the joints not chosen (those missing are held at 0).

    Returns
    -------
    RigidBodyModel

    Raises
    ------
    InputError
        An unknown joint, a sub-tree that is not connected, or a transmission coupling a chosen
        joint to one held still.
    """
    from .rigid_model import RigidBodyModel

    chain = model.chain
    if chain.mimic:
        raise InputError(
            f"{arg('joints')}: model {chain.name!r} has mimic joints; choosing a sub-tree of it is not "
            "supported. Identify the whole robot."
        )
    idx = _chosen(chain, list(joints))
    n = chain.n_joints
    q = np.array([float(held.get(name, 0.0)) for name in chain.joint_names])
    parents = chain.parents
    beta = model.parameter_vector()
    inertia, _ = chain.split(beta)
    root = idx[0]
    # the root's placement: the held ancestors' transforms, then its own constant placement
    T = np.eye(4)
    a = parents[root]
    while a >= 0:
        T = _joint_transform(chain, a, q[a]) @ T
        a = parents[a]
    T0 = np.eye(4)
    T0[:3, :3], T0[:3, 3] = chain.rotation[root], chain.translation[root]
    T = T @ T0
    joint_frame = {i: inertia[i].copy() for i in idx}
    # descendants not chosen ride on their nearest chosen ancestor (frames at the held q)
    to_body = {}  # full index -> (chosen index, transform from the chosen frame to its frame)
    for i in range(n):
        pi = parents[i]
        if i in idx:
            to_body[i] = (i, np.eye(4))
        elif pi >= 0 and pi in to_body:
            k, Tk = to_body[pi]
            to_body[i] = (k, Tk @ _joint_transform(chain, i, q[i]))
            joint_frame[k] = joint_frame[k] + inertial.transform_standard(
                inertia[i], to_body[i][1][:3, :3], to_body[i][1][:3, 3]
            )
    sub = dataclasses.replace(
        chain,
        joint_names=tuple(chain.joint_names[i] for i in idx),
        joint_types=tuple(chain.joint_types[i] for i in idx),
        rotation=np.array([T[:3, :3] if i == root else chain.rotation[i] for i in idx]),
        translation=np.array([T[:3, 3] if i == root else chain.translation[i] for i in idx]),
        axis=chain.axis[idx],
        standard=np.array([np.linalg.solve(chain.link_to_joint[i], joint_frame[i]) for i in idx]),
        link_to_joint=chain.link_to_joint[idx],
        drive={k: np.asarray(v)[idx] for k, v in chain.drive.items()},
        limits={k: np.asarray(v)[idx] for k, v in chain.limits.items()},
        parent=tuple(-1 if i == root else idx.index(parents[i]) for i in idx),
        identify=(),
        transmission=_sub_transmission(chain, idx),
        description=f"{chain.name}: joints {', '.join(chain.joint_names[i] for i in idx)}; "
        "the others held still",
    )
    return RigidBodyModel(sub, cache=getattr(model, "_cache_enabled", True))


def _sub_transmission(chain, idx):
    """The transmission of the chosen joints' motors (refused where it couples to others)."""
    tr = chain.transmission
    if tr is None:
        return None
    K = tr.motor_from_joint
    rest = [j for j in range(chain.n_joints) if j not in idx]
    if np.any(K[np.ix_(idx, rest)]) or np.any(K[np.ix_(rest, idx)]):
        raise InputError(
            f"{arg('joints')}: the [transmission] couples a chosen joint with one held still (a motor "
            "that turns both); choose the coupled joints together."
        )
    terms = tuple((idx.index(k), kind, name, v) for (k, kind, name, v) in tr.terms if k in idx)
    kt = None if tr.torque_constants is None else tr.torque_constants[idx]
    return dataclasses.replace(
        tr,
        motor_from_joint=K[np.ix_(idx, idx)],
        joint_offsets=tr.joint_offsets[idx],
        torque_constants=kt,
        terms=terms,
    )


def subtree_recording(model, joints, recordings, *, tolerance: float = HOLD_TOLERANCE):
    """The held positions of a log and its channels renumbered for `subtree_model`.

    Parameters
    ----------
    model : RigidBodyModel
        The full model.
    joints : sequence of str
        The chosen joints (see `subtree_model`).
    recordings : list of Recording
        With the full model's channels q1..qn, tau1..taun.
    tolerance : float [rad | m]
        How far a held joint may move (peak to peak) in each recording.

    Returns
    -------
    (dict, list of Recording)
        The held positions (name → median of the first recording) and the recordings with
        ``q``/``qd``/``qdd``/``tau`` of the chosen joints as ``q1..qm`` … and no other joint
        channel.

    Raises
    ------
    InputError
        A joint that is held moves more than ``tolerance``, or moves between recordings.
    """
    import re

    chain = model.chain
    idx = _chosen(chain, list(joints))
    names = chain.joint_names
    related = _related(chain, idx)
    held = {}
    for j in related:
        for r, rec in enumerate(recordings):
            col = np.asarray(rec[f"q{j + 1}"], dtype=float)
            spread = float(np.ptp(col))
            mid = float(np.median(col))
            if spread > tolerance or (r and abs(mid - held[names[j]]) > tolerance):
                raise InputError(
                    f"{arg('joints')}: joint {names[j]!r} (q{j + 1}) is held still in the sub-tree "
                    f"model, but it moves in recording {r + 1} (range {spread:.3g}, median "
                    f"{mid:.6g}; tolerance {tolerance:g}): it carries or is carried by the "
                    f"chosen joints, so its motion matters. Add it to {arg('joints')}, or use a log "
                    "in which it holds still."
                )
            held.setdefault(names[j], mid)
    out = []
    pattern = re.compile(r"(q|qd|qdd|tau|r|rd|rdd)(\d+)")
    for rec in recordings:
        keep, cols, units = [], [], []
        for name, unit in zip(rec.names, rec.units, strict=True):
            m = pattern.fullmatch(name)
            if m is None:
                keep.append(name)
            elif int(m[2]) - 1 in idx:
                keep.append(f"{m[1]}{idx.index(int(m[2]) - 1) + 1}")
            else:
                continue
            cols.append(np.asarray(rec[name], dtype=float))
            units.append(unit)
        out.append(
            type(rec)(rec.t, np.column_stack(cols), tuple(keep), tuple(units), dict(rec.metadata))
        )
    return held, out


def _related(chain, idx) -> list:
    """Joints not chosen whose position matters: ancestors of the root and descendants."""
    parents = chain.parents
    out = []
    a = parents[idx[0]]
    while a >= 0:
        out.append(a)
        a = parents[a]
    below = set(idx)
    for i in range(chain.n_joints):
        if i not in idx and parents[i] in below:
            below.add(i)
            out.append(i)
    return sorted(out)
