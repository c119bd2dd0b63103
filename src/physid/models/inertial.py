"""Inertial parameters of a rigid body: physical ↔ standard ↔ 4 × 4 pseudo-inertia.

physid's one parameter order (the *standard* inertial parameters of a link, linear in the
dynamics), written down once::

    p = [m, mcx, mcy, mcz, XX, XY, XZ, YY, YZ, ZZ]

m [kg] is the mass, m·c = (mcx, mcy, mcz) [kg·m] the first moments (c the centre of mass in the
link frame) and XX … ZZ [kg·m²] the entries of the inertia tensor **about the link frame's
origin**, in the link frame's axes::

    I_O = ⎡XX XY XZ⎤ = I_C + m (|c|² E − c cᵀ)   (parallel-axis theorem)
          ⎢XY YY YZ⎥
          ⎣XZ YZ ZZ⎦

with I_C the inertia about the centre of mass (what URDF ``<inertia>`` holds, after rotating it
by the ``<inertial><origin rpy>``). Note XY = ∫ ... is the *tensor entry* (−∫ x y dm), the URDF
``ixy`` convention, not the product of inertia ∫ x y dm.

pinocchio orders the same ten numbers as ``[m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]``
(`to_pinocchio_order` / `from_pinocchio_order` convert at that boundary).

The pseudo-inertia J = ⎡Σ  m c⎤ with Σ = ½ tr(I_O) E − I_O = ∫ r rᵀ dm is positive definite
                       ⎣m cᵀ m ⎦
exactly when the body is physically realisable (Wensing et al., 2017), which `is_physical` checks.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError, ShapeError

__all__ = [
    "STANDARD_NAMES",
    "standard_from_physical",
    "physical_from_standard",
    "pseudo_inertia",
    "pseudo_inertia_to_standard",
    "to_pinocchio_order",
    "from_pinocchio_order",
    "inertia_matrix",
    "inertia_vector",
    "transform_standard",
    "check_physical",
]

#: Names (without the joint number) of the standard parameters, in physid's order.
STANDARD_NAMES = ("m", "mcx", "mcy", "mcz", "XX", "XY", "XZ", "YY", "YZ", "ZZ")

# positions of physid's XX XY XZ YY YZ ZZ in pinocchio's Ixx Ixy Iyy Ixz Iyz Izz and back
_TO_PIN = np.array([0, 1, 2, 3, 4, 5, 7, 6, 8, 9])
_FROM_PIN = np.argsort(_TO_PIN)


def _vector10(p, name: str) -> np.ndarray:
    arr = np.asarray(p, dtype=float)
    if arr.shape[-1:] != (10,):
        raise ShapeError(f"{name} must have 10 entries on its last axis; got shape {arr.shape}.")
    return arr


def inertia_matrix(six) -> np.ndarray:
    """3 × 3 symmetric tensor from ``[XX, XY, XZ, YY, YZ, ZZ]`` (any leading axes).

    Parameters
    ----------
    six : array_like (..., 6) [kg·m²]
        Tensor entries in physid's order.

    Returns
    -------
    ndarray (..., 3, 3) [kg·m²]
    """
    s = np.asarray(six, dtype=float)
    if s.shape[-1:] != (6,):
        raise ShapeError(f"an inertia needs 6 entries [XX, XY, XZ, YY, YZ, ZZ]; got {s.shape}.")
    xx, xy, xz, yy, yz, zz = np.moveaxis(s, -1, 0)
    return np.stack(
        [np.stack([xx, xy, xz], -1), np.stack([xy, yy, yz], -1), np.stack([xz, yz, zz], -1)], -2
    )


def inertia_vector(matrix) -> np.ndarray:
    """``[XX, XY, XZ, YY, YZ, ZZ]`` of a 3 × 3 tensor (its symmetric part; any leading axes).

    Parameters
    ----------
    matrix : array_like (..., 3, 3) [kg·m²]

    Returns
    -------
    ndarray (..., 6) [kg·m²]
    """
    m = np.asarray(matrix, dtype=float)
    m = 0.5 * (m + np.swapaxes(m, -1, -2))
    return np.stack(
        [m[..., 0, 0], m[..., 0, 1], m[..., 0, 2], m[..., 1, 1], m[..., 1, 2], m[..., 2, 2]], -1
    )


def standard_from_physical(mass, com, inertia_com) -> np.ndarray:
    """Standard parameters from mass, centre of mass and inertia about the centre of mass.

    Parameters
    ----------
    mass : float [kg]
    com : array_like (3,) [m]
        Centre of mass in the link frame.
    inertia_com : array_like (6,) ``[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]`` or (3, 3) [kg·m²]
        Inertia tensor about the centre of mass, in the link frame's axes.

    Returns
    -------
    ndarray (10,)
        ``[m, mcx, mcy, mcz, XX, XY, XZ, YY, YZ, ZZ]`` (inertia about the link-frame origin).

    Examples
    --------
    >>> standard_from_physical(2.0, [0.5, 0, 0], [0.01, 0, 0, 0.02, 0, 0.03]).tolist()
    [2.0, 1.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.52, 0.0, 0.53]
    """
    m = float(mass)
    c = np.asarray(com, dtype=float).reshape(3)
    ic = np.asarray(inertia_com, dtype=float)
    if ic.shape == (6,):
        ic = inertia_matrix(ic)
    if ic.shape != (3, 3):
        raise ShapeError(f"inertia_com must be 6 entries or a 3×3 matrix; got shape {ic.shape}.")
    io = ic + m * (float(c @ c) * np.eye(3) - np.outer(c, c))
    return np.concatenate([[m], m * c, inertia_vector(io)])


def physical_from_standard(p10):
    """Mass, centre of mass and inertia about the centre of mass from standard parameters.

    Parameters
    ----------
    p10 : array_like (10,)
        ``[m, mcx, mcy, mcz, XX, XY, XZ, YY, YZ, ZZ]``.

    Returns
    -------
    mass : float [kg]
    com : ndarray (3,) [m]
    inertia_com : ndarray (6,) [kg·m²]
        ``[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]`` about the centre of mass.

    Raises
    ------
    InputError
        m ≤ 0 (the centre of mass is undefined).
    """
    p = _vector10(p10, "p10")
    m = float(p[0])
    if not m > 0:
        raise InputError(f"p10 has mass {m}; the centre of mass needs m > 0.")
    c = p[1:4] / m
    io = inertia_matrix(p[4:])
    ic = io - m * (float(c @ c) * np.eye(3) - np.outer(c, c))
    return m, c, inertia_vector(ic)


def pseudo_inertia(p10) -> np.ndarray:
    """4 × 4 pseudo-inertia J = [[Σ, m c], [m cᵀ, m]], Σ = ½ tr(I) E − I (any leading axes).

    Parameters
    ----------
    p10 : array_like (..., 10)
        Standard parameters.

    Returns
    -------
    ndarray (..., 4, 4)
        Positive definite exactly for physically realisable bodies.
    """
    p = _vector10(p10, "p10")
    io = inertia_matrix(p[..., 4:])
    tr = np.trace(io, axis1=-2, axis2=-1)[..., None, None]
    sigma = 0.5 * tr * np.eye(3) - io
    J = np.zeros(p.shape[:-1] + (4, 4))
    J[..., :3, :3] = sigma
    J[..., :3, 3] = p[..., 1:4]
    J[..., 3, :3] = p[..., 1:4]
    J[..., 3, 3] = p[..., 0]
    return J


def pseudo_inertia_to_standard(J) -> np.ndarray:
    """Standard parameters from a pseudo-inertia (inverse of `pseudo_inertia`).

    Parameters
    ----------
    J : array_like (..., 4, 4)

    Returns
    -------
    ndarray (..., 10)
    """
    J = np.asarray(J, dtype=float)
    if J.shape[-2:] != (4, 4):
        raise ShapeError(f"J must be 4×4 on its last two axes; got {J.shape}.")
    sigma = 0.5 * (J[..., :3, :3] + np.swapaxes(J[..., :3, :3], -1, -2))
    io = np.trace(sigma, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) - sigma
    mc = 0.5 * (J[..., :3, 3] + J[..., 3, :3])
    return np.concatenate([J[..., 3, 3][..., None], mc, inertia_vector(io)], -1)


def to_pinocchio_order(p10) -> np.ndarray:
    """physid ``[m, mcx, mcy, mcz, XX, XY, XZ, YY, YZ, ZZ]`` → pinocchio ``[…, Ixx, Ixy, Iyy,
    Ixz, Iyz, Izz]``.

    Parameters
    ----------
    p10 : array_like (..., 10)

    Returns
    -------
    ndarray (..., 10)
    """
    return _vector10(p10, "p10")[..., _TO_PIN].copy()


def from_pinocchio_order(p10) -> np.ndarray:
    """pinocchio ``[m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`` → physid's order.

    Parameters
    ----------
    p10 : array_like (..., 10)

    Returns
    -------
    ndarray (..., 10)
    """
    return _vector10(p10, "p10")[..., _FROM_PIN].copy()


def transform_standard(p10, R, p) -> np.ndarray:
    """The same body's standard parameters in a parent frame, where x_parent = R x_child + p.

    Parameters
    ----------
    p10 : array_like (10,)
        Standard parameters in the child frame.
    R : array_like (3, 3)
        Rotation of the child frame in the parent frame.
    p : array_like (3,) [m]
        Origin of the child frame in the parent frame.

    Returns
    -------
    ndarray (10,)
        Standard parameters about the parent origin, in the parent axes (zero-mass bodies, e.g.
        a pure rotor inertia, are handled: Σ transforms as R Σ Rᵀ + …).
    """
    J = pseudo_inertia(p10)
    T = np.eye(4)
    T[:3, :3] = np.asarray(R, dtype=float)
    T[:3, 3] = np.asarray(p, dtype=float)
    return pseudo_inertia_to_standard(T @ J @ T.T)


def check_physical(p10, *, tol: float = 0.0):
    """What makes a body physically impossible, as a list of sentences (empty: realisable).

    Checks m > 0, the inertia about the centre of mass positive definite and its principal
    moments obeying the triangle inequality (I1 ≤ I2 + I3, ...), which together are equivalent
    to a positive definite pseudo-inertia.

    Parameters
    ----------
    p10 : array_like (10,)
    tol : float
        Relative tolerance on the inequalities.

    Returns
    -------
    list of str
    """
    p = _vector10(p10, "p10")
    problems = []
    m = float(p[0])
    if not m > 0:
        return [f"the mass {m:g} kg is not positive"]
    _, _, ic = physical_from_standard(p)
    eig = np.linalg.eigvalsh(inertia_matrix(ic))
    scale = max(float(np.abs(eig).max()), 1e-300)
    if eig[0] < -tol * scale - 1e-15 * scale:
        problems.append(
            f"the inertia about the centre of mass is not positive semi-definite (principal "
            f"moments {np.round(eig, 9).tolist()} kg·m²)"
        )
    elif eig[2] > eig[0] + eig[1] + tol * scale + 1e-12 * scale:
        problems.append(
            f"the principal moments {np.round(eig, 9).tolist()} kg·m² violate the triangle "
            f"inequality I3 ≤ I1 + I2"
        )
    return problems
