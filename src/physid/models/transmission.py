"""Transmissions between motors and joints: gear ratios, coupled wrists, motor-side terms.

A rigid-body model may say how its joints are driven (``[transmission]`` in a model file or a
URDF sidecar, docs/model-files.md). With n motors and n joints and a constant, invertible
*coupling matrix* K (``motor_from_joint``)::

    θm = K (q − q0)          motor angles from joint angles (q0: ``joint_offsets``)
    τ  = Kᵀ τm               joint torques from motor torques (virtual work: τmᵀ δθm = τᵀ δq)
    τm = kt ⊙ i              motor torques from currents (``torque_constants``, N·m/A)

A gear ratio is a diagonal K (``gear_ratios``); a differential wrist whose motor 6 turns with
q5 + q6 has the row ``[0, 0, 0, 0, N6, N6]``.

Motor-side terms of motor k (rotor inertia Im_k, viscous Fvm_k and Coulomb Fcm_k friction, on
the motor's own angle) enter the joint equations through K. From the rotor's kinetic energy
``T = ½ θ̇mᵀ diag(Im) θ̇m`` with ``θ̇m = K q̇`` (K constant), Lagrange's equations give
``Kᵀ diag(Im) K q̈``; the dissipative torques ``Fvm ⊙ θ̇m`` and ``Fcm ⊙ sign(θ̇m)`` on the motor
side become ``Kᵀ (…)`` on the joints. Each term is linear in its parameter, so its regressor
column is, for motor k with row kₖ of K,

    inertia:  kₖᵀ (kₖ · q̈)      viscous:  kₖᵀ (kₖ · q̇)      Coulomb:  kₖᵀ sign(kₖ · q̇)

(W. Khalil and E. Dombre, *Modeling, Identification and Control of Robots*, 2002, section 9.3
writes the coupled wrist the same way). For a diagonal K the three columns are N² q̈, N² q̇ and
|N| sign(q̇) (N sign(N q̇) = |N| sign(q̇), whatever the sign of the ratio): the joint-side
armature and friction of that joint, which the base parameters then merge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelFileError, arg

__all__ = ["Transmission", "MOTOR_TERMS", "parse_transmission", "attach_transmission"]

#: Motor-side terms: (key in the TOML table, parameter prefix, description, unit).
MOTOR_TERMS = (
    ("inertia", "Im", "rotor inertia (motor side)", "kg*m^2"),
    ("viscous", "Fvm", "viscous friction (motor side)", "N*m*s/rad"),
    ("coulomb", "Fcm", "Coulomb friction (motor side)", "N*m"),
)
_TERM_PREFIX = {t[0]: t[1] for t in MOTOR_TERMS}
_TERM_UNIT = {t[0]: t[3] for t in MOTOR_TERMS}


@dataclass(frozen=True, eq=False)
class Transmission:
    """Motors and their coupling to the joints (immutable; arrays read-only).

    Attributes
    ----------
    motor_from_joint : ndarray (n, n)
        K in θm = K (q − q0); invertible.
    joint_offsets : ndarray (n,) [rad | m]
        q0: the joint positions at θm = 0.
    torque_constants : ndarray (n,) [N·m/A] or None
        kt in τm = kt ⊙ i (None: currents cannot be converted).
    terms : tuple of (int, str, str, float)
        Motor-side terms ``(motor index (0-based), kind, parameter name, nominal value)``;
        kind is ``"inertia"``, ``"viscous"`` or ``"coulomb"``.
    source : str
        The file that gave them (for messages).
    """

    motor_from_joint: np.ndarray
    joint_offsets: np.ndarray
    torque_constants: np.ndarray | None = None
    terms: tuple = ()
    source: str = "<built-in>"

    def __post_init__(self):
        for name in ("motor_from_joint", "joint_offsets", "torque_constants"):
            value = getattr(self, name)
            if value is None:
                continue
            arr = np.array(value, dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_motors(self) -> int:
        """Number of motors (= joints)."""
        return int(self.motor_from_joint.shape[0])

    def names(self) -> tuple:
        """Parameter names of the motor-side terms, in the order of `terms`."""
        return tuple(t[2] for t in self.terms)

    def units(self) -> tuple:
        """SI units of the motor-side parameters (the motor's own angle is in rad)."""
        return tuple(_TERM_UNIT[t[1]] for t in self.terms)

    def nominal(self) -> np.ndarray:
        """Nominal values of the motor-side parameters."""
        return np.array([t[3] for t in self.terms], dtype=float)

    def content(self) -> dict:
        """JSON-ready description (keys caches)."""
        return {
            "K": self.motor_from_joint.round(15).tolist(),
            "terms": [[t[0], t[1], t[2]] for t in self.terms],
        }

    # -- dynamics ---------------------------------------------------------------------------
    def columns(self, qd, qdd, smoothing: float = 0.0) -> np.ndarray:
        """Regressor columns of the motor-side terms, shape (N, n, n_terms).

        Parameters
        ----------
        qd, qdd : ndarray (N, n)
            Joint velocities and accelerations.
        smoothing : float [rad/s]
            0: exact sign; > 0: tanh(θ̇m / smoothing) in the Coulomb terms (simulation).

        Returns
        -------
        ndarray (N, n, n_terms) [N·m per unit parameter]
        """
        K = self.motor_from_joint
        N = qd.shape[0]
        out = np.empty((N, K.shape[1], len(self.terms)))
        thd = qd @ K.T  # θ̇m = K q̇
        thdd = qdd @ K.T  # θ̈m = K q̈
        for c, (k, kind, _name, _v) in enumerate(self.terms):
            if kind == "inertia":
                s = thdd[:, k]
            elif kind == "viscous":
                s = thd[:, k]
            elif smoothing > 0:
                s = np.tanh(thd[:, k] / smoothing)
            else:
                s = np.sign(thd[:, k])
            out[:, :, c] = s[:, None] * K[k][None, :]  # τ = kₖᵀ s
        return out

    def torque(self, values, qd, qdd, smoothing: float = 0.0) -> np.ndarray:
        """Joint torques (N, n) of the motor-side terms at parameter ``values`` (n_terms,)."""
        if not self.terms:
            return np.zeros_like(qd)
        return self.columns(qd, qdd, smoothing) @ np.asarray(values, dtype=float)

    def mass(self, values) -> np.ndarray:
        """Kᵀ diag(Im) K (n, n): the rotors' share of the mass matrix at ``values``."""
        K = self.motor_from_joint
        im = np.zeros(K.shape[0])
        for (k, kind, _name, _v), v in zip(self.terms, np.asarray(values, float), strict=True):
            if kind == "inertia":
                im[k] += v
        return K.T @ (im[:, None] * K)

    # -- channel conversions ----------------------------------------------------------------
    def joint_positions(self, theta) -> np.ndarray:
        """q = K⁻¹ θm + q0 for motor angles θm (N, n) [rad] (solve, not inverse)."""
        sol = np.linalg.solve(self.motor_from_joint, np.asarray(theta, float).T).T
        return sol + self.joint_offsets

    def joint_torques(self, tau_motor) -> np.ndarray:
        """τ = Kᵀ τm for motor torques (N, n) [N·m]."""
        return np.asarray(tau_motor, float) @ self.motor_from_joint

    def joint_torques_from_currents(self, current) -> np.ndarray:
        """τ = Kᵀ (kt ⊙ i) for motor currents (N, n) [A]."""
        if self.torque_constants is None:
            raise ModelFileError(
                f"{self.source}: the recording gives motor currents (im1..), but the "
                "[transmission] table has no torque_constants; add torque_constants = [...] "
                "(N·m/A, one per motor)."
            )
        return self.joint_torques(np.asarray(current, float) * self.torque_constants)

    def joint_side(
        self, names, column, source: str = "the recording", prismatic: tuple = ()
    ) -> tuple:
        """Joint channels computed from a recording's motor-side channels.

        ``qm1..qmn`` (motor angles [rad]) give ``q1..qn`` = K⁻¹ θm + q0; ``taum1..taumn``
        (motor torques [N·m]) give ``tau1..taun`` = Kᵀ τm; ``im1..imn`` (motor currents [A])
        give ``tau1..taun`` = Kᵀ (kt ⊙ i). A prismatic joint's q is a length [m] and its
        τ a force [N] (K's entries for it in rad/m: a ball screw of lead ℓ turns 2π/ℓ).

        Parameters
        ----------
        names : sequence of str
            The recording's channel names.
        column : callable
            ``column(name) -> ndarray (n_samples,)``.
        source : str
            The recording (for messages).
        prismatic : sequence of bool, optional
            Per joint: is it prismatic (its channels in m and N; missing entries: revolute).

        Returns
        -------
        (dict, dict)
            New columns (name → ndarray) and their units ([rad] and [N·m], [m] and [N] for a
            prismatic joint); empty without motor channels.

        Raises
        ------
        ModelFileError
            Some motor channels of a kind but not all, both a motor-side and a joint-side
            channel of the same quantity, or currents without torque constants.
        """
        n = self.n_motors
        have = set(names)
        out, units = {}, {}
        linear = tuple(bool(x) for x in prismatic) + (False,) * (n - len(prismatic))
        kinds = (
            ("qm", "q", ("rad", "m")),
            ("taum", "tau", ("N·m", "N")),
            ("im", "tau", ("N·m", "N")),
        )
        for stem, target, unit in kinds:
            wanted = [f"{stem}{k + 1}" for k in range(n)]
            present = [w for w in wanted if w in have]
            if not present:
                continue
            if len(present) != n:
                missing = [w for w in wanted if w not in have]
                raise ModelFileError(
                    f"{source}: motor channels {present} are given but {missing} are not; the "
                    f"coupling (K, {n} × {n}) needs all {n} motors' {stem} channels."
                )
            clash = [f"{target}{k + 1}" for k in range(n) if f"{target}{k + 1}" in have]
            if stem == "im" and "taum1" in have:
                clash.append("taum1..")
            if clash:
                raise ModelFileError(
                    f"{source}: both motor-side {stem}1..{stem}{n} and {clash} are given for "
                    f"the same quantity; map one of them ({arg('channels')})."
                )
            data = np.column_stack([np.asarray(column(w), dtype=float) for w in wanted])
            if stem == "qm":
                joint = self.joint_positions(data)
            elif stem == "taum":
                joint = self.joint_torques(data)
            else:
                joint = self.joint_torques_from_currents(data)
            for j in range(n):
                out[f"{target}{j + 1}"] = joint[:, j]
                units[f"{target}{j + 1}"] = unit[linear[j]]
        return out, units


# ---------------------------------------------------------------------------------------------
# the [transmission] table
# ---------------------------------------------------------------------------------------------

_TOP = {"motor_from_joint", "gear_ratios", "joint_offsets", "torque_constants", "motors"}


def _numbers(value, key, n, where) -> np.ndarray:
    if not isinstance(value, list) or len(value) != n:
        got = f"{len(value)} values" if isinstance(value, list) else repr(value)
        raise ModelFileError(
            f"{where}: {key} must be a list of {n} numbers (one per joint); got {got}."
        )
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ModelFileError(f"{where}: {key} must hold finite numbers; got {v!r}.")
        out.append(float(v))
    return np.array(out)


def _coupling(table: dict, n: int, where: str) -> np.ndarray:
    """K of the table: ``motor_from_joint`` (n × n) or ``gear_ratios`` (diagonal), checked."""
    if "motor_from_joint" in table and "gear_ratios" in table:
        raise ModelFileError(
            f"{where}: give motor_from_joint (the coupling matrix) or gear_ratios (its "
            "diagonal), not both."
        )
    if "gear_ratios" in table:
        g = _numbers(table["gear_ratios"], "gear_ratios", n, where)
        zero = [j + 1 for j in range(n) if g[j] == 0]
        if zero:
            raise ModelFileError(
                f"{where}: gear_ratios has 0 for joint(s) {zero}; a gear ratio N (θm = N q) "
                "must be non-zero (negative for a motor turning the other way)."
            )
        return np.diag(g)
    if "motor_from_joint" not in table:
        raise ModelFileError(
            f"{where}: give motor_from_joint = [[...], ...] (θm = K q, {n} × {n}) or "
            "gear_ratios = [...]."
        )
    raw = table["motor_from_joint"]
    if not isinstance(raw, list) or len(raw) != n or not all(isinstance(r, list) for r in raw):
        raise ModelFileError(
            f"{where}: motor_from_joint must be {n} rows (one per motor) of {n} numbers (one "
            f"per joint), the matrix K of θm = K q; got "
            f"{len(raw) if isinstance(raw, list) else repr(raw)} rows."
        )
    K = np.array(
        [_numbers(r, f"motor_from_joint row {k + 1}", n, where) for k, r in enumerate(raw)]
    )
    s = np.linalg.svd(K, compute_uv=False)
    if s[-1] <= 1e-12 * max(s[0], 1e-300):
        zero = [k + 1 for k in range(n) if not np.any(K[k])]
        hint = f" (row(s) {zero} are all zero)" if zero else ""
        raise ModelFileError(
            f"{where}: motor_from_joint is singular{hint} (smallest singular value "
            f"{s[-1]:.3g}, largest {s[0]:.3g}): the motors cannot set every joint. Each joint "
            "needs a motor; check the rows (one per motor) and the gear ratios (non-zero)."
        )
    return K


def _motor_terms(table, n: int, where: str) -> tuple:
    """The ``[transmission.motors.motor_<k>]`` tables → `Transmission.terms`."""
    if not isinstance(table, dict):
        raise ModelFileError(
            f"{where}: motors must be tables [transmission.motors.motor_<k>] (k = 1..{n})."
        )
    terms = []
    for key, entry in table.items():
        w = f"{where} [transmission.motors.{key}]"
        if not (key.startswith("motor_") and key[6:].isdigit() and 1 <= int(key[6:]) <= n):
            raise ModelFileError(
                f"{w}: motor tables are named motor_1 .. motor_{n} (the rows of "
                f"motor_from_joint); got {key!r}."
            )
        k = int(key[6:]) - 1
        if not isinstance(entry, dict) or set(entry) - set(_TERM_PREFIX):
            raise ModelFileError(
                f"{w}: keys are {sorted(_TERM_PREFIX)}; each a parameter name (identified, "
                f'nominal 0; e.g. inertia = "Im{k + 1}") or a number (its nominal value, '
                f"named Im{k + 1} …); got {entry!r}."
            )
        for kind in _TERM_PREFIX:  # a fixed order: inertia, viscous, coulomb
            if kind not in entry:
                continue
            v = entry[kind]
            if isinstance(v, str) and v.isidentifier():
                terms.append((k, kind, v, 0.0))
            elif not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v):
                terms.append((k, kind, f"{_TERM_PREFIX[kind]}{k + 1}", float(v)))
            else:
                raise ModelFileError(
                    f'{w}: {kind} must be a parameter name (e.g. "{_TERM_PREFIX[kind]}{k + 1}") '
                    f"or a finite number; got {v!r}."
                )
    terms.sort(key=lambda t: (t[0], list(_TERM_PREFIX).index(t[1])))
    return tuple(terms)


def parse_transmission(table, joint_names, source: str, taken=()) -> Transmission:
    """Read a ``[transmission]`` table (already parsed TOML) for a chain's joints.

    Parameters
    ----------
    table : dict
        ``motor_from_joint`` (n × n, θm = K q) or ``gear_ratios`` (n), optional
        ``joint_offsets`` (n) [rad | m], ``torque_constants`` (n) [N·m/A] and
        ``motors.motor_<k>`` tables of motor-side terms (``inertia``, ``viscous``, ``coulomb``).
    joint_names : sequence of str
        The chain's joints (n).
    source : str
        The model file (for messages).
    taken : iterable of str
        Parameter names already used by the chain (a motor term may not reuse one).

    Returns
    -------
    Transmission

    Raises
    ------
    ModelFileError
        Unknown keys, a coupling matrix of the wrong size or singular, a gear ratio of 0, a
        torque constant of 0, a parameter name used twice.
    """
    where = f"{source} ([transmission])"
    if not isinstance(table, dict):
        raise ModelFileError(f"{where}: transmission must be a table.")
    bad = set(table) - _TOP
    if bad:
        raise ModelFileError(f"{where}: unknown key(s) {sorted(bad)}; allowed: {sorted(_TOP)}.")
    n = len(joint_names)
    K = _coupling(table, n, where)
    q0 = _numbers(table.get("joint_offsets", [0.0] * n), "joint_offsets", n, where)
    kt = None
    if "torque_constants" in table:
        kt = _numbers(table["torque_constants"], "torque_constants", n, where)
        if np.any(kt == 0):
            raise ModelFileError(
                f"{where}: torque_constants has 0 for motor(s) "
                f"{[k + 1 for k in range(n) if kt[k] == 0]}; a motor's kt (N·m/A) is non-zero."
            )
    terms = _motor_terms(table.get("motors", {}), n, where)
    names = [t[2] for t in terms]
    dup = sorted({s for s in names if names.count(s) > 1} | (set(names) & set(taken)))
    if dup:
        raise ModelFileError(
            f"{where}: parameter name(s) {dup} used twice; give each motor term its own name."
        )
    return Transmission(K, q0, kt, terms, source)


def attach_transmission(chain, table, source: str):
    """``chain`` (a `physid.models.rigid.RigidChain`) driven through the ``[transmission]``
    table ``table`` (see `parse_transmission`); the chain itself when ``table`` is None.

    Parameters
    ----------
    chain : RigidChain
    table : dict or None
    source : str

    Returns
    -------
    RigidChain
    """
    import dataclasses

    if table is None:
        return chain
    names = [chain.joint_names[i] for i in chain.independent]  # the model's coordinates
    tr = parse_transmission(table, names, source, taken=chain.parameter_names())
    return dataclasses.replace(chain, transmission=tr)
