"""URDF files and rigid-body TOML chains → `physid.models.rigid.RigidChain`.

URDF (read with the standard library's XML parser; no ROS): ``revolute``, ``continuous`` and
``prismatic`` joints become the model's joints in depth-first order of the tree from its root (as
pinocchio orders them; a branching robot is a kinematic tree, each joint's parent recorded);
``fixed`` joints are merged (the child link's inertia is moved into the parent's frame and
added); ``<origin xyz rpy>``, ``<axis>``, ``<inertial>`` (origin, mass, inertia about the centre
of mass), ``<limit>`` (position, velocity, effort) and ``<dynamics damping friction>`` (viscous
and Coulomb friction) are read; visuals, collisions, meshes, transmissions and gazebo tags are
ignored. A ``<mimic joint multiplier offset>`` joint follows its leader (q = multiplier ·
q_leader + offset, as pinocchio's ``mimic=True``): it is no coordinate of the model, but its link
and drive terms act through the leader; on a fixed joint the tag is ignored with a note.
``planar`` and ``floating`` joints are refused with a message.

A sidecar TOML file (``extends = "robot.urdf"``) adds drive terms per joint and chooses what to
identify (docs/model-files.md, "URDF and inertial parameters").
"""

from __future__ import annotations

import math
import re
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..errors import ModelFileError
from . import inertial
from .rigid import DRIVE_NAMES, RigidChain

__all__ = ["read_urdf", "parse_urdf", "read_sidecar", "ModelWarning", "rpy_matrix"]


class ModelWarning(UserWarning):
    """A model that loads but is physically doubtful (e.g. an inertia violating the triangle
    inequality); ``strict=True`` turns it into a `ModelFileError`."""


#: TOML keys of a joint's drive terms → parameter prefix.
DRIVE_KEYS = {
    "armature": "Ia",
    "rotor_inertia": "Ia",
    "viscous": "Fv",
    "coulomb": "Fc",
    "viscous_positive": "Fvp",
    "viscous_negative": "Fvn",
    "coulomb_positive": "Fcp",
    "coulomb_negative": "Fcn",
    "torque_offset": "OF",
}
STANDARD_KEYS = ("m", "mcx", "mcy", "mcz", "XX", "XY", "XZ", "YY", "YZ", "ZZ")
PHYSICAL_KEYS = ("mass", "com", "inertia")


def rpy_matrix(rpy) -> np.ndarray:
    """Rotation of URDF roll-pitch-yaw angles [rad]: R = Rz(yaw) Ry(pitch) Rx(roll).

    Parameters
    ----------
    rpy : array_like (3,) [rad]

    Returns
    -------
    ndarray (3, 3)
    """
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _homogeneous(R, p) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


# ---------------------------------------------------------------------------------------------
# URDF
# ---------------------------------------------------------------------------------------------


def _where(source, elem, what: str) -> str:
    line = elem.get("__line__") if elem is not None else None
    return f"{source}, line {line} ({what})" if line else f"{source} ({what})"


def _floats(text, n, where, attr):
    if text is None:
        return None
    parts = text.replace(",", " ").split()
    try:
        values = [float(v) for v in parts]
    except ValueError:
        raise ModelFileError(
            f"{where}: {attr}={text!r} must be {n} numbers separated by spaces."
        ) from None
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise ModelFileError(
            f"{where}: {attr}={text!r} must be {n} finite numbers separated by spaces."
        )
    return values


def _float(elem, attr, where, default=None):
    text = elem.get(attr)
    if text is None:
        return default
    try:
        v = float(text)
    except ValueError:
        raise ModelFileError(f"{where}: {attr}={text!r} is not a number.") from None
    if not math.isfinite(v):
        raise ModelFileError(f"{where}: {attr}={text!r} must be finite.")
    return v


def _origin(elem, where):
    o = elem.find("origin") if elem is not None else None
    if o is None:
        return np.eye(3), np.zeros(3)
    xyz = _floats(o.get("xyz", "0 0 0"), 3, where, "origin xyz")
    rpy = _floats(o.get("rpy", "0 0 0"), 3, where, "origin rpy")
    return rpy_matrix(rpy), np.array(xyz)


def _parse_xml(text: str, source: str):
    """Element tree of ``text`` with each element's line number in its ``__line__`` attribute.

    Entity declarations are refused (no entity expansion attacks; URDF never needs them).
    """
    import xml.parsers.expat as expat

    builder = ET.TreeBuilder()
    parser = expat.ParserCreate()

    def start(tag, attrs):
        attrs = dict(attrs)
        attrs["__line__"] = str(parser.CurrentLineNumber)
        builder.start(tag, attrs)

    def entity(*_args):
        raise ModelFileError(
            f"{source}, line {parser.CurrentLineNumber}: the XML declares an entity; URDF files "
            "need none, and physid does not expand them. Remove the <!DOCTYPE>/<!ENTITY> part."
        )

    parser.StartElementHandler = start
    parser.EndElementHandler = builder.end
    parser.CharacterDataHandler = builder.data
    parser.EntityDeclHandler = entity
    try:
        parser.Parse(text, True)
        root = builder.close()
    except expat.ExpatError as exc:
        raise ModelFileError(
            f"{source}: not a well-formed XML (URDF) file: {expat.errors.messages[exc.code]} at "
            f"line {exc.lineno}, column {exc.offset}. Check the tags and quotes near that line."
        ) from None
    except (AssertionError, IndexError):
        raise ModelFileError(f"{source}: not a well-formed XML (URDF) file.") from None
    if root is None:
        raise ModelFileError(f"{source}: the file holds no XML element; give a <robot> document.")
    return root


def parse_urdf(text: str, source: str = "<string>", *, strict: bool = False) -> RigidChain:
    """Parse URDF text into a rigid chain.

    Parameters
    ----------
    text : str
        The URDF document.
    source : str
        Name used in messages (the file path).
    strict : bool
        Refuse (instead of warn about) physically doubtful inertias and zero masses.

    Returns
    -------
    RigidChain
        Joints in tree order from the root; link parameters in the joint (child link) frames.

    Raises
    ------
    ModelFileError
        Not XML, no ``<robot>``, a loop or several roots, a missing parent/child link, a negative
        mass, a zero-length axis, an unsupported joint type, a mimic joint whose leader is
        missing, fixed, of another type or a mimic joint itself.
    """
    if not isinstance(text, str) or not text.strip():
        raise ModelFileError(f"{source}: the URDF file is empty; give a <robot> document.")
    root = _parse_xml(text, source)
    if root.tag != "robot":
        raise ModelFileError(
            f"{source}: the root element is <{root.tag}>, not <robot>; is this a URDF file? "
            "(xacro files must be expanded first: `xacro robot.urdf.xacro > robot.urdf`)."
        )
    name = root.get("name") or Path(source).stem
    links = _urdf_links(root, source, strict)
    joints = {}
    child_of = {}
    children = {}
    for el in root.findall("joint"):
        jname, joint = _urdf_joint(el, source, links, joints, child_of)
        joints[jname] = joint
        child_of[joint["child"]] = jname
        children.setdefault(joint["parent"], []).append(jname)
    roots = [lk for lk in links if lk not in child_of]
    if len(roots) != 1:
        if not roots:
            raise ModelFileError(
                f"{source}: every link is the child of a joint, so the joints form a loop; a URDF "
                "must be a tree with one root link."
            )
        raise ModelFileError(
            f"{source}: the URDF has {len(roots)} root links {roots[:6]} (links that are no "
            "joint's child); connect them with joints so that one root remains."
        )
    order, bodies_inertia = _tree_order(roots[0], links, joints, children, source)
    n = len(order)
    standard = np.array([bodies_inertia.get(k, np.zeros(10)) for k in range(n)])
    drive = {}
    damp = [joints[j]["damping"] for j in order]
    fric = [joints[j]["friction"] for j in order]
    if any(v is not None for v in damp):
        drive["Fv"] = np.array([v or 0.0 for v in damp])
    if any(v is not None for v in fric):
        drive["Fc"] = np.array([v or 0.0 for v in fric])
    limits = _urdf_limits(joints, order)
    return RigidChain(
        name=name,
        joint_names=tuple(order),
        joint_types=tuple(joints[j]["type"] for j in order),
        rotation=np.array([joints[j]["placement"][:3, :3] for j in order]),
        translation=np.array([joints[j]["placement"][:3, 3] for j in order]),
        axis=np.array([joints[j]["axis"] for j in order]),
        standard=standard,
        link_to_joint=np.broadcast_to(np.eye(10), (n, 10, 10)),
        drive=drive,
        gravity=np.array([0.0, 0.0, -9.81]),
        limits=limits,
        source=source,
        parent=tuple(joints[j]["parent_body"] for j in order),
        mimic=_mimic_joints(order, joints),
    )


def _urdf_limits(joints: dict, order: list) -> dict:
    """The chain's ``limits`` from the joints' ``<limit>`` (no acceleration limit in URDF)."""
    return {
        "position": np.array(
            [[joints[j]["limits"]["lower"], joints[j]["limits"]["upper"]] for j in order]
        ),
        "velocity": np.array([joints[j]["limits"]["velocity"] for j in order]),
        "effort": np.array([joints[j]["limits"]["effort"] for j in order]),
        "acceleration": np.full(len(order), math.nan),
    }


def _mimic_joints(order: list, joints: dict) -> tuple:
    """``(follower, leader, multiplier, offset)`` of each movable mimic joint, checked."""
    out = []
    for k, jname in enumerate(order):
        spec = joints[jname].get("mimic")
        if spec is None:
            continue
        leader, mult, off = spec
        w = joints[jname]["where"]
        if leader not in order:
            what = "a fixed joint" if leader in joints else "not a joint of the robot"
            raise ModelFileError(
                f"{w}: joint {jname!r} mimics {leader!r}, which is {what}; a mimic joint "
                f"follows a movable joint (the movable ones: {order[:8]})."
            )
        if joints[leader].get("mimic") is not None:
            raise ModelFileError(
                f"{w}: joint {jname!r} mimics {leader!r}, itself a mimic joint; make it mimic "
                f"{joints[leader]['mimic'][0]!r} (multiplying the multipliers)."
            )
        if joints[leader]["type"] != joints[jname]["type"]:
            raise ModelFileError(
                f"{w}: joint {jname!r} ({joints[jname]['type']}) mimics {leader!r} "
                f"({joints[leader]['type']}); a mimic joint must be of its leader's type."
            )
        out.append((k, order.index(leader), mult, off))
    return tuple(out)


def _urdf_links(root, source: str, strict: bool) -> dict:
    """Link name -> its 10 standard inertial parameters, for every ``<link>``."""
    links = {}
    for el in root.findall("link"):
        lname = el.get("name")
        w = _where(source, el, "link")
        if not lname:
            raise ModelFileError(f"{w}: a <link> needs a name attribute.")
        if lname in links:
            raise ModelFileError(
                f"{w}: link {lname!r} is defined twice; link names must be unique."
            )
        links[lname] = _link_parameters(el, source, lname, strict)
    if not links:
        raise ModelFileError(f"{source}: the robot has no <link>; a URDF needs links and joints.")
    return links


def _urdf_joint(el, source: str, links: dict, joints: dict, child_of: dict) -> tuple:
    """``(name, record)`` of one ``<joint>``: its type, links, placement, axis, limits, dynamics."""
    jname = el.get("name")
    w = _where(source, el, f"joint {jname!r}")
    if not jname:
        raise ModelFileError(f"{w}: a <joint> needs a name attribute.")
    if jname in joints:
        raise ModelFileError(f"{w}: joint {jname!r} is defined twice.")
    jtype = el.get("type")
    if jtype in ("planar", "floating"):
        raise ModelFileError(
            f"{w}: joint type {jtype!r} is not supported (physid models serial chains of "
            "revolute, continuous and prismatic joints on a fixed base); make it 'fixed' or "
            "model its degrees of freedom as separate joints."
        )
    if jtype not in ("revolute", "continuous", "prismatic", "fixed"):
        raise ModelFileError(
            f"{w}: unknown joint type {jtype!r}; use revolute, continuous, prismatic or fixed."
        )
    if el.find("mimic") is not None and jtype == "fixed":
        warnings.warn(
            f"{w}: note: the fixed joint {jname!r} carries a <mimic> tag; a fixed joint has no "
            "coordinate to copy, so the tag is ignored.",
            ModelWarning,
            stacklevel=4,
        )
    mimic = None
    if el.find("mimic") is not None and jtype != "fixed":
        me = el.find("mimic")
        if not me.get("joint"):
            raise ModelFileError(f'{w}: <mimic> needs joint="LEADER", the joint it follows.')
        mimic = (me.get("joint"), _float(me, "multiplier", w, 1.0), _float(me, "offset", w, 0.0))
    parent, child = _joint_links(el, w, jname, links, child_of)
    R, p = _origin(el, w)
    axis = np.array([1.0, 0.0, 0.0])
    ax = el.find("axis")
    if ax is not None and jtype != "fixed":
        axis = np.array(_floats(ax.get("xyz", "1 0 0"), 3, w, "axis xyz"))
    norm = float(np.linalg.norm(axis))
    if jtype != "fixed" and norm < 1e-12:
        raise ModelFileError(
            f"{w}: the axis of joint {jname!r} has zero length; give a direction, e.g. "
            '<axis xyz="0 0 1"/>.'
        )
    lim = el.find("limit")
    limits = {"lower": math.nan, "upper": math.nan, "velocity": math.nan, "effort": math.nan}
    if lim is not None:
        for key in limits:
            limits[key] = _float(lim, key, w, math.nan)
    if jtype == "continuous":
        limits["lower"], limits["upper"] = -math.inf, math.inf
    dyn = el.find("dynamics")
    damping = friction = None
    if dyn is not None:
        damping = _float(dyn, "damping", w)
        friction = _float(dyn, "friction", w)
    return jname, {
        "type": "revolute" if jtype == "continuous" else jtype,
        "parent": parent,
        "child": child,
        "R": R,
        "p": p,
        "axis": axis / max(norm, 1e-300),
        "limits": limits,
        "damping": damping,
        "friction": friction,
        "where": w,
        "mimic": mimic,
    }


def _joint_links(el, w: str, jname: str, links: dict, child_of: dict) -> tuple:
    """``(parent, child)`` link names of a ``<joint>``, checked to make a tree."""
    pe, ce = el.find("parent"), el.find("child")
    parent = pe.get("link") if pe is not None else None
    child = ce.get("link") if ce is not None else None
    for role, lk in (("parent", parent), ("child", child)):
        if not lk:
            raise ModelFileError(f'{w}: the joint needs <{role} link="..."/>.')
        if lk not in links:
            raise ModelFileError(
                f'{w}: {role} link {lk!r} is not defined; add <link name="{lk}"/> or fix '
                f"the name (links: {sorted(links)[:8]})."
            )
    if parent == child:
        raise ModelFileError(f"{w}: the joint connects link {parent!r} to itself (a loop).")
    if child in child_of:
        raise ModelFileError(
            f"{w}: link {child!r} is the child of two joints ({child_of[child]!r} and "
            f"{jname!r}): the URDF has a loop; a URDF must be a tree (each link has one "
            "parent joint)."
        )
    return parent, child


def _tree_order(root: str, links: dict, joints: dict, children: dict, source: str) -> tuple:
    """The movable joints in depth-first order from ``root`` (their ``placement`` and
    ``parent_body`` set), and each body's standard parameters with its fixed links folded in.

    Bodies are the root (the base, -1) and each movable joint's child, with the links fixed to it.
    Depth first, children in document order: pinocchio's order, and the joints of one arm of a
    branching robot stay together.
    """
    body_of = {root: (-1, np.eye(4))}  # link -> (body index, T_body_link)
    order = []  # movable joints in tree order
    bodies_inertia = {}
    stack = [root]
    seen = set()
    child_joint = {}  # link -> the joint whose child it is
    while stack:
        lk = stack.pop()
        if lk in seen:
            raise ModelFileError(f"{source}: link {lk!r} is reached twice (a loop).")
        seen.add(lk)
        b, T = body_of[lk]
        if lk != root:
            jname = child_joint[lk]
            j = joints[jname]
            if j["type"] != "fixed":
                j["parent_body"] = b
                j["placement"] = T
                order.append(jname)
                b, T = len(order) - 1, np.eye(4)
                body_of[lk] = (b, T)
        bodies_inertia.setdefault(b, np.zeros(10))
        bodies_inertia[b] = bodies_inertia[b] + inertial.transform_standard(
            links[lk], T[:3, :3], T[:3, 3]
        )
        for jname in reversed(children.get(lk, [])):  # popped in document order
            j = joints[jname]
            body_of[j["child"]] = (b, T @ _homogeneous(j["R"], j["p"]))
            child_joint[j["child"]] = jname
            stack.append(j["child"])
    if not order:
        raise ModelFileError(
            f"{source}: the robot has no revolute, continuous or prismatic joint; nothing moves."
        )
    return order, bodies_inertia


def _link_parameters(el, source, lname, strict) -> np.ndarray:
    """Standard parameters of one URDF link in its own frame (zeros without <inertial>)."""
    ine = el.find("inertial")
    if ine is None:
        return np.zeros(10)
    w = _where(source, ine, f"link {lname!r} inertial")
    me = ine.find("mass")
    mass = _float(me, "value", w, 0.0) if me is not None else 0.0
    ie = ine.find("inertia")
    six = np.zeros(6)
    if ie is not None:
        vals = {k: _float(ie, k, w, 0.0) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        six = np.array([vals[k] for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")])
    R, c = _origin(ine, w)
    ic = R @ inertial.inertia_matrix(six) @ R.T
    return _checked_standard(mass, c, ic, w, strict, six_given=ie is not None)


def _checked_standard(mass, c, ic, w, strict, *, six_given=True):
    if mass < 0:
        raise ModelFileError(
            f"{w}: mass {mass} kg is negative; a link's mass must be > 0 (or remove <inertial> "
            "for a massless link)."
        )
    if mass == 0:
        if np.any(ic != 0):
            msg = (
                f"{w}: mass 0 kg with a non-zero inertia is not physical; give the link's mass "
                "(or remove <inertial> for a massless link)."
            )
            if strict:
                raise ModelFileError(msg)
            warnings.warn(msg, ModelWarning, stacklevel=4)
        return inertial.standard_from_physical(0.0, c, ic)
    p = inertial.standard_from_physical(mass, c, ic)
    problems = inertial.check_physical(p, tol=1e-9)
    if problems:
        msg = (
            f"{w}: {problems[0]}; a real body has positive principal moments with each at most "
            "the sum of the other two. Check the inertia values and their units (kg·m²)."
        )
        if strict:
            raise ModelFileError(msg)
        warnings.warn(msg, ModelWarning, stacklevel=4)
    return p


def read_urdf(path, *, strict: bool = False) -> RigidChain:
    """Read a URDF file (see `parse_urdf`).

    Parameters
    ----------
    path : str or Path
    strict : bool
        Refuse physically doubtful inertias instead of warning.

    Returns
    -------
    RigidChain
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ModelFileError(
            f"cannot read URDF file {str(path)!r}: {exc.strerror or exc}."
        ) from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ModelFileError(
            f"{path}: not a UTF-8 text file; a URDF is an XML text document."
        ) from None
    return parse_urdf(text, str(path), strict=strict)


# ---------------------------------------------------------------------------------------------
# per-joint TOML tables (sidecar and rigid-body chains)
# ---------------------------------------------------------------------------------------------


def joint_inertial(table: dict, where: str, strict: bool, evaluate, *, default=None):
    """Standard parameters (10,) of a joint table: standard keys or mass/com/inertia; else
    ``default``. ``evaluate(value, key)`` turns a TOML value into a float."""
    std = [k for k in STANDARD_KEYS if k in table]
    phys = [k for k in PHYSICAL_KEYS if k in table]
    if std and phys:
        raise ModelFileError(
            f"{where}: give the link either physically (mass, com, inertia) or by its standard "
            f"parameters ({', '.join(STANDARD_KEYS)}), not both; got {phys + std}."
        )
    if std:
        p = np.array([evaluate(table.get(k, 0.0), k) for k in STANDARD_KEYS])
        if p[0] < 0:
            raise ModelFileError(f"{where}: m = {p[0]} kg is negative; a mass must be > 0.")
        if p[0] > 0:
            problems = inertial.check_physical(p, tol=1e-9)
            if problems:
                msg = f"{where}: {problems[0]}; check the standard parameters."
                if strict:
                    raise ModelFileError(msg)
                warnings.warn(msg, ModelWarning, stacklevel=3)
        return p
    if phys:
        mass = evaluate(table.get("mass", 0.0), "mass")
        com = table.get("com", [0.0, 0.0, 0.0])
        if not isinstance(com, list) or len(com) != 3:
            raise ModelFileError(f"{where}: com must be [cx, cy, cz] in metres; got {com!r}.")
        c = np.array([evaluate(v, "com") for v in com])
        ine = table.get("inertia", [0.0] * 6)
        if not isinstance(ine, list) or len(ine) != 6:
            raise ModelFileError(
                f"{where}: inertia must be [Ixx, Ixy, Ixz, Iyy, Iyz, Izz] in kg·m² about the "
                f"centre of mass; got {ine!r}."
            )
        six = np.array([evaluate(v, "inertia") for v in ine])
        return _checked_standard(mass, c, inertial.inertia_matrix(six), where, strict)
    return default


def joint_drive(table: dict, where: str, evaluate) -> dict:
    """Drive terms (prefix → value) of a joint table."""
    out = {}
    for key, prefix in DRIVE_KEYS.items():
        if key in table:
            if prefix in out:
                raise ModelFileError(
                    f"{where}: armature and rotor_inertia are the same term; give one."
                )
            out[prefix] = evaluate(table[key], key)
    return out


def _plain_number(value, key, where):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ModelFileError(f"{where}: {key} must be a finite number; got {value!r}.")
    return float(value)


_SIDECAR_TOP = {
    "name", "kind", "description", "extends", "gravity", "joints", "identify", "strict",
    "recording",  # the channel map of the robot's logs (read by spec.read_recording_map)
}  # fmt: skip
_SIDECAR_TOP |= {"transmission"}  # motors and their coupling (physid.models.transmission)
_SIDECAR_JOINT = set(DRIVE_KEYS) | set(STANDARD_KEYS) | set(PHYSICAL_KEYS) | {"acceleration"}


def read_sidecar(data: dict, source: str, *, strict: bool = False) -> RigidChain:
    """A sidecar TOML table (already parsed) extending a URDF → rigid chain.

    Parameters
    ----------
    data : dict
        The TOML content: ``extends`` (URDF path, relative to the TOML file), optional ``name``,
        ``description``, ``gravity``, ``identify`` (list of parameter names), a
        ``[recording]`` table (the channel map of the robot's logs, docs/your-data.md), and
        ``[joints.<urdf joint name>]`` tables with drive terms (armature, viscous, coulomb,
        viscous_positive, viscous_negative, coulomb_positive, coulomb_negative, torque_offset),
        an ``acceleration`` limit, or inertial values that replace the URDF's.
    source : str
        Path of the TOML file.
    strict : bool

    Returns
    -------
    RigidChain
    """
    extra = set(data) - _SIDECAR_TOP
    if extra:
        raise ModelFileError(
            f"{source}: unknown key(s) {sorted(extra)} in a URDF sidecar; allowed: "
            f"{sorted(_SIDECAR_TOP)}."
        )
    if "recording" in data:  # checked here, used when a recording is read (the CLI, validate)
        from .spec_common import _parse_recording

        _parse_recording(data, "", source)
    path = _sidecar_target(data, source)
    if "strict" in data and not isinstance(data["strict"], bool):
        raise ModelFileError(
            f"{source}: strict must be a TOML boolean, true or false without quotes; got "
            f"{data['strict']!r} ({type(data['strict']).__name__})."
        )
    strict = bool(data.get("strict", strict))
    chain = read_urdf(path, strict=strict)
    table = data.get("joints", {})
    if not isinstance(table, dict):
        raise ModelFileError(
            f"{source}: joints must be tables [joints.<urdf joint name>] in a sidecar."
        )
    standard, drive_values, accel = _sidecar_joints(table, chain, source, strict)
    drive = {k: drive_values[k] for k in DRIVE_NAMES if k in drive_values}
    gravity = chain.gravity
    if "gravity" in data:
        g = data["gravity"]
        if not isinstance(g, list) or len(g) != 3:
            raise ModelFileError(f"{source}: gravity must be [gx, gy, gz] in m/s²; got {g!r}.")
        gravity = np.array([_plain_number(v, "gravity", source) for v in g])
    limits = dict(chain.limits)
    limits["acceleration"] = accel
    identify = data.get("identify", ())
    if not isinstance(identify, (list, tuple)) or not all(isinstance(s, str) for s in identify):
        raise ModelFileError(
            f"{source}: identify must be a list of parameter names; got {identify!r}."
        )
    name = data.get("name", chain.name)
    return _with_transmission(
        data,
        source,
        RigidChain(
            name=str(name),
            joint_names=chain.joint_names,
            joint_types=chain.joint_types,
            rotation=chain.rotation,
            translation=chain.translation,
            axis=chain.axis,
            standard=standard,
            link_to_joint=chain.link_to_joint,
            drive=drive,
            gravity=gravity,
            limits=limits,
            source=source,
            description=str(data.get("description", "")),
            identify=tuple(identify),
            parent=chain.parent,
        ),
    )


def _with_transmission(data: dict, source: str, chain: RigidChain) -> RigidChain:
    """The sidecar's chain with its ``[transmission]`` table, if any."""
    from .transmission import attach_transmission

    return attach_transmission(chain, data.get("transmission"), source)


def _sidecar_target(data: dict, source: str) -> Path:
    """The URDF a sidecar ``extends`` (relative to the sidecar), checked to exist."""
    target = data.get("extends")
    if not isinstance(target, str) or not target.strip():
        raise ModelFileError(
            f'{source}: extends must be the path of a URDF file, e.g. "robot.urdf".'
        )
    path = Path(target)
    if not path.is_absolute():
        path = Path(source).parent / path
    if not path.exists():
        raise ModelFileError(
            f"{source}: extends = {target!r}: no such file {str(path)!r} (paths are relative to "
            "the TOML file)."
        )
    if path.resolve() == Path(source).resolve():
        raise ModelFileError(
            f"{source}: extends = {target!r} names the sidecar itself (a cycle): extends must "
            "name the robot's URDF file."
        )
    if path.is_file():
        with open(path, "rb") as fh:
            head = fh.read(512)
        if not looks_like_xml(head) and re.search(rb"^\s*extends\s*=", head, re.M):
            raise ModelFileError(
                f"{source}: extends = {target!r} names another sidecar TOML, not a URDF (a "
                "sidecar extends a URDF file only, so chains of sidecars, and cycles, are "
                "refused): point extends at the robot's URDF file."
            )
    return path


def _sidecar_joints(table: dict, chain: RigidChain, source: str, strict: bool) -> tuple:
    """``(standard, drive_values, accel)``: the URDF chain's values with the sidecar's
    ``[joints.<name>]`` tables applied."""
    standard = chain.standard.copy()
    drive_values = {k: np.array(v, dtype=float) for k, v in chain.drive.items()}
    accel = chain.limits["acceleration"].copy()
    for jname, jt in table.items():
        w = f"{source} ([joints.{jname}])"
        if jname not in chain.joint_names:
            raise ModelFileError(
                f"{w}: the URDF has no movable joint {jname!r}; its joints: "
                f"{list(chain.joint_names)}."
            )
        if not isinstance(jt, dict):
            raise ModelFileError(f"{w}: must be a table of drive terms, e.g. armature = 0.1.")
        bad = set(jt) - _SIDECAR_JOINT
        if bad:
            raise ModelFileError(
                f"{w}: unknown key(s) {sorted(bad)}; allowed: {sorted(_SIDECAR_JOINT)}."
            )
        k = chain.joint_names.index(jname)

        def ev(value, key, _w=w):
            return _plain_number(value, key, _w)

        p = joint_inertial(jt, w, strict, ev)
        if p is not None:
            standard[k] = p
        for prefix, v in joint_drive(jt, w, ev).items():
            drive_values.setdefault(prefix, np.zeros(chain.n_joints))[k] = v
        if "acceleration" in jt:
            accel[k] = ev(jt["acceleration"], "acceleration")
    return standard, drive_values, accel


def looks_like_xml(head: bytes) -> bool:
    """Whether a file's first bytes look like XML (for files without a .urdf suffix)."""
    return bool(re.match(rb"\s*(<\?xml|<robot)", head))
