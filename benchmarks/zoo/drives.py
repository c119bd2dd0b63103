"""Two simulators of the zoo written from their equations (numpy only; no physid, no pinocchio).

* `LinearDrive`: a carriage of mass M on a prismatic axis (EMPS-like, Janot, Gautier, Brunot
  2019), viscous friction Fv and asymmetric Coulomb friction (Fc+ resists motion in +x, Fc− in
  −x; at rest the carriage sticks while the applied force lies in [Fc−, Fc+]). The force is held
  over each controller period (zero-order hold) and the motion between the controller's samples
  is integrated *exactly*: with a constant force F and a constant friction branch the equation
  M v̇ = F − Fv v − Fc± has the solution v(t) = v∞ + (v0 − v∞) e^(−t/T), T = M/Fv,
  v∞ = (F − Fc±)/Fv, and the instant where v reaches 0 is an event (t0 = T ln((v0 − v∞)/(−v∞)));
  there the carriage sticks (v = 0 exactly) or slides on the other branch.
* `TwoLink`: a 2-link planar arm moving in a vertical plane (both joint axes along y, links along
  x, gravity along −z), equations of motion derived by hand (Lagrange, below), rotor inertia
  reflected through the gear, Stribeck friction per joint with the sign smoothed as
  tanh(q̇/ε) (ε small: creeps instead of sticking), integrated by fixed-step RK4 with the torque
  held over each controller period.

Both come with a URDF writer (`*.urdf(path)`), which the recipe (pinocchio) and physid read;
`tests/test_zoo_cases.py` checks the arm's torques against pinocchio's inverse dynamics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

G = 9.81  # m/s², along −z


# ----------------------------------------------------------------------------- linear drive
@dataclass(frozen=True)
class LinearDrive:
    """Carriage mass [kg], viscous [N·s/m], Coulomb for +x / −x motion [N] (Fc− < 0)."""

    mass: float = 95.0
    viscous: float = 200.0
    coulomb_pos: float = 20.0
    coulomb_neg: float = -17.0

    @property
    def coulomb(self) -> float:
        """The symmetric part: Fc sign(v) + offset equals Fc+ (v > 0) and Fc− (v < 0)."""
        return 0.5 * (self.coulomb_pos - self.coulomb_neg)

    @property
    def offset(self) -> float:
        return 0.5 * (self.coulomb_pos + self.coulomb_neg)

    def step(self, x: float, v: float, force: float, h: float) -> tuple[float, float]:
        """Exact motion over h [s] under a constant force [N] from (x [m], v [m/s])."""
        T = self.mass / self.viscous
        left = h
        for _ in range(4):  # at most: slide, stop, (stick | slide back): 3 segments
            if left <= 0.0:
                break
            if v == 0.0:
                if self.coulomb_neg <= force <= self.coulomb_pos:
                    return x, 0.0  # sticks: static friction balances the force
                direction = 1.0 if force > self.coulomb_pos else -1.0
            else:
                direction = 1.0 if v > 0 else -1.0
            fric = self.coulomb_pos if direction > 0 else self.coulomb_neg
            v_inf = (force - fric) / self.viscous
            t_stop = math.inf
            if v_inf * direction < 0.0:  # decelerates towards the opposite branch: v hits 0
                t_stop = T * math.log((v - v_inf) / (-v_inf))
            dt = min(left, t_stop)
            e = math.exp(-dt / T)
            x = x + v_inf * dt + (v - v_inf) * T * (1.0 - e)
            v = 0.0 if dt == t_stop else v_inf + (v - v_inf) * e
            left -= dt
        return x, v

    def simulate(self, r, h, kp, kd, resolution, gain, volt_max=10.0):
        """PD position loop at period h [s]: u = (Kp (r − x̃) − Kd ṽ)/gain [V], x̃ the encoder's
        quantised position (step ``resolution`` [m]), ṽ its backward difference; the force
        gain·u [N] (u clipped to ±volt_max) is held over the period. Starts at rest at r[0].
        Returns the true x, v, the encoder x̃ and the voltage u at the samples (n,)."""
        n = r.size
        X, V, Xq, U = (np.empty(n) for _ in range(4))
        x, v = float(r[0]), 0.0
        xq_prev = round(x / resolution) * resolution
        for k in range(n):
            xq = round(x / resolution) * resolution
            vq = (xq - xq_prev) / h
            u = (kp * (r[k] - xq) - kd * vq) / gain
            u = min(max(u, -volt_max), volt_max)
            X[k], V[k], Xq[k], U[k] = x, v, xq, u
            x, v = self.step(x, v, gain * u, h)
            xq_prev = xq
        return X, V, Xq, U

    def urdf(self, path: Path) -> Path:
        """A URDF of the carriage: one horizontal prismatic joint along x (gravity ⟂ axis)."""
        text = f"""<?xml version="1.0"?>
<robot name="linear_drive">
  <link name="base"/>
  <link name="carriage">
    <inertial><origin xyz="0 0 0.05" rpy="0 0 0"/><mass value="{self.mass}"/>
      <inertia ixx="1.0" ixy="0" ixz="0" iyy="1.0" iyz="0" izz="1.0"/></inertial>
  </link>
  <joint name="axis" type="prismatic">
    <parent link="base"/><child link="carriage"/>
    <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-0.1" upper="0.3" effort="400" velocity="1"/>
  </joint>
</robot>
"""
        Path(path).write_text(text, encoding="utf-8")
        return Path(path)


# ----------------------------------------------------------------------------- 2-link arm
@dataclass(frozen=True)
class TwoLink:
    """Links: mass [kg], length [m], centre of mass along the link [m], inertia about the
    centre of mass about y [kg·m²]; drives: gear ratio, torque constant [N·m/A], rotor inertia
    [kg·m², motor side]; joint-side friction: Coulomb Fc, static Fs [N·m], Stribeck velocity vs
    [rad/s], viscous Fv [N·m·s/rad], sign smoothing ε [rad/s]."""

    m: tuple = (2.0, 1.0)
    length: tuple = (0.4, 0.3)
    lc: tuple = (0.2, 0.15)
    inertia: tuple = (0.03, 0.01)
    ratio: float = 100.0
    kt: float = 0.05
    rotor: tuple = (2.0e-5, 1.0e-5)
    fc: tuple = (1.5, 0.8)
    fs: tuple = (2.2, 1.2)
    vs: tuple = (0.05, 0.05)
    fv: tuple = (1.0, 0.5)
    eps: float = 1e-3

    @property
    def armature(self) -> np.ndarray:
        """Reflected rotor inertia N² Jm [kg·m²]."""
        return self.ratio**2 * np.asarray(self.rotor)

    def mass_matrix(self, q):
        """M(q) (n, 2, 2) with the rotor inertias. Lagrange, for x1 = lc1 (cos q1, −sin q1) in
        the (x, z) plane (a rotation about +y turns x towards −z) and x2 = l1 (cos q1, −sin q1)
        + lc2 (cos q12, −sin q12): the classic planar 2R form."""
        q = np.atleast_2d(q)
        m1, m2 = self.m
        l1 = self.length[0]
        c1, c2 = self.lc
        i1, i2 = self.inertia
        ia = self.armature
        cq2 = np.cos(q[:, 1])
        M = np.empty((q.shape[0], 2, 2))
        M[:, 0, 0] = i1 + i2 + m1 * c1**2 + m2 * (l1**2 + c2**2 + 2 * l1 * c2 * cq2) + ia[0]
        M[:, 0, 1] = M[:, 1, 0] = i2 + m2 * (c2**2 + l1 * c2 * cq2)
        M[:, 1, 1] = i2 + m2 * c2**2 + ia[1]
        return M

    def bias(self, q, qd):
        """Coriolis, centrifugal and gravity torques (n, 2): h = −m2 l1 lc2 sin q2,
        c = [h (2 q̇1 q̇2 + q̇2²), −h q̇1²], g = ∂V/∂q with V = g Σ m z
        (z1 = −lc1 sin q1, z2 = −l1 sin q1 − lc2 sin q12)."""
        q, qd = np.atleast_2d(q), np.atleast_2d(qd)
        m1, m2 = self.m
        l1 = self.length[0]
        c1, c2 = self.lc
        h = -m2 * l1 * c2 * np.sin(q[:, 1])
        c12 = np.cos(q[:, 0] + q[:, 1])
        out = np.empty_like(q, dtype=float)
        out[:, 0] = h * (2 * qd[:, 0] * qd[:, 1] + qd[:, 1] ** 2)
        out[:, 1] = -h * qd[:, 0] ** 2
        out[:, 0] += -G * ((m1 * c1 + m2 * l1) * np.cos(q[:, 0]) + m2 * c2 * c12)
        out[:, 1] += -G * m2 * c2 * c12
        return out

    def friction(self, qd):
        """Stribeck: (Fc + (Fs − Fc) exp(−(q̇/vs)²)) tanh(q̇/ε) + Fv q̇ per joint (n, 2)."""
        qd = np.atleast_2d(qd)
        fc, fs, vs, fv = (np.asarray(a, float) for a in (self.fc, self.fs, self.vs, self.fv))
        return (fc + (fs - fc) * np.exp(-((qd / vs) ** 2))) * np.tanh(qd / self.eps) + fv * qd

    def inverse_dynamics(self, q, qd, qdd, friction=True):
        """τ = M(q) q̈ + c(q, q̇) + g(q) [+ friction] (n, 2) [N·m], rotor inertia included."""
        qdd = np.atleast_2d(qdd)
        tau = np.einsum("nij,nj->ni", self.mass_matrix(q), qdd) + self.bias(q, qd)
        return tau + self.friction(qd) if friction else tau

    def _acc(self, q, qd, tau):
        """q̈ = M⁻¹ (τ − c − g − friction) for one state (scalars: this is the inner loop)."""
        m1, m2 = self.m
        l1 = self.length[0]
        c1, c2 = self.lc
        i1, i2 = self.inertia
        ia1, ia2 = self.armature
        s2, cq2 = math.sin(q[1]), math.cos(q[1])
        a11 = i1 + i2 + m1 * c1 * c1 + m2 * (l1 * l1 + c2 * c2 + 2 * l1 * c2 * cq2) + ia1
        a12 = i2 + m2 * (c2 * c2 + l1 * c2 * cq2)
        a22 = i2 + m2 * c2 * c2 + ia2
        h = -m2 * l1 * c2 * s2
        c12 = math.cos(q[0] + q[1])
        f = []
        for j in range(2):
            v = qd[j]
            st = self.fc[j] + (self.fs[j] - self.fc[j]) * math.exp(-((v / self.vs[j]) ** 2))
            f.append(st * math.tanh(v / self.eps) + self.fv[j] * v)
        b1 = tau[0] - h * (2 * qd[0] * qd[1] + qd[1] ** 2)
        b1 -= -G * ((m1 * c1 + m2 * l1) * math.cos(q[0]) + m2 * c2 * c12) + f[0]
        b2 = tau[1] + h * qd[0] ** 2 + G * m2 * c2 * c12 - f[1]
        det = a11 * a22 - a12 * a12  # 2×2 solve by Cramer's rule (M is well conditioned)
        return ((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det)

    def simulate(self, r, h, kp, kd, counts, substeps=2, i_max=5.0, settle=1.0):
        """PD loop at period h [s] on the joint side, τ = Kp (r − q̃) − Kd ṽ, q̃ the motor
        encoder (``counts`` per motor turn) through the gear, ṽ its backward difference; the
        commanded current i = τ/(N kt) (clipped to ±i_max [A]) is held over the period and
        the joints move by RK4 (``substeps`` per period). Starts at rest at r[0] and holds it
        for ``settle`` s. Returns true q, q̇ (n, 2), motor angles θm = N q̃ (n, 2) and the
        current (n, 2)."""
        n = r.shape[0]
        step = 2 * np.pi / counts / self.ratio  # joint-side encoder step [rad]
        Q, V, TH, CUR = (np.empty((n, 2)) for _ in range(4))
        q, qd = [float(r[0, 0]), float(r[0, 1])], [0.0, 0.0]
        qq_prev = [round(x / step) * step for x in q]
        dt = h / substeps
        kn = self.ratio * self.kt
        for k in range(-round(settle / h), n):
            rk = r[max(k, 0)]
            qq = [round(x / step) * step for x in q]
            cur = []
            for j in range(2):
                tj = kp[j] * (rk[j] - qq[j]) - kd[j] * (qq[j] - qq_prev[j]) / h
                cur.append(min(max(tj / kn, -i_max), i_max))
            tau = (kn * cur[0], kn * cur[1])
            if k >= 0:
                Q[k], V[k], TH[k], CUR[k] = q, qd, (self.ratio * qq[0], self.ratio * qq[1]), cur
            for _ in range(substeps):  # RK4 with τ held
                a1 = self._acc(q, qd, tau)
                q2 = [q[j] + 0.5 * dt * qd[j] for j in (0, 1)]
                v2 = [qd[j] + 0.5 * dt * a1[j] for j in (0, 1)]
                a2 = self._acc(q2, v2, tau)
                q3 = [q[j] + 0.5 * dt * v2[j] for j in (0, 1)]
                v3 = [qd[j] + 0.5 * dt * a2[j] for j in (0, 1)]
                a3 = self._acc(q3, v3, tau)
                q4 = [q[j] + dt * v3[j] for j in (0, 1)]
                v4 = [qd[j] + dt * a3[j] for j in (0, 1)]
                a4 = self._acc(q4, v4, tau)
                q = [q[j] + dt / 6 * (qd[j] + 2 * v2[j] + 2 * v3[j] + v4[j]) for j in (0, 1)]
                qd = [qd[j] + dt / 6 * (a1[j] + 2 * a2[j] + 2 * a3[j] + a4[j]) for j in (0, 1)]
            qq_prev = qq
        return Q, V, TH, CUR

    def urdf(self, path: Path) -> Path:
        """The arm as a URDF: joint axes along y, link j along x, centre of mass on the link.
        Only iyy acts in the plane; ixx, izz are given values a real link has."""
        m1, m2 = self.m
        (l1, _), (c1, c2), (i1, i2) = self.length, self.lc, self.inertia
        text = f"""<?xml version="1.0"?>
<robot name="two_link">
  <link name="base"/>
  <link name="link1">
    <inertial><origin xyz="{c1} 0 0" rpy="0 0 0"/><mass value="{m1}"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="{i1}" iyz="0" izz="{i1 - 0.001}"/></inertial>
  </link>
  <link name="link2">
    <inertial><origin xyz="{c2} 0 0" rpy="0 0 0"/><mass value="{m2}"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="{i2}" iyz="0" izz="{i2 - 0.0005}"/></inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="link1"/>
    <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-3.1" upper="3.1" effort="25" velocity="3"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="link1"/><child link="link2"/>
    <origin xyz="{l1} 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-3.1" upper="3.1" effort="25" velocity="3"/>
  </joint>
</robot>
"""
        Path(path).write_text(text, encoding="utf-8")
        return Path(path)
